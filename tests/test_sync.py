"""Synchronized rules (thesis A.2.5.2): postponed until the memories are up to date, delivered once."""
from pathlib import Path

from retalisc.driver.engine import Engine

CASE = Path(__file__).parent / "golden" / "synchronized_rule"


def _feed(engine, lines):
    produced, rejected = engine.feed_lines("\n".join(lines))
    assert rejected == []
    return [e.event for e in produced]


def test_a_match_waits_for_every_memory_and_is_released_by_the_update():
    engine = Engine.load(CASE / "program.rtl")
    assert _feed(engine, ['{"event": "tf(odom, base, 0)", "t": 0}', '{"event": "tf(base, cam, 100)", "t": 0}',
                          '{"event": "marker(m1, 1000)", "t": 0.5}']) == []
    assert _feed(engine, ['{"event": "tf(odom, base, 10)", "t": 1}']) == []          # base_cam still behind
    assert _feed(engine, ['{"event": "tf(base, cam, 200)", "t": 1}']) == ["pose(m1,1155.0)"]
    assert _feed(engine, ['{"event": "tf(base, cam, 300)", "t": 2}']) == []          # delivered once
    assert engine.end_of_input() == []


def test_end_of_input_runs_or_drops_what_still_waits():
    lines = ['{"event": "tf(odom, base, 0)", "t": 0}', '{"event": "tf(base, cam, 100)", "t": 0}',
             '{"event": "marker(m1, 1000)", "t": 0.5}']
    engine = Engine.load(CASE / "program.rtl")
    _feed(engine, lines)
    assert engine.query("rtl_sync_pending(N)") == {"N": "1"}
    assert [e.event for e in engine.end_of_input()] == ["pose(m1,1100)"]
    dropping = Engine.load(CASE / "program.rtl")
    _feed(dropping, lines)
    assert dropping.end_of_input(drop_pending=True) == []


def test_the_clock_passing_the_delay_bound_completes_a_history():
    engine = Engine.load(CASE / "program.rtl")
    engine.set_flag("max_delay", "0.5")      # runtime flags are shared by the engines of a process
    try:
        _feed(engine, ['{"event": "tf(odom, base, 0)", "t": 0}', '{"event": "tf(base, cam, 100)", "t": 0}',
                       '{"event": "marker(m1, 1000)", "t": 0.5}'])
        assert _feed(engine, ['{"event": "other", "t": 0.9}']) == []
        assert _feed(engine, ['{"event": "other", "t": 1.0}']) == ["pose(m1,1100)"]
    finally:
        engine.set_flag("max_delay", "1.0")


AVAILABILITY = """
c_mem(cam, tf(_, _)-[], inf, inf).
c_mem(base, odom(_)-[], inf, inf).
max_delay(tf/2, 0.2).
max_delay(odom/1, learn).
syncronized(seen(M, N), aggregate_all(count, mem(cam, _), N), [[cam, T]]) <- marker(M)^T.
syncronized(moved(M, N), aggregate_all(count, mem(base, _), N), [[base, T]]) <- arm(M)^T.
"""


def _events(engine, *items):
    produced = engine.feed_batch(items)
    return [e.event for e in produced]


def test_a_declared_delay_per_type_completes_the_history():
    engine = Engine.from_source(AVAILABILITY)
    assert _events(engine, ("tf(a, 1)", 0.0), ("marker(m1)", 1.0)) == []
    assert _events(engine, ("noise", 1.1)) == []
    assert _events(engine, ("noise", 1.2)) == ["seen(m1,1)"]      # 1.2 - 0.2 >= 1.0: no tf up to 1.0 can come


def test_an_updated_event_completes_the_history():
    engine = Engine.from_source(AVAILABILITY)
    assert _events(engine, ("tf(a, 1)", 0.0), ("marker(m1)", 1.0)) == []
    assert _events(engine, ("updated(tf/2)", 0.5)) == []            # only up to 0.5
    assert _events(engine, ("updated(tf/2)", 1.0)) == ["seen(m1,1)"]


def test_a_learned_delay_grows_with_the_largest_delay_seen():
    engine = Engine.from_source(AVAILABILITY)
    assert _events(engine, ("odom(1)", 5.0), ("odom(2)", 3.0)) == []       # odom(2) arrived 2 s late
    assert engine.query("rtl_type_delay(odom/1, D)") == {"D": "2.0"}
    assert _events(engine, ("arm(a)", 5.5)) == []
    assert _events(engine, ("noise", 7.0)) == []                             # 7 - 2 < 5.5
    assert _events(engine, ("noise", 7.5)) == ["moved(a,2)"]


QUERIES = """
c_mem(odom, tf(odom, _)-[], inf, inf).
c_mem(cam, tf(cam, _)-[], inf, inf).
at(Id, T, V) :- prev(Id, tf(_, V1)^T1, T), next(Id, tf(_, V2)^T2, T, inf), time_fraction(T1, T2, T, F),
    V is V1 + F * (V2 - V1).
pos(T, X) :- at(odom, T, A), at(cam, T, B), X is A + B.
"""


def test_a_synchronized_query_waits_until_its_memories_are_up_to_date():
    engine = Engine.from_source(QUERIES)
    engine.feed_batch([("tf(odom, 0)", 0), ("tf(cam, 100)", 0), ("tf(odom, 10)", 1)])
    future = engine.query_synchronized("pos(0.5, X)", at=0.5)
    assert not future.done()                                  # cam has nothing after 0.5 yet
    assert engine.query("pos(0.5, X)") is None                # unsynchronized: no `next` for cam yet
    engine.feed_batch([("tf(cam, 200)", 1)])
    assert future.result(timeout=0) == [{"X": "155.0"}]
    ready = engine.query_synchronized("pos(0.25, X)", at=0.25)
    assert ready.result(timeout=0) == [{"X": "127.5"}]        # achievable at once


def test_a_synchronized_query_times_out_on_event_time_or_is_dropped():
    engine = Engine.from_source(QUERIES)
    engine.set_flag("max_delay", "inf")
    try:
        engine.feed_batch([("tf(odom, 0)", 0), ("tf(cam, 100)", 0)])
        late = engine.query_synchronized("pos(0.5, X)", at=0.5, timeout=2)
        waiting = engine.query_synchronized("pos(0.6, X)", at=0.6)
        engine.feed_batch([("tf(odom, 10)", 2.4)])
        assert not late.done()
        engine.feed_batch([("tf(odom, 20)", 2.5)])
        assert late.exception(timeout=0).kind == "timeout"
        engine.end_of_input(drop_pending=True)
        assert waiting.exception(timeout=0).kind == "dropped"
    finally:
        engine.set_flag("max_delay", "1.0")
