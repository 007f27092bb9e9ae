"""One meaning for `where`, whether or not the optimiser can push a condition onto an event:
under every consumption policy, a candidate that fails a condition consumes nothing. A
condition the optimiser pushes (`Y < 3`, checked when `b` arrives) and the same condition in a
form it cannot push (`Y < 3 + 0*X`, checked when the join has both events) give the same
output, for every stream and arrival order."""
import re

import pytest
from hypothesis import given, settings, HealthCheck
from hypothesis import strategies as st

from retalisc.driver.engine import Engine

# (pushable rule, the same condition in a form that is not pushed); {h} is the head name
PAIRS = [
    "{h}(I, X, Y) <- a(I, X) seq b(I, Y) where (Y < 3{y}).",
    "{h}(I, X, Y) <- a(I, X) seq b(I, Y) where (X > 1{x}).",
    "{h}(I, X, Y) <- a(I, X) and b(I, Y) where (Y >= 2{y}).",
    "{h}(I, X, Y, Z) <- a(I, X) seq b(I, Y) seq c(I, Z) where (Y < 3{y}).",
    "{h}(I, X, Y) <- (a(I, X) seq b(I, Y) where Y =\\= 1{y}) or c(I, X).",
    "{h}(I, X, Y) <- a(I, X) seq b(I, Y) where (Y < 4{y}, X =\\= 2{x}).",
]


def program(policy: str) -> str:
    rules = [f":- set_etalis_flag(event_consumption_policy, {policy})."]
    for n, rule in enumerate(PAIRS):
        rules.append(rule.format(h=f"pushed{n}", x="", y=""))
        rules.append(rule.format(h=f"joined{n}", x=" + 0*Y", y=" + 0*X"))
    return "\n".join(rules) + "\n"


@pytest.fixture(scope="module")
def engines():
    return {policy: Engine.from_source(program(policy), f"conditions_{policy}.rtl")
            for policy in ("recent", "chronological", "unrestricted")}


def outputs(engine, stream):
    engine.activate()           # one program per process: the fixture loaded three
    engine.clear()
    produced = engine.feed_batch(stream)
    by_rule = {}
    for event in produced:
        name, _, args = event.event.partition("(")
        for kind in ("pushed", "joined"):
            if name.startswith(kind):
                by_rule.setdefault((int(name[len(kind):]), kind), []).append((re.sub(r"_\w+", "_", args),
                                                                              event.start, event.end,
                                                                              event.op))
    return by_rule


@st.composite
def streams(draw):
    n = draw(st.integers(1, 18))
    events = [(f"{draw(st.sampled_from('abc'))}({draw(st.integers(1, 2))}, {draw(st.integers(0, 4))})", t)
              for t in range(1, n + 1)]
    return draw(st.permutations(events))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(stream=streams(), policy=st.sampled_from(["recent", "chronological", "unrestricted"]))
def test_a_pushed_and_an_unpushed_condition_give_the_same_output(engines, stream, policy):
    by_rule = outputs(engines[policy], stream)
    for n in range(len(PAIRS)):
        assert by_rule.get((n, "pushed"), []) == by_rule.get((n, "joined"), []), (n, PAIRS[n], policy, stream)


def test_the_comparison_is_not_trivial(engines):
    # a failing b would have consumed the a under `recent` if the condition were checked after the join
    stream = [("a(1, 2)", 1), ("b(1, 9)", 2), ("b(1, 0)", 3)]
    by_rule = outputs(engines["recent"], stream)
    assert [args for args, *_ in by_rule[(0, "joined")]] == ["1,2,0)"]
    assert by_rule[(0, "pushed")] == by_rule[(0, "joined")]
