"""Per-rule selection: a rule's own consumption policy, as a label property
(`r1([property(consumption_policy, recent)]) 'rule:' ...`) or an `event_rule_property/3`
fact, overrides the program's flag; and the `first` selection pairs each left event with its
first matching right event only (by time, whatever the arrival order), exactly under any
arrival order and deletion (checked against a brute-force oracle)."""
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine
from retalisc.frontend.errors import RetalisError

from ele_oracle import net_output


def outputs(engine, batch):
    return [(o.event, o.start, o.end, o.op) for o in engine.feed_batch(batch)]


def fresh(engine, max_delay="inf"):
    engine.activate()           # one program per process: another test may have loaded its own
    engine.clear()
    engine.set_flag("max_delay", max_delay)
    return engine


STREAM = [("a(1, 1)", 1), ("a(1, 2)", 2), ("b(1, 7)", 3), ("b(1, 8)", 4)]


@pytest.mark.parametrize("program, expected", [
    # the program is unrestricted; r1 alone is recent, r2 chronological, r3 unrestricted
    (":- set_etalis_flag(event_consumption_policy, unrestricted).\n"
     "r1([property(consumption_policy, recent)]) 'rule:' x(P, Q) <- a(K, P) seq b(K, Q).\n"
     "r2 'rule:' y(P, Q) <- a(K, P) seq b(K, Q).\n"
     "event_rule_property(r2, consumption_policy, chronological).\n"
     "r3 'rule:' z(P, Q) <- a(K, P) seq b(K, Q).\n",
     {"x": [("x(2,7)", 2, 3), ("x(1,8)", 1, 4)], "y": [("y(1,7)", 1, 3), ("y(2,8)", 2, 4)],
      "z": [("z(1,7)", 1, 3), ("z(2,7)", 2, 3), ("z(1,8)", 1, 4), ("z(2,8)", 2, 4)]}),
    # the program is recent; r3 asks for unrestricted, r1 for first
    (":- set_etalis_flag(event_consumption_policy, recent).\n"
     "r1([property(consumption_policy, first)]) 'rule:' x(P, Q) <- a(K, P) seq b(K, Q).\n"
     "r2 'rule:' y(P, Q) <- a(K, P) seq b(K, Q).\n"
     "r3([property(event_consumption_policy, unrestricted)]) 'rule:' z(P, Q) <- a(K, P) seq b(K, Q).\n",
     {"x": [("x(1,7)", 1, 3), ("x(2,7)", 2, 3)], "y": [("y(2,7)", 2, 3), ("y(1,8)", 1, 4)],
      "z": [("z(1,7)", 1, 3), ("z(2,7)", 2, 3), ("z(1,8)", 1, 4), ("z(2,8)", 2, 4)]}),
])
def test_a_rule_property_overrides_the_program_policy(program, expected):
    engine = fresh(Engine.from_source(program, "policies.rtl"))
    produced = outputs(engine, STREAM)
    for head, want in expected.items():
        assert [(e, s, t) for e, s, t, op in produced if e.startswith(head + "(")] == want, head


def test_a_bad_rule_policy_is_a_located_error():
    with pytest.raises(RetalisError) as error:
        compile_source("r1([property(consumption_policy, newest)]) 'rule:' x <- a seq b.\n", "bad.rtl")
    assert str(error.value.span) == "bad.rtl:1:1" and "recent, chronological, first" in error.value.message


def test_first_pairs_each_grasp_with_the_next_release_whatever_the_arrival_order():
    program = "r1([property(consumption_policy, first)]) 'rule:' moved(C, G, R) <- grasp(C, G) seq release(C, R).\n"
    engine = fresh(Engine.from_source(program, "cups.rtl"))
    assert outputs(engine, [("grasp(cup, 1)", 0), ("release(cup, 1)", 5), ("grasp(cup, 2)", 6),
                            ("release(cup, 2)", 8)]) == [("moved(cup,1,1)", 0, 5, "add"), ("moved(cup,2,2)", 6, 8, "add")]
    # a release that happened at 3 arrives late: it is the first release after grasp 1
    assert outputs(engine, [("release(cup, 9)", 3)]) == [("moved(cup,1,1)", 0, 5, "retract"),
                                                         ("moved(cup,1,9)", 0, 3, "add")]
    # deleting it gives grasp 1 its next release back
    assert outputs(engine, [("release(cup, 9)", 3, 3, "retract")]) == [("moved(cup,1,9)", 0, 3, "retract"),
                                                                       ("moved(cup,1,1)", 0, 5, "add")]


# ---- `first` against the oracle ---------------------------------------------------------

FIRST = ("r1([property(consumption_policy, first)]) 'rule:' fs(K, P, Q) <- a(K, P) seq b(K, Q).\n"
         "r2([property(consumption_policy, first)]) 'rule:' fw(K, P, Q) <- (a(K, P) and b(K, Q)).3.\n")
event = st.tuples(st.sampled_from("ab"), st.integers(1, 2), st.integers(0, 3), st.integers(0, 12),
                  st.sampled_from([0, 0, 1]))


@pytest.fixture(scope="module")
def engine():
    engine = Engine.from_source(FIRST, "first.rtl")
    yield engine
    fresh(engine, "1.0")


def oracle(events):
    """For each a, the first b (smallest start, end, value) it matches: `seq` (b after a)
    and `and` inside a window of 3."""
    result = Counter()
    for name, matches in (("fs", lambda s1, e1, s2, e2: e1 < s2),
                          ("fw", lambda s1, e1, s2, e2: max(e1, e2) - min(s1, s2) <= 3)):
        for k, i, p, s1, d1 in events:
            if k != "a":
                continue
            e1 = s1 + d1
            partners = sorted((s2, s2 + d2, q) for k2, i2, q, s2, d2 in events
                              if k2 == "b" and i2 == i and matches(s1, e1, s2, s2 + d2))
            if partners:
                s2, e2, q = partners[0]
                start, end = (s1, e2) if name == "fs" else (min(s1, s2), max(e1, e2))
                result[f"{name}({i},{p},{q})@{start}-{end}"] += 1
    return result


def run(engine, ops, max_delay):
    fresh(engine, max_delay)
    return net_output(engine.feed_batch([(f"{k}({i}, {x})", s, s + d, op) for op, (k, i, x, s, d) in ops]))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(event, min_size=2, max_size=12), st.data())
def test_first_matches_the_oracle_in_any_order_with_deletions(engine, events, data):
    arrival = data.draw(st.permutations(events))
    doomed = data.draw(st.lists(st.integers(0, len(arrival) - 1), unique=True, max_size=len(arrival)))
    ops = [("add", e) for e in arrival]
    for index in sorted(doomed, reverse=True):
        ops.insert(data.draw(st.integers(index + 1, len(ops))), ("retract", arrival[index]))
    remaining = [e for i, e in enumerate(arrival) if i not in doomed]
    assert run(engine, ops, "inf") == oracle(remaining)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(event, st.integers(0, 2)), min_size=2, max_size=14))
def test_first_matches_the_oracle_within_the_delay_bound(engine, delayed):
    arrival = [e for e, _ in sorted(delayed, key=lambda ed: ed[0][3] + ed[0][4] + ed[1])]
    assert run(engine, [("add", e) for e in arrival], "2") == oracle([e for e, _ in delayed])
