"""ELE at the edges: partial matches are the events themselves (`_` is not a
wildcard that merges different events), retractions inside the retraction horizon are exact
for every operator, retractions outside it are reported, and late blockers take back what
they block while it is inside the horizon."""
import pytest

from retalisc.driver.engine import Engine

from ele_oracle import net_output


def outputs(engine, batch):
    return [(o.event, o.start, o.end, o.op) for o in engine.feed_batch(batch)]


def fresh(engine, max_delay="inf"):
    engine.clear()
    engine.set_flag("max_delay", max_delay)
    return engine


# ---- 1. `_` under the consumption policies ------------------------------------------------

RECENT_ANONYMOUS = """
:- set_etalis_flag(event_consumption_policy, recent).
c(K) <- a(K, _) seq b(K).
"""
RECENT_NAMED = """
:- set_etalis_flag(event_consumption_policy, recent).
c(K) <- a(K, V) seq b(K).
"""
ISSUE_STREAM = [("a(1, 10)", 1), ("a(1, 20)", 2), ("b(1)", 3), ("b(1)", 4)]


@pytest.mark.parametrize("program", [RECENT_ANONYMOUS, RECENT_NAMED], ids=["anonymous", "named"])
def test_recent_does_not_take_different_events_for_twins(program):
    """The minimal case: a(1,10) and a(1,20) are different events, so neither replaces
    the other; b(1)@3 takes the newest, b(1)@4 the other (as ETALIS derives)."""
    engine = fresh(Engine.from_source(program, "twins.rtl"))
    assert outputs(engine, ISSUE_STREAM) == [("c(1)", 2, 3, "add"), ("c(1)", 1, 4, "add")]


def test_recent_still_replaces_an_identical_twin():
    engine = fresh(Engine.from_source(RECENT_ANONYMOUS, "twins.rtl"))
    stream = [("a(1, 10)", 1), ("a(1, 10)", 2), ("b(1)", 3), ("b(1)", 4)]
    assert outputs(engine, stream) == [("c(1)", 2, 3, "add")]


def test_recent_does_not_take_events_of_the_two_branches_of_an_or_for_twins():
    """A partial match from one branch of an `or` leaves the other branch's variables unbound;
    it is not a twin of one from the other branch (that merely unifies with it)."""
    program = ":- set_etalis_flag(event_consumption_policy, recent).\nr(K) <- (d(K, _) or c(K, _)) seq b(K).\n"
    engine = fresh(Engine.from_source(program, "or_twins.rtl"))
    stream = [("d(1, 1)", 1), ("c(1, 2)", 2), ("b(1)", 3), ("b(1)", 4), ("d(1, 1)", 5), ("d(1, 1)", 6), ("b(1)", 7),
              ("b(1)", 8)]
    # d(1, 1)@6 replaces its true twin d(1, 1)@5: b(1)@8 finds nothing
    assert outputs(engine, stream) == [("r(1)", 2, 3, "add"), ("r(1)", 1, 4, "add"), ("r(1)", 6, 7, "add")]


@pytest.mark.parametrize("policy", ["recent", "chronological", "unrestricted"])
@pytest.mark.parametrize("pattern, stream, bogus", [
    # a join: the partner of b(1) differs only in the unnamed argument
    ("c(K) <- a(K, _) seq b(K).", [("a(1, 10)", 1), ("a(1, 20)", 2), ("b(1)", 3), ("b(1)", 4)], ("a(1, 30)", 2)),
    # a negation: the blocker of the pair, and one that differs only in the unnamed argument
    ("c(K) <- not(n(K, _)).[a(K), b(K)].", [("a(1)", 1), ("n(1, 5)", 2), ("b(1)", 3)], ("n(1, 6)", 2)),
    # fnot: the same
    ("c(K) <- a(K) fnot n(K, _).", [("n(1, 5)", 1), ("a(1)", 2)], ("n(1, 6)", 1)),
    # an aggregate over events that differ only in the unnamed argument
    ("c(K, N) <- a(K, _) seq aggregate(count, b(K, _), N).", [("a(1, 1)", 1), ("b(1, 5)", 2), ("b(1, 6)", 2)],
     ("a(1, 2)", 1)),
])
def test_naming_an_unused_variable_changes_nothing(policy, pattern, stream, bogus):
    """Same program with `_` and with named variables: the same output, and deleting an event
    that was never added, which differs from an added one only in the unnamed argument,
    changes nothing."""
    named = pattern
    for n in range(pattern.count("_")):
        named = named.replace("_", f"Unused{n}", 1)
    results = []
    for rule in (pattern, named):
        program = f":- set_etalis_flag(event_consumption_policy, {policy}).\n{rule}\n"
        engine = fresh(Engine.from_source(program, "named.rtl"))
        added = outputs(engine, stream)
        after_bogus = outputs(engine, [(bogus[0], bogus[1], bogus[1], "retract")])
        results.append((added, after_bogus))
    assert results[0] == results[1]
    assert results[0][1] == []


# ---- 2. the retraction horizon ----------------------------------------------------------

ISSUE_SEQ = "s(X) <- (a(X) seq b(X)).5.\n"


def issue_lines(k):
    lines = ['{"event": "a(1)", "t": 1}', '{"event": "b(1)", "t": 2}']
    lines += [f'{{"event": "b(9)", "t": {t}}}' for t in range(3, 3 + k)]
    return lines + ['{"event": "a(1)", "t": 1, "op": "retract"}']


@pytest.fixture(scope="module")
def issue_engine():
    return Engine.from_source(ISSUE_SEQ, "issue_seq.rtl")


@pytest.mark.parametrize("k", list(range(1, 10)) + [20, 25])
def test_a_retraction_inside_the_horizon_is_exact_and_one_outside_is_reported(issue_engine, k):
    """A case: window 5 + delay bound 1 = horizon 6. a(1)@1 is deleted when the
    clock is 2 + k: exact while 1 >= 2 + k - 6 (k <= 5), reported on its line after that."""
    engine = fresh(issue_engine, "1")
    lines = issue_lines(k)
    produced, rejected = engine.feed_lines("\n".join(lines))
    warnings = engine.take_warnings()
    retracts = [(o.event, o.start, o.end) for o in produced if o.op == "retract"]
    assert rejected == []
    if k <= 5:
        assert retracts == [("s(1)", 1, 2)] and warnings == []
        assert (engine.stats()["retracted"], engine.stats()["too_late"]) == (1, 0)
    else:
        assert retracts == []
        assert [w.line for w in warnings] == [len(lines)]
        # exact while nothing it could need was forgotten; "at least" once something was (the
        # kept generation holding a(1)@1 and b(1)@2 is emptied by the sweep at 25)
        expected = "1" if k <= 20 else "at least 0"
        assert warnings[0].text == f"retraction too late: {expected} derived events not retracted"
        assert (engine.stats()["retracted"], engine.stats()["too_late"]) == (0, 1)


def test_the_retraction_horizon_can_be_lengthened(issue_engine):
    engine = fresh(issue_engine, "1")
    engine.set_flag("retraction_horizon", "40")
    try:
        produced, _ = engine.feed_lines("\n".join(issue_lines(30)))
    finally:
        engine.set_flag("retraction_horizon", "auto")
    assert [(o.event, o.op) for o in produced if o.op == "retract"] == [("s(1)", "retract")]
    assert engine.take_warnings() == []


def test_the_horizon_is_infinite_when_nothing_is_forgotten():
    engine = fresh(Engine.from_source("s(X) <- a(X) seq b(X).\n", "nowindow.rtl"), "1")
    lines = issue_lines(200)
    produced, _ = engine.feed_lines("\n".join(lines))
    assert [(o.event, o.op) for o in produced if o.op == "retract"] == [("s(1)", "retract")]
    assert engine.take_warnings() == []


@pytest.mark.parametrize("cli", ["swipl", "retalisc"])
def test_the_warning_names_the_file_and_line(tmp_path, cli, swipl, retalisc_cmd):
    import subprocess
    from retalisc.compiler import compile_source
    program = tmp_path / "s.rtl"
    program.write_text(ISSUE_SEQ)
    events = tmp_path / "events.jsonl"
    events.write_text("\n".join(issue_lines(7)) + "\n")
    if cli == "swipl":
        compiled = tmp_path / "s.pl"
        compiled.write_text(compile_source(ISSUE_SEQ, str(program)).prolog)
        command = [swipl, str(compiled), "--max-delay=1", str(events)]
    else:
        command = retalisc_cmd + ["run", str(program), "--events", str(events), "--max-delay", "1"]
    run = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ['{"event": "s(1)", "start": 1, "end": 2}']
    warning, *detections, summary = run.stderr.splitlines()
    assert warning == f"{events}:10: warning: retraction too late: 1 derived events not retracted"
    assert detections == ([] if cli == "swipl" else ["retalis: detections per rule: r1 1"])
    assert summary.startswith("retalis: 9 events in, 1 derived, 0 rejected, 1 too late to retract, ")
    assert " retracted" not in summary
    # lengthened on the command line, the same deletion is exact
    if cli == "swipl":
        command.insert(2, "--retraction-horizon=10")
    else:
        command += ["--retraction-horizon", "10"]
    run = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert run.stdout.splitlines()[-1] == '{"event": "s(1)", "start": 1, "end": 2, "op": "retract"}'
    assert "warning" not in run.stderr


# Every operator under a window, plus one rule without (kept forever), on streams long enough
# for the sweep to retire partial matches: delay bound 1, largest window 4, horizon 5.
HORIZON_RULES = [f"{op}_r(I, X, Y) <- (a(I, X) {op} b(I, Y)).3." for op in
                 ["seq", "and", "par", "equals", "meets", "during", "starts", "finishes"]] + [
    "or_r(I, X) <- (a(I, X) or c(I, X)).2.",
    "where_r(I, X, Y) <- (a(I, X) seq b(I, Y) where X < Y).4.",
    "nested_r(I, X, Z) <- ((a(I, X) seq b(I, _)) during c(I, Z)).4.",
    "not_r(I, X) <- (not(c(I, _)).[a(I, X), b(I, _)]).4.",
    "cnot_r(I) <- ((a(I, _) seq b(I, _)) cnot c(I, _)).3.",
    "fnot_r(I, X) <- (a(I, X) fnot c(I, _)).2.",
    "chain_r(I, X) <- (seq_r(I, X, _) seq c(I, _)).4.",
    "free_r(I) <- a(I, _) seq c(I, _).",
]
HORIZON_PROGRAM = "\n".join(HORIZON_RULES)
HORIZON_PARSED = None
DELAY, HORIZON = 1, 5


@pytest.fixture(scope="module")
def horizon_engine():
    return Engine.from_source(HORIZON_PROGRAM, "horizon.rtl")


def horizon_oracle(events):
    from collections import Counter
    from retalisc.frontend.parser import read_term
    from retalisc.frontend.program import parse_program
    from retalisc.frontend.writer import write_term
    from ele_oracle import matches, substitute_ground
    global HORIZON_PARSED
    if HORIZON_PARSED is None:
        HORIZON_PARSED = parse_program(HORIZON_PROGRAM, "horizon.rtl")
    parsed = [(read_term(f"{k}({i}, {x})"), s, s + d) for k, i, x, s, d in events]
    derived = []
    result = Counter()
    # rules over derived events (chain_r) see the derived events of the rules before them
    for rule in HORIZON_PARSED.event_rules:
        for bindings, start, end in matches(rule.pattern, parsed + derived):
            head = substitute_ground(rule.head, bindings)
            result[f"{write_term(head, 999).replace(' ', '')}@{start}-{end}"] += 1
            derived.append((head, start, end))
    return result


from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

# (kind, id, value, start, duration) over 40 seconds: the sweep runs many times
timed_event = st.tuples(st.sampled_from("abc"), st.integers(1, 2), st.integers(0, 3), st.integers(0, 40),
                        st.sampled_from([0, 0, 1, 2]))


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(timed_event, min_size=2, max_size=30), st.data())
def test_late_events_and_deletions_inside_the_horizon_are_exact(horizon_engine, events, data):
    """Each event arrives up to the horizon late (more than the delay bound: it must find the
    kept partial matches); some are deleted again, each while it is inside the horizon. The
    net output equals the oracle over the events that remain, and no deletion is too late."""
    jitter = st.floats(0, HORIZON - 0.01)
    keyed = []
    for index, e in enumerate(events):
        end = e[3] + e[4]
        arrive = end + data.draw(jitter)
        keyed.append((arrive, index, "add", e))
        if data.draw(st.booleans()):
            keyed.append((data.draw(st.floats(arrive + 0.001, end + HORIZON - 0.002)), index, "retract", e))
    keyed.sort(key=lambda k: (k[0], k[2] == "retract"))
    engine = fresh(horizon_engine, str(DELAY))
    batch = [(f"{k}({i}, {x})", s, s + d, op) for _, _, op, (k, i, x, s, d) in keyed]
    assert net_output(engine.feed_batch(batch)) == horizon_oracle(
        [e for _, index, op, e in keyed if op == "add" and
         not any(o == "retract" and j == index for _, j, o, _ in keyed)])
    assert engine.take_warnings() == []


AGGREGATES = """
count_r(I, N) <- (a(I, _) seq aggregate(count, b(I, _), N)).4.
sum_r(I, S) <- (a(I, _) seq aggregate(sum(X), b(I, X), S)).4.
min_r(I, M) <- (a(I, _) seq aggregate(min(X), b(I, X), M)).4.
avg_r(I, M) <- a(I, _) seq aggregate(avg(X), b(I, X), M).
"""


@pytest.fixture(scope="module")
def aggregate_engine():
    return Engine.from_source(AGGREGATES, "aggregates.rtl")


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.sampled_from("ab"), st.integers(1, 2), st.integers(0, 9), st.integers(0, 30)),
                min_size=2, max_size=25, unique_by=lambda e: e[:3] + (e[3] // 1000,)), st.data())
def test_deleting_an_aggregated_event_inside_the_horizon_replays_its_accumulators(aggregate_engine, events, data):
    """Aggregate values follow the processing order; deleting an A or a P inside the horizon
    leaves the net output of a run in which it was never processed, the others in the same
    order."""
    events = sorted(events, key=lambda e: e[3])
    doomed = data.draw(st.lists(st.integers(0, len(events) - 1), unique=True, max_size=4))
    ops = [("add", e) for e in events]
    for index in sorted(doomed, reverse=True):
        # the deletion comes while the event is inside the horizon (1 + 4): before any event
        # that ends 5 seconds or more after it
        limit = next((i for i, (_, e) in enumerate(ops) if e[3] >= events[index][3] + 5 and
                      i > ops.index(("add", events[index]))), len(ops))
        position = data.draw(st.integers(ops.index(("add", events[index])) + 1, limit))
        ops.insert(position, ("retract", events[index]))
    engine = fresh(aggregate_engine, "1")
    got = net_output(engine.feed_batch([(f"{k}({i}, {x})", t, t, op) for op, (k, i, x, t) in ops]))
    reference = fresh(aggregate_engine, "1")
    kept = [e for i, e in enumerate(events) if i not in doomed]
    expected = net_output(reference.feed_batch([(f"{k}({i}, {x})", t, t) for k, i, x, t in kept]))
    assert got == expected


def test_a_deleted_aggregated_event_takes_its_values_back():
    engine = fresh(Engine.from_source("s(K, S) <- (a(K) seq aggregate(sum(X), b(K, X), S)).10.", "agg.rtl"), "1")
    outputs(engine, [("a(1)", 1), ("b(1, 5)", 2), ("b(1, 7)", 3), ("b(1, 1)", 4)])
    assert outputs(engine, [("b(1, 7)", 3, 3, "retract")]) == [
        ("s(1,12)", 1, 3, "retract"), ("s(1,13)", 1, 4, "retract"), ("s(1,6)", 1, 4, "add")]
    assert outputs(engine, [("a(1)", 1, 1, "retract")]) == [("s(1,0)", 1, 1, "retract"), ("s(1,5)", 1, 2, "retract"),
                                                            ("s(1,6)", 1, 4, "retract")]


@pytest.mark.parametrize("policy", ["recent", "chronological"])
def test_under_a_policy_deleting_a_consumed_event_takes_its_result_back(policy):
    program = f":- set_etalis_flag(event_consumption_policy, {policy}).\nc(K) <- (a(K) seq b(K)).5.\n"
    engine = fresh(Engine.from_source(program, "policy.rtl"), "1")
    assert outputs(engine, [("a(1)", 1), ("b(1)", 2), ("z", 5)]) == [("c(1)", 1, 2, "add")]
    assert outputs(engine, [("a(1)", 1, 1, "retract")]) == [("c(1)", 1, 2, "retract")]
    assert outputs(engine, [("b(1)", 2, 2, "retract")]) == []        # its match is gone already
    # a waiting event made nothing: deleting it takes nothing back
    assert outputs(engine, [("a(2)", 6), ("a(2)", 6, 6, "retract"), ("b(2)", 7)]) == []


def test_policy_records_are_forgotten_after_the_horizon():
    program = ":- set_etalis_flag(event_consumption_policy, recent).\nc(K) <- a(K) seq b(K).\n"
    engine = fresh(Engine.from_source(program, "policy.rtl"), "1")
    batch = []
    for t in range(2000):
        batch += [(f"a({t % 7})", 2 * t), (f"b({t % 7})", 2 * t + 1)]
    assert len(engine.feed_batch(batch)) == 2000
    # horizon 1 s, swept every 64 events: a few dozen records at most, not one per match
    assert int(engine.bridge.call_text("retalis:rtl_store_size(N), format(string(Out), '~w', [N])")) < 150


NEGATION = "n(X) <- (not(c(X)).[a(X), b(X)]).5.\nf(X) <- (a(X) fnot c(X)).5.\n"


@pytest.fixture(scope="module")
def negation_engine():
    return Engine.from_source(NEGATION, "negation.rtl")


def test_deleting_a_blocker_inside_the_horizon_derives_again_what_it_blocked(negation_engine):
    """Horizon 6: the a(1)@2 the blocker kept out has been retired by the sweep at 8.5 (its
    start is more than 5 + 1 before), the blocker c(1)@3 is still inside the horizon when it
    is deleted; what it blocked is derived again."""
    engine = fresh(negation_engine, "1")
    assert outputs(engine, [("a(1)", 2), ("c(1)", 3), ("b(1)", 4), ("z", 8.5)]) == [("f(1)", 2, 2, "add")]
    assert engine.bridge.call_text(f"{engine.module}:e_r1_1_lefts_kept_a(X, S, E), "
                                   "format(string(Out), '~w@~w', [X, S])") == "1@2"
    assert outputs(engine, [("c(1)", 3, 3, "retract")]) == [("n(1)", 2, 4, "add")]


def test_a_blocker_later_than_the_delay_bound_takes_back_what_it_blocks(negation_engine):
    """A case with a late blocker: delay bound 2, horizon 7; c(1)@3 arrives 6 s late."""
    engine = fresh(negation_engine, "2")
    assert outputs(engine, [("a(1)", 0), ("b(1)", 5), ("z", 9)]) == [("f(1)", 0, 0, "add"), ("n(1)", 0, 5, "add")]
    assert outputs(engine, [("c(1)", 3)]) == [("n(1)", 0, 5, "retract")]
    # f(1)@0 stays: c(1)@3 is after it
    assert outputs(engine, [("c(1)", 3, 3, "retract")]) == [("n(1)", 0, 5, "add")]


def test_a_blocker_later_than_the_horizon_may_take_back_nothing(negation_engine):
    """Beyond the horizon (documented): the pair it falls inside of may be forgotten (here the
    kept generation holding it is emptied by the sweep at 60)."""
    engine = fresh(negation_engine, "2")
    outputs(engine, [("a(1)", 0), ("b(1)", 5), ("z", 40), ("z", 50), ("z", 60)])
    assert outputs(engine, [("c(1)", 3)]) == []
    assert engine.stats()["late"] == 1


def test_a_too_late_deletion_changes_nothing_not_even_actions():
    program = ("n(X) do new_event(seen(X)) <- (not(c(X)).[a(X), b(X)]).5.\n"
               "s(X) <- seen(X).\n"
               "sub(1, watcher, n(X)-[], got(X), 0).\n")
    engine = fresh(Engine.from_source(program, "dry.rtl"), "1")
    assert outputs(engine, [("a(1)", 0), ("c(1)", 1), ("b(1)", 2), ("z", 8)]) == []
    assert outputs(engine, [("c(1)", 1, 1, "retract")]) == []
    [warning] = engine.take_warnings()
    assert warning.text == "retraction too late: 0 derived events not retracted, 1 not derived again"
    assert outputs(engine, [("z", 9)]) == []                  # no seen(1) was raised
    assert (engine.stats()["retracted"], engine.stats()["too_late"]) == (0, 1)
