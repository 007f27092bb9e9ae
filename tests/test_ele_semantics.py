"""Every ELE operator against the brute-force oracle (tests/ele_oracle.py): random rules,
random streams, any arrival order, with and without windows, and deletions.

The engine's net output (additions minus retractions, as a multiset) must equal the
oracle's matches over the events that remain.
"""
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine
from retalisc.frontend.parser import read_term
from retalisc.frontend.program import parse_program
from retalisc.frontend.writer import write_term

from ele_oracle import matches, net_output, substitute_ground

OPERATORS = ["seq", "and", "par", "equals", "meets", "during", "starts", "finishes"]

# Rules over events a(I, X), b(I, X), c(I, X); each rule derives r<k>(...).
RULES = [f"{op}_r(I, X, Y) <- a(I, X) {op} b(I, Y)." for op in OPERATORS] + [
    "or_r(I, X) <- a(I, X) or c(I, X).",
    "where_r(I, X, Y) <- a(I, X) seq b(I, Y) where X < Y.",
    "window_r(I, X, Y) <- (a(I, X) and b(I, Y)).3.",
    "nested_r(I, X, Y, Z) <- ((a(I, X) seq b(I, Y)) during c(I, Z)).",
    "three_r(I, X) <- (a(I, X) seq b(I, _) seq c(I, _)).6.",
    "not_r(I, X, Y) <- not(c(I, _)).[a(I, X), b(I, Y)].",
    "cnot_r(I) <- (a(I, _) seq b(I, _)) cnot c(I, _).",
    "fnot_r(I, X) <- a(I, X) fnot c(I, _).",
    "wfnot_r(I, X) <- (a(I, X) fnot c(I, _)).2.",
    "wnot_r(I) <- (not(c(I, _)).[a(I, _), b(I, _)]).5.",
    "mix_r(I, X) <- (a(I, X) par b(I, _)) or (c(I, X) meets b(I, _)).",
]
PROGRAM = "\n".join(RULES)
PARSED = parse_program(PROGRAM, "semantics.rtl")

# (kind, id, value, start, duration): small domains so that operators actually fire,
# including equal time stamps (equals, meets, starts, finishes).
event = st.tuples(st.sampled_from("abc"), st.integers(1, 2), st.integers(0, 3), st.integers(0, 5),
                  st.sampled_from([0, 0, 1, 2, 3]))


@pytest.fixture(scope="module")
def engine():
    return Engine.from_source(PROGRAM, "semantics.rtl")


def oracle(events):
    parsed = [(read_term(f"{k}({i}, {x})"), s, s + d) for k, i, x, s, d in events]
    result = Counter()
    for rule in PARSED.event_rules:
        for bindings, start, end in matches(rule.pattern, parsed):
            result[f"{write_term(substitute_ground(rule.head, bindings), 999).replace(' ', '')}@{start}-{end}"] += 1
    return result


def feed(engine, ops):
    engine.clear()
    engine.set_flag("max_delay", "inf")
    batch = [(f"{k}({i}, {x})", s, s + d, op) for op, (k, i, x, s, d) in ops]
    return net_output(engine.feed_batch(batch))


def test_the_oracle_sees_every_operator(engine):
    events = [("a", 1, 0, 0, 2), ("b", 1, 1, 2, 1), ("c", 1, 2, 0, 5), ("b", 1, 2, 0, 3), ("a", 1, 3, 1, 0)]
    expected = oracle(events)
    for name in ["seq_r", "and_r", "par_r", "meets_r", "starts_r", "during_r", "nested_r", "not_r"]:
        assert any(k.startswith(name) for k in expected), name
    assert feed(engine, [("add", e) for e in events]) == expected


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(event, min_size=2, max_size=14), st.randoms(use_true_random=False))
def test_every_operator_matches_the_oracle_in_any_arrival_order(engine, events, random):
    arrival = list(events)
    random.shuffle(arrival)
    assert feed(engine, [("add", e) for e in arrival]) == oracle(events)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(event, min_size=2, max_size=12), st.data())
def test_deleting_events_retracts_what_was_derived_from_them(engine, events, data):
    """Events arrive in any order; some are deleted again, each at a random later point."""
    arrival = data.draw(st.permutations(events))
    doomed = data.draw(st.lists(st.integers(0, len(arrival) - 1), unique=True, max_size=len(arrival)))
    ops = [("add", e) for e in arrival]
    for index in sorted(doomed, reverse=True):
        position = data.draw(st.integers(index + 1, len(ops)))
        ops.insert(position, ("retract", arrival[index]))
    remaining = [e for i, e in enumerate(arrival) if i not in doomed]
    assert feed(engine, ops) == oracle(remaining)


def test_deleting_an_event_that_was_never_added_changes_nothing(engine):
    engine.clear()
    engine.set_flag("max_delay", "inf")
    engine.feed_batch([("a(1, 1)", 1), ("b(1, 2)", 3)])
    assert engine.feed("b(1, 2)", 4, op="retract") == []          # never added at t=4
    assert [o.op for o in engine.feed("b(1, 2)", 3, op="retract") if o.event.startswith("seq_r")] == ["retract"]
