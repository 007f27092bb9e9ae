"""The store of an unwindowed negation keeps only what can still block a match: a negated
event that ended before every later event can start (delay bound, longest interval seen) and
outside the retraction horizon is dropped with the waiting partial matches it blocks for
good. The oracle is the same program without that sweep: same output for any stream that
respects the delay bound, in any arrival order within it, with interval events and
deletions; and the store stays flat on a long stream."""
import random
import re

import pytest
from hypothesis import given, settings, HealthCheck
from hypothesis import strategies as st

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine

RULES = [
    "cn(I, X, Y) <- (a(I, X) seq b(I, Y)) cnot c(I, _).",
    "nt(I, X, Y) <- not(c(I, _)).[a(I, X), b(I, Y)].",
    "nk(I, X, Y) <- not(c(_, X)).[a(I, X), b(I, Y)].",      # key only on the left
    "nr(I, X, Y) <- not(c(Y, _)).[a(I, X), b(I, Y)].",      # key on the right: never swept
]
POLICIES = ("recent", "chronological", "unrestricted")
DELAY = 2.0


def program(policy: str, rules=RULES) -> str:
    return f":- set_etalis_flag(event_consumption_policy, {policy}).\n" + "\n".join(rules) + "\n"


def without_sweep(prolog: str) -> str:
    return re.sub(r"^ele_forget_blockers\(Before[^\n]*\n(?:[ \t][^\n]*\n)*", "", prolog, flags=re.M)


def load(policy: str, sweep: bool, rules=RULES, tag: str = "") -> Engine:
    result = compile_source(program(policy, rules), f"negation_{policy}_{sweep}{tag}.rtl",
                            module=f"negation_{policy}_{'sweep' if sweep else 'keep'}{tag}")
    if not sweep:
        assert "ele_forget_blockers(Before" in result.prolog
        result.prolog = without_sweep(result.prolog)
        assert "ele_forget_blockers(Before" not in result.prolog
    engine = Engine.from_compiled(result)
    engine.set_flag("max_delay", repr(DELAY))
    return engine


@pytest.fixture(scope="module")
def engines():
    return {(policy, sweep): load(policy, sweep) for policy in POLICIES for sweep in (True, False)}


def run(engine: Engine, items):
    engine.activate()            # one program per process: the fixture loaded six
    engine.clear()
    engine.set_flag("max_delay", repr(DELAY))
    out = []
    for k in range(0, len(items), 50):
        out += [(e.event, e.start, e.end, e.op) for e in engine.feed_batch(items[k:k + 50])]
    return out, engine.store_size()


@st.composite
def streams(draw):
    """Events half a time unit apart, some of them intervals, each arriving up to 1.5 time
    units late (the delay bound is 2), some deleted later."""
    rng = random.Random(draw(st.integers(0, 10**6)))
    n = draw(st.integers(150, 400))
    events = []
    for k in range(1, n + 1):
        t = k / 2
        kind = rng.choice("aabbc")
        start = t - (rng.choice([0, 0, 0, 0.5, 4]) if kind != "c" else rng.choice([0, 0, 1]))
        events.append((f"{kind}({rng.randint(1, 2)}, {rng.randint(1, 3)})", start, t))
    arrival = sorted(events, key=lambda e: e[2] + rng.uniform(0, DELAY - 0.5))
    items = list(arrival)
    with_deletions = []
    for k, item in enumerate(items):
        with_deletions.append(item)
        if k % 17 == 0:         # a deletion arrives right after the event, inside the horizon
            with_deletions.append((item[0], item[1], item[2], "retract"))
    return with_deletions


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(stream=streams(), policy=st.sampled_from(POLICIES))
def test_the_sweep_changes_no_output(engines, stream, policy):
    swept, _ = run(engines[(policy, True)], stream)
    kept, _ = run(engines[(policy, False)], stream)
    assert swept == kept


def long_stream(n: int, seed: int = 3):
    rng = random.Random(seed)
    return [(f"{rng.choice('abc')}({rng.randint(1, 20)}, {rng.randint(1, 20)})", t) for t in range(1, n + 1)]


@pytest.mark.parametrize("policy", ["recent", "unrestricted"])
def test_the_store_stays_flat_on_a_long_stream(policy):
    # (the last rule's blockers share only the right side's variables: its store is not swept)
    swept, kept = load(policy, True, RULES[:3], "_flat"), load(policy, False, RULES[:3], "_flat")
    stream = long_stream(6_000)
    _, size_short = run(swept, stream[:1_500])
    _, size_long = run(swept, stream)
    _, size_kept = run(kept, stream)
    if policy == "recent":
        assert size_long < size_kept / 3, (size_short, size_long, size_kept)
        assert size_long <= 1.5 * size_short + 50, (size_short, size_long)
    else:                           # unrestricted keeps every unblocked left and right, by definition
        assert size_long < size_kept / 2, (size_short, size_long, size_kept)


SWEEP_COUNT = """\
:- use_module(retalis_runtime(retalis)).
:- dynamic sweeps/1.
sweeps(0).
count_sweeps(Before) :-
    retract(sweeps(N)), N1 is N + 1, assertz(sweeps(N1)),
    nb_getval(rtl_clock, Clock), nb_getval(rtl_longest_event, Longest),
    assertz(sweep_at(Clock, Longest, Before)).
:- dynamic sweep_at/3.
main :-
    M = negation_sweeps,
    asserta(M:(ele_forget_blockers(Before) :- user:count_sweeps(Before), fail)),
    rtl_output_to(buffer),
    rtl_input(add, z(1), 0, 500),           % an interval: later events may start 500 s earlier
    forall(between(501, 3500, T),
           ( K is T mod 3, I is T mod 7,
             ( K =:= 0 -> E = a(I, T) ; K =:= 1 -> E = b(I, T) ; E = c(I, T) ),
             rtl_input(add, E, T, T), rtl_take_output(_) )),
    sweeps(N), rtl_flag(max_delay, Delay), rtl_horizon(Horizon),
    findall(C-L, sweep_at(C, L, _), At),
    format("~w ~w ~w ~q~n", [N, Delay, Horizon, At]).
"""


def test_the_blockers_are_swept_once_the_clock_moved_half_of_what_they_keep(tmp_path, swipl):
    # The compiled sweep visits every stored negated event: it runs when the clock has moved on
    # by half of max(delay + longest interval, horizon) since the last one, not at every sweep
    # of the stores (every 64 events here, each visiting hundreds of negated events kept for the
    # longest interval seen, 500 s).
    import subprocess
    result = compile_source(program("recent", RULES[:1]), "negation_sweeps.rtl", module="negation_sweeps")
    (tmp_path / "p.pl").write_text(result.prolog)
    (tmp_path / "count.pl").write_text(SWEEP_COUNT)
    done = subprocess.run([swipl, "-g", "consult(count), main, halt", str(tmp_path / "p.pl"), "--none"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    count, delay, horizon, at = done.stdout.split(" ", 3)
    sweeps = [tuple(map(float, pair.split("-"))) for pair in at.strip()[1:-1].split(",")]
    assert int(count) == len(sweeps) >= 3
    for (clock0, longest0), (clock1, _) in zip(sweeps, sweeps[1:]):
        assert clock1 - clock0 >= max(float(delay) + longest0, float(horizon)) / 2
    assert int(count) < 3000 / 64 / 2
