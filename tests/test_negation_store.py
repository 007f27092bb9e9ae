"""The store of an unwindowed negation keeps only what can still block a match: a negated
event that ended before every later right operand can start (delay bound, longest interval of
that type seen so far) and
outside the retraction horizon is dropped with the waiting partial matches it blocks for
good. The oracle is the same program without that sweep: same output for any stream that
respects the delay bound, in any arrival order within it, with interval events and
deletions; and the store stays flat on a long stream."""
import json
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
    return re.sub(r"^ele_forget_blockers\(Clock[^\n]*\n(?:[ \t][^\n]*\n)*", "", prolog, flags=re.M)


def load(policy: str, sweep: bool, rules=RULES, tag: str = "") -> Engine:
    result = compile_source(program(policy, rules), f"negation_{policy}_{sweep}{tag}.rtl",
                            module=f"negation_{policy}_{'sweep' if sweep else 'keep'}{tag}")
    if not sweep:
        assert "ele_forget_blockers(Clock" in result.prolog
        result.prolog = without_sweep(result.prolog)
        assert "ele_forget_blockers(Clock" not in result.prolog
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
    # (from 3,000 events on: before, the waiting rights, at most one per key and value under
    # `recent`, 20 x 20 per rule, are still filling up)
    _, size_short = run(swept, stream[:3_000])
    _, size_long = run(swept, stream)
    _, size_kept = run(kept, stream)
    if policy == "recent":
        assert size_long < size_kept / 3, (size_short, size_long, size_kept)
        assert size_long <= 1.5 * size_short + 50, (size_short, size_long)
    else:                           # unrestricted keeps every unblocked left and right, by definition
        assert size_long < size_kept / 2, (size_short, size_long, size_kept)


SWEEP_COUNT = """\
:- use_module(retalis_runtime(retalis)).
:- use_module(library(assoc)).
:- dynamic sweep_at/4.
count_sweeps(_) :-
    nb_getval(rtl_clock, Clock),
    nb_getval(rtl_longest_by_type, ByType),
    ( get_assoc(b/2, ByType, Longest) -> true ; Longest = 0 ),
    ( nb_current('rtl_blockers_due e_r1_1', Due) -> true ; Due = null ),
    predicate_property(negation_sweeps:e_r1_1_negs(_, _, _, _, _), number_of_clauses(Negs)),
    assertz(sweep_at(Clock, Longest, Due, Negs)).
main(Interval) :-
    M = negation_sweeps,
    asserta(M:(ele_forget_blockers(Clock) :- user:count_sweeps(Clock), fail)),
    rtl_output_to(buffer),
    rtl_input(add, Interval, 0, 500),       % an interval: 500 s long
    forall(between(501, 3500, T),
           ( K is T mod 3, I is T mod 7,
             ( K =:= 0 -> E = a(I, T) ; K =:= 1 -> E = b(I, T) ; E = c(I, T) ),
             rtl_input(add, E, T, T), rtl_take_output(_) )),
    rtl_flag(max_delay, Delay), rtl_horizon(Horizon),
    findall([C, L, D, N], sweep_at(C, L, D, N), At),
    format("~w ~w ~q~n", [Delay, Horizon, At]).
"""


def sweeps(tmp_path, swipl, interval: str):
    import subprocess
    result = compile_source(program("recent", RULES[:1]), "negation_sweeps.rtl", module="negation_sweeps")
    (tmp_path / "p.pl").write_text(result.prolog)
    (tmp_path / "count.pl").write_text(SWEEP_COUNT)
    done = subprocess.run([swipl, "-g", f"consult(count), main({interval}), halt", str(tmp_path / "p.pl"), "--none"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    delay, horizon, at = done.stdout.split(" ", 2)
    # at each sweep of the stores, before the blockers' own clause: clock, longest B, when
    # the blockers' sweep is due (set by the last one), negated events stored
    offers = [tuple(offer) for offer in json.loads(at)]
    return float(delay), float(horizon), offers


def test_the_blockers_are_swept_once_the_clock_moved_half_of_what_they_keep(tmp_path, swipl):
    # The compiled sweep visits every stored negated event, so it runs when the clock has moved
    # on by half of what it keeps, max(delay + longest interval of a B, horizon), since the last
    # one: here every 250 s (a B of 500 s was seen), not at each sweep of the stores.
    delay, horizon, offers = sweeps(tmp_path, swipl, "b(1, 0)")
    assert len(offers) > 3000 / 64 - 5                  # the stores are swept every 64 events
    assert offers[-1][1] == 500
    taken = [(prev, cur) for prev, cur in zip(offers, offers[1:]) if cur[2] != prev[2]]
    assert 3000 / 250 - 2 <= len(taken) <= 3000 / 250 + 1
    for prev, cur in taken:
        clock, longest, due, _ = prev
        assert prev[2] is None or clock >= prev[2]
        assert cur[2] == clock + max(delay + longest, horizon) / 2
    # what it keeps stays bounded: a third of the events are negated, kept at most 1.5 * 501 s
    assert max(n for *_, n in offers) <= 1.5 * 501 / 3 + 64


def test_a_long_interval_of_another_event_does_not_delay_the_sweep(tmp_path, swipl):
    # What a blocker must wait for is how early a later B can start: a long interval of
    # another event (here z, as a long derived event would be) does not make it wait.
    delay, horizon, offers = sweeps(tmp_path, swipl, "z(1)")
    assert all(longest == 0 for _, longest, _, _ in offers)
    taken = [cur for prev, cur in zip(offers, offers[1:]) if cur[2] != prev[2]]
    assert len(taken) >= len(offers) - 2
    assert max(n for *_, n in offers[1:]) <= 64


def test_a_right_operand_longer_than_any_before_it_that_starts_before_a_sweep_is_counted_late():
    """No longest interval is known in advance: a b spanning 300 time units, on time, starts
    before the blockers a sweep dropped (with the waiting a they blocked for good). The match
    it would have made is missing, and the run says so by counting it late; without the
    sweep it is there and nothing is late."""
    rule = ["nt(I, X, Y) <- not(c(I, _)).[a(I, X), b(I, Y)]."]
    items = [("a(1, 1)", 1, 1), ("c(1, 1)", 3, 3)] + [(f"d({k})", 3 + k, 3 + k) for k in range(1, 300)]
    items.append(("b(1, 7)", 2, 302))
    results = {}
    for sweep in (True, False):
        engine = load("unrestricted", sweep, rule, tag="_long_b")
        out, _ = run(engine, items)
        results[sweep] = ([e for e in out if e[0].startswith("nt(")], engine.stats()["late"])
    assert results[False] == ([("nt(1,1,7)", 1, 302, "add")], 0)
    assert results[True] == ([], 1)
