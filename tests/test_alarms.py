"""Timers on event time: `alarm(E, D) <- P` (and ETALIS's
`exceptionAlarm(E, D)`) raises E over [P's start, P's end + D] once the clock reaches P's end
+ D, without moving the clock; pending timers fire in time order, are deleted with their match, are
removed with their rule, and do not fire at the end of the input unless `flush_timers`."""
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine
from retalisc.frontend.parser import read_term
from retalisc.frontend.program import parse_program
from retalisc.frontend.writer import write_term

from ele_oracle import matches, net_output, substitute_ground
from timer_support import fresh, outputs

DOOR = """
alarm(check(R), 30) <- door_closed(R).
late_check(R) <- check(R) seq tick.
exceptionAlarm(recheck(R), 1) <- check(R).
"""




@pytest.fixture(scope="module")
def door():
    engine = Engine.from_source(DOOR, "door.rtl")
    yield engine
    fresh(engine)


def test_alarms_fire_in_time_order_as_the_clock_reaches_them_without_moving_it(door):
    engine = fresh(door)
    assert outputs(engine, [("door_closed(k)", 0), ("door_closed(j)", 5), ("tick", 29)]) == []
    assert engine.clock() == 29
    # the clock reaches 30: check(k) is raised after the tick at 30 (not before it)
    assert outputs(engine, [("tick", 30)]) == [("check(k)", 0, 30, "add")]
    # the tick at 36 passes recheck(k)@31 and check(j)@35: both before the tick, in time order
    assert outputs(engine, [("tick", 36)]) == [
        ("recheck(k)", 0, 31, "add"), ("check(j)", 5, 35, "add"), ("late_check(k)", 0, 36, "add"),
        ("late_check(j)", 5, 36, "add"), ("recheck(j)", 5, 36, "add")]
    assert engine.clock() == 36


def test_deleting_the_match_cancels_a_pending_alarm_or_takes_the_raised_event_back(door):
    engine = fresh(door)
    outputs(engine, [("door_closed(k)", 0), ("door_closed(j)", 5), ("tick", 32)])
    assert outputs(engine, [("door_closed(j)", 5, 5, "retract")]) == []          # pending: cancelled
    assert outputs(engine, [("door_closed(k)", 0, 0, "retract")]) == [
        ("check(k)", 0, 30, "retract"), ("late_check(k)", 0, 32, "retract"),
        ("recheck(k)", 0, 31, "retract")]                                           # fired: taken back
    assert outputs(engine, [("tick", 100)]) == []


def test_pending_alarms_fire_at_the_end_of_the_input_only_when_flushed(door):
    engine = fresh(door)
    outputs(engine, [("door_closed(k)", 0)])
    assert engine.end_of_input() == []
    engine.set_flag("flush_timers", "true")
    # the clock passes the last timer pending now (check(k)@30), not recheck(k)@31 that it sets
    assert [(o.event, o.end) for o in engine.end_of_input()] == [("check(k)", 30)]


def test_a_late_match_raises_an_alarm_already_due_at_once(door):
    engine = fresh(door, "100")
    outputs(engine, [("tick", 50)])
    assert outputs(engine, [("door_closed(k)", 10)]) == [
        ("check(k)", 10, 40, "add"), ("late_check(k)", 10, 50, "add"), ("recheck(k)", 10, 41, "add")]


def test_removing_a_rule_forgets_its_pending_alarms():
    engine = fresh(Engine.from_source("x <- y.\n", "rules.rtl"))
    engine.add_rules("r9 'rule:' alarm(check(R), 30) <- door_closed(R).\n")
    outputs(engine, [("door_closed(k)", 0)])
    engine.remove_rule("r9")
    assert outputs(engine, [("tick", 100)]) == []


def test_a_self_rearming_alarm_is_bounded_and_flushing_it_ends():
    engine = fresh(Engine.from_source("alarm(beat, 1) <- start.\nalarm(beat, 1) <- beat.\n", "beat.rtl"))
    produced = outputs(engine, [("start", 0), ("tick", 5)])
    assert [e for e, *_ in produced] == ["beat"] * 5
    engine.set_flag("flush_timers", "true")
    assert [(o.event, o.end) for o in engine.end_of_input()] == [("beat", 6)]


# ---- properties against the oracle ------------------------------------------------------

RULES = ["alarm(x(I, Y), 3) <- a(I, _) seq b(I, Y).", "alarm(z(I), 0) <- c(I, _) or a(I, 0)."]
PARSED = parse_program("\n".join(RULES), "alarms.rtl")
event = st.tuples(st.sampled_from("abc"), st.integers(1, 2), st.integers(0, 2), st.integers(0, 20),
                  st.sampled_from([0, 0, 1]))


@pytest.fixture(scope="module")
def engine():
    engine = Engine.from_source("\n".join(RULES), "alarms.rtl")
    yield engine
    fresh(engine)


def oracle(events, clock=None):
    parsed = [(read_term(f"{k}({i}, {x})"), s, s + d) for k, i, x, s, d in events]
    result = Counter()
    for rule in PARSED.event_rules:
        raised, delay = rule.head.args
        for bindings, start, end in matches(rule.pattern, parsed):
            due = end + delay.value
            if clock is None or due <= clock:
                result[f"{write_term(substitute_ground(raised, bindings), 999).replace(' ', '')}@{start}-{due}"] += 1
    return result


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(event, st.integers(0, 3)), min_size=1, max_size=14), st.data(), st.booleans())
def test_alarms_match_the_oracle_under_delays_and_deletions(engine, delayed, data, flush):
    arrival = [e for e, _ in sorted(delayed, key=lambda ed: ed[0][3] + ed[0][4] + ed[1])]
    doomed = data.draw(st.lists(st.integers(0, len(arrival) - 1), unique=True, max_size=len(arrival)))
    ops = [("add", e) for e in arrival]
    for index in sorted(doomed, reverse=True):
        ops.insert(data.draw(st.integers(index + 1, len(ops))), ("retract", arrival[index]))
    fresh(engine, "3", "true" if flush else "false", "1000")
    produced = engine.feed_batch([(f"{k}({i}, {x})", s, s + d, op) for op, (k, i, x, s, d) in ops])
    produced += engine.end_of_input()
    remaining = [e for i, e in enumerate(arrival) if i not in doomed]
    clock = max(s + d for _, (k, i, x, s, d) in ops)
    assert net_output(produced) == oracle(remaining, None if flush else clock)


def test_alarm_with_a_plain_second_argument_stays_an_ordinary_event():
    program = "alarm(S, L) <- smoke(S, L).\nalarm(check(S), L * 2) <- heat(S, L).\n"
    engine = fresh(Engine.from_source(program, "plain.rtl"))
    assert outputs(engine, [("smoke(s1, high)", 1), ("heat(s2, 3)", 2), ("tick", 8)]) == [
        ("alarm(s1,high)", 1, 1, "add"), ("check(s2)", 2, 8, "add")]


def test_loading_another_program_forgets_the_pending_timers_of_the_previous_one():
    first = fresh(Engine.from_source("alarm(beat, 1) <- start.\n", "first.rtl"))
    outputs(first, [("start", 0)])
    second = Engine.from_source("seen(X) <- x(X).\n", "second.rtl")      # no clear: only the switch
    assert outputs(second, [("x(1)", 5)]) == [("seen(1)", 5, 5, "add")]
