"""Absence over a duration, `not(C).[A, D]`: no C in the D seconds after A
ends, decided once the clock has passed A's end + D + max_delay, one event over
[start of A, end of A + D], taken back by a late blocker inside the retraction horizon.

Golden cases for the edges, then hypothesis properties against the brute-force oracle
(tests/ele_oracle.py): arrival orders within the delay bound, any order with an unbounded
delay, and deletions equal to recomputation; at the end of each run the pending absences are
decided (`flush_timers`)."""
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine
from retalisc.frontend.errors import RetalisError
from retalisc.frontend.parser import read_term
from retalisc.frontend.program import parse_program
from retalisc.frontend.writer import write_term

from ele_oracle import matches, net_output, substitute_ground
from timer_support import fresh, outputs

ROOM = "empty(Room) <- not(seen(_, Room)).[door_closed(Room), 30].\n"



@pytest.fixture(scope="module")
def room():
    engine = Engine.from_source(ROOM, "room.rtl")
    yield engine
    fresh(engine)           # flags are shared by the engines of a process



# ---- golden cases -----------------------------------------------------------------------

def test_an_absence_is_decided_once_the_clock_passes_end_plus_duration_plus_delay(room):
    engine = fresh(room, "1")
    assert outputs(engine, [("door_closed(k)", 20), ("tick", 50), ("tick", 51)]) == []   # 20 + 30 + 1 not passed
    assert outputs(engine, [("tick", 51.5)]) == [("empty(k)", 20, 50, "add")]
    assert outputs(engine, [("tick", 100)]) == []                                       # decided once


def test_a_blocker_inside_the_period_blocks_and_one_outside_does_not(room):
    engine = fresh(room, "0")
    stream = [("door_closed(a)", 0), ("seen(p, a)", 30),              # ends at the close: blocks
              ("door_closed(b)", 100), ("seen(p, b)", 100),           # starts at A's end: outside
              ("door_closed(c)", 200), ("seen(p, c)", 230.5, 230.5),  # after the close
              ("door_closed(d)", 300), ("seen(p, d)", 329, 331),      # ends after the close
              ("seen(p, e)", 395), ("door_closed(e)", 400), ("tick", 1000)]
    assert outputs(engine, stream) == [("empty(b)", 100, 130, "add"), ("empty(c)", 200, 230, "add"),
                                       ("empty(d)", 300, 330, "add"), ("empty(e)", 400, 430, "add")]


def test_a_late_blocker_takes_the_result_back_and_deleting_it_restores_it(room):
    engine = fresh(room, "1")
    assert outputs(engine, [("door_closed(k)", 20), ("tick", 60)]) == [("empty(k)", 20, 50, "add")]
    assert outputs(engine, [("seen(p, k)", 49)]) == [("empty(k)", 20, 50, "retract")]   # 11 s late
    assert engine.stats()["late"] == 1
    assert outputs(engine, [("seen(p, k)", 49, 49, "retract")]) == [("empty(k)", 20, 50, "add")]


def test_deleting_the_opening_event_cancels_its_wait_or_takes_its_result_back(room):
    engine = fresh(room, "1")
    outputs(engine, [("door_closed(a)", 0), ("door_closed(b)", 10), ("tick", 25)])
    assert outputs(engine, [("door_closed(a)", 0, 0, "retract")]) == []                # still waiting
    assert outputs(engine, [("tick", 45)]) == [("empty(b)", 10, 40, "add")]              # a never fires
    assert outputs(engine, [("door_closed(b)", 10, 10, "retract")]) == [("empty(b)", 10, 40, "retract")]


def test_pending_absences_do_not_fire_at_the_end_of_the_input_unless_flushed(room):
    engine = fresh(room, "1")
    outputs(engine, [("door_closed(k)", 20), ("tick", 40)])
    assert engine.end_of_input() == []
    engine.set_flag("flush_timers", "true")
    assert [(o.event, o.start, o.end) for o in engine.end_of_input()] == [("empty(k)", 20, 50)]


def test_an_absence_feeds_other_rules():
    engine = fresh(Engine.from_source(ROOM + "alert(R) <- empty(R) seq door_opened(R).\n", "chain.rtl"), "1")
    stream = [("door_closed(k)", 0), ("door_opened(k)", 40)]
    assert outputs(engine, stream) == [("empty(k)", 0, 30, "add"), ("alert(k)", 0, 40, "add")]


def test_the_store_stays_flat_over_a_long_run(room):
    engine = fresh(room, "1")
    sizes = []
    for block in range(5):
        batch = []
        for i in range(80):
            t = block * 2000 + i * 10
            batch += [(f"door_closed(r{i % 7})", t), (f"seen(p, r{i % 5})", t + 3)]
        engine.feed_batch(batch)
        sizes.append(engine.store_size())
    # a block holds 160 events; what the store keeps (the horizon's worth) does not grow with them
    assert max(sizes) < 100 and max(sizes[1:]) - min(sizes[1:]) <= 10, sizes


@pytest.mark.parametrize("text, message", [
    ("e <- not(b).[a, -3].", "not negative"),
    ("e <- not(b).[a, 3, 4].", "not(P).[P1, Seconds]"),
])
def test_a_bad_duration_is_a_located_error(text, message):
    with pytest.raises(RetalisError) as error:
        compile_source(text, "bad.rtl")
    assert message in str(error.value)


# ---- properties against the oracle ------------------------------------------------------

RULES = [
    "gone(I) <- not(c(I, _)).[a(I, _), 4].",
    "now(I, X) <- not(b(I, _)).[a(I, X), 0].",
    "short(I) <- (not(c(I, _)).[b(I, _), 3]).5.",
    "back(I, Y) <- gone(I) seq b(I, Y).",
]
PROGRAM = "\n".join(RULES)
PARSED = parse_program(PROGRAM, "absence.rtl")

event = st.tuples(st.sampled_from("abc"), st.integers(1, 2), st.integers(0, 2), st.integers(0, 20),
                  st.sampled_from([0, 0, 1, 2]))


@pytest.fixture(scope="module")
def engine():
    engine = Engine.from_source(PROGRAM, "absence.rtl")
    yield engine
    fresh(engine)


def oracle(events):
    """Matches of every rule, in order: the heads of a rule are events for the later ones."""
    parsed = [(read_term(f"{k}({i}, {x})"), s, s + d) for k, i, x, s, d in events]
    result = Counter()
    for rule in PARSED.event_rules:
        derived = []
        for bindings, start, end in matches(rule.pattern, parsed):
            head = substitute_ground(rule.head, bindings)
            derived.append((head, start, end))
            result[f"{write_term(head, 999).replace(' ', '')}@{start}-{end}"] += 1
        parsed += derived
    return result


def run(engine, ops, max_delay, horizon="auto"):
    fresh(engine, max_delay, "true", horizon)
    batch = [(f"{k}({i}, {x})", s, s + d, op) for op, (k, i, x, s, d) in ops]
    produced = engine.feed_batch(batch) + engine.end_of_input()
    assert engine.stats()["failed"] == 0
    return net_output(produced)


def test_the_oracle_is_not_trivial(engine):
    events = [("a", 1, 0, 0, 0), ("b", 1, 1, 6, 0), ("a", 2, 1, 0, 0), ("c", 2, 0, 2, 0), ("b", 2, 0, 10, 0)]
    expected = oracle(events)
    for name in ("gone(1)", "now(1,0)", "short(1)", "back(1,1)", "short(2)"):
        assert any(k.startswith(name) for k in expected), name
    assert not any(k.startswith("gone(2)") for k in expected)
    assert run(engine, [("add", e) for e in sorted(events, key=lambda e: e[3] + e[4])], "0") == expected


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(event, st.integers(0, 3)), min_size=2, max_size=16))
def test_arrival_orders_within_the_delay_bound_match_the_oracle(engine, delayed):
    # each event arrives up to 3 s after its end; ties keep their stream order
    arrival = [e for e, _ in sorted(delayed, key=lambda ed: ed[0][3] + ed[0][4] + ed[1])]
    assert run(engine, [("add", e) for e in arrival], "3") == oracle([e for e, _ in delayed])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(event, min_size=2, max_size=12), st.randoms(use_true_random=False))
def test_any_arrival_order_with_an_unbounded_delay_matches_the_oracle(engine, events, random):
    arrival = list(events)
    random.shuffle(arrival)
    assert run(engine, [("add", e) for e in arrival], "inf") == oracle(events)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(event, st.integers(0, 2)), min_size=2, max_size=12), st.data())
def test_deletions_equal_recomputation(engine, delayed, data):
    """Events arrive within the bound (absences are decided on the way); some are deleted
    again at a random later point, before or after their absence was decided."""
    arrival = [e for e, _ in sorted(delayed, key=lambda ed: ed[0][3] + ed[0][4] + ed[1])]
    doomed = data.draw(st.lists(st.integers(0, len(arrival) - 1), unique=True, max_size=len(arrival)))
    ops = [("add", e) for e in arrival]
    for index in sorted(doomed, reverse=True):
        position = data.draw(st.integers(index + 1, len(ops)))
        ops.insert(position, ("retract", arrival[index]))
    remaining = [e for i, e in enumerate(arrival) if i not in doomed]
    assert run(engine, ops, "2", horizon="1000") == oracle(remaining)


# ---- the robot example (examples/room_empty; its golden output is checked by test_golden) ----

def test_the_room_example_is_one_rule_and_a_late_sighting_takes_it_back():
    from pathlib import Path

    folder = Path(__file__).resolve().parent.parent / "examples" / "room_empty"
    engine = fresh(Engine.load(folder / "room_empty.rtl"), "1")
    produced, rejected = engine.feed_lines((folder / "events.jsonl").read_text().rstrip("\n"))
    assert rejected == []
    assert [(o.event, o.start, o.end) for o in produced if o.event.startswith("room_left_empty")] == [
        ("room_left_empty(kitchen,alice)", 0, 35), ("room_left_empty(lab,dan)", 50, 82)]
    # someone was in the lab at 70 after all: the message arrives late, inside the horizon
    assert outputs(engine, [("seen(zed, lab)", 70)]) == [("room_left_empty(lab,dan)", 50, 82, "retract")]
    fresh(engine)
