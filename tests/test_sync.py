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
        assert _feed(engine, ['{"event": "other", "t": 1.0}']) == []   # a tf at 0.5 is 0.5 s late: still in time
        assert _feed(engine, ['{"event": "other", "t": 1.01}']) == ["pose(m1,1100)"]
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
    assert _events(engine, ("noise", 1.2)) == []                  # a tf at 1.0 would be 0.2 s late: in time
    assert _events(engine, ("noise", 1.25)) == ["seen(m1,1)"]     # 1.0 + 0.2 < 1.25: no tf up to 1.0 can come


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
    assert _events(engine, ("noise", 7.5)) == []                             # exactly 2 s: in time
    assert _events(engine, ("noise", 7.6)) == ["moved(a,2)"]


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


# ---- property: per-type delays do not change the answers --------------------------------

import subprocess  # noqa: E402
import sys  # noqa: E402

from hypothesis import given, settings, strategies as st  # noqa: E402

DELAYED = """
c_mem(odom, odom(_)-[], inf, inf).
c_mem(cam, cam(_)-[], inf, inf).
at(Id, T, V) :-
    prev(Id, E1^T1, T), arg(1, E1, V1),
    (   next(Id, E2^T2, T, inf)
    ->  arg(1, E2, V2), time_fraction(T1, T2, T, F), V is V1 + F * (V2 - V1)
    ;   V = V1
    ).
place(T, X) :- at(odom, T, A), at(cam, T, B), X is A + B.
synchronized(pose(M, X), place(T, X), [[odom, T], [cam, T]]) <- marker(M)^T.
"""

_stream = st.lists(st.tuples(st.sampled_from(["odom", "cam", "marker"]), st.integers(0, 40), st.integers(0, 9)),
                   min_size=1, max_size=25)


def _outcome(events):
    engine = Engine.from_source(DELAYED)
    engine.set_flag("max_delay", "inf")     # no deadline: waits end by a later record or the end of input
    try:
        produced = engine.feed_batch(events)
        produced += engine.end_of_input()
    finally:
        engine.set_flag("max_delay", "1.0")
    return sorted((e.event, e.start) for e in produced)


@settings(max_examples=30, deadline=None)
@given(_stream, st.fixed_dictionaries({t: st.integers(0, 15) for t in ("odom", "cam", "marker")}))
def test_per_type_delays_give_the_answers_of_the_in_order_stream(stream, delays):
    # odom/cam events carry their value; markers are named by their index; times are tenths of seconds
    events = []
    for index, (kind, time, value) in enumerate(stream):
        term = f"marker(m{index})" if kind == "marker" else f"{kind}({value})"
        events.append((kind, time / 10, term))
    in_order = sorted(events, key=lambda e: e[1])
    delayed = sorted(events, key=lambda e: (e[1] + delays[e[0]] / 10, e[1]))   # each type stays in order
    assert _outcome([(term, t) for _, t, term in delayed]) == _outcome([(term, t) for _, t, term in in_order])


def test_cli_run_prints_synchronized_answers_where_they_complete(tmp_path):
    case = Path(__file__).parent / "golden" / "synchronized_rule"
    run = subprocess.run([sys.executable, "-m", "retalisc", "run", str(case / "program.rtl"), "--events",
                          str(case / "events.jsonl"), "--echo-input", "--query", "0.5", "place(0, 0.5, X)",
                          "--query", "1.5", "place(0, 1.5, X)", "--query-timeout", "0.7"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    answered = lines.index('{"query": "1", "at": 0.5, "status": "answered", "answers": [{"X": "155.0"}], '
                           '"message": ""}')
    released_by = lines.index('{"event": "tf(base,cam,200)", "start": 1, "end": 1, "input": true}')
    next_input = lines.index('{"event": "marker(m3,3000)", "start": 1.5, "end": 1.5, "input": true}')
    assert released_by < answered < next_input            # written while that event is processed
    assert '{"query": "2", "at": 1.5, "status": "timeout", "answers": [], ' \
           '"message": "not achievable by the deadline"}' in lines
    refused = subprocess.run([sys.executable, "-m", "retalisc", "run", str(case / "program.rtl"), "--events",
                              str(case / "events.jsonl"), "--query", "1", "shell(ls)"],
                             capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and "unsafe" in refused.stderr


# ---- the thesis's examples (4.2.5, rules 4.7 and 4.8) ----------------------------------

STATE = Path(__file__).parent.parent / "examples" / "state_knowledge" / "state_knowledge.rtl"


def test_interpolation_waits_for_the_first_later_observation():
    engine = Engine.load(STATE)
    engine.feed_batch([("tf(cam, base, [0, 0, 1])", 10)])
    future = engine.query_synchronized("tf(cam, base, L)^11", at=11)
    engine.feed_batch([("tf(base, rcf, [10, 0, 0])", 12)])        # a later tf, but not a cam-base one
    assert not future.done()
    engine.feed_batch([("tf(cam, base, [0, 2, 1])", 12)])
    assert future.result(timeout=0) == [{"L": "[0.0,1.0,1.0]"}]


def test_extrapolation_waits_until_t_plus_one_plus_the_delay_bound():
    engine = Engine.load(STATE)
    engine.feed_batch([("tf(base, rcf, [10, 0, 0])", 10)])
    future = engine.query_synchronized("tf(base, rcf, L)^10.5", at=10.5)
    engine.feed_batch([("noise", 12.4)])
    assert not future.done()                                        # a base-rcf in [10.5, 11.5] may still come
    engine.feed_batch([("noise", 12.5)])                            # 10.5 + 1 + max delay 1: a base-rcf
    assert not future.done()                                        # at 11.5 is exactly 1 s late, in time
    engine.feed_batch([("noise", 12.51)])
    assert future.result(timeout=0) == [{"L": "[10,0,0]"}]


TABLE = """
c_mem(segs, segR(_, _)-[], inf, inf).
c_mem(objs, obj(_, _)-[], inf, inf).
max_delay(segR/2, 100).
max_delay(obj/2, 100).
table_objects(T, Os) :-
    findall(O, ( mem(segs, segR(O, table)^Z), Z =< T, \\+ mem(objs, obj(O, person)^_) ), Os).
"""


def test_updated_events_make_the_table_objects_query_achievable():
    engine = Engine.from_source(TABLE)
    engine.feed_batch([("segR(cup, table)", 1), ("segR(ann, table)", 2), ("obj(cup, mug)", 3)])
    future = engine.query_synchronized("table_objects(5, Os)", at=5)
    engine.feed_batch([("updated(segR/2)", 5), ("obj(ann, person)", 4)])
    assert not future.done()                                        # obj/2 may still be incomplete up to 5
    engine.feed_batch([("updated(obj/2)", 6)])
    assert future.result(timeout=0) == [{"Os": "[cup]"}]


def test_query_with_synchronized_true_returns_a_future():
    engine = Engine.load(STATE)
    engine.feed_batch([("tf(cam, base, [0, 0, 1])", 10)])
    future = engine.query("tf(cam, base, L)^11", at=11, synchronized=True)
    engine.feed_batch([("tf(cam, base, [0, 2, 1])", 12)])
    assert future.result(timeout=0) == [{"L": "[0.0,1.0,1.0]"}]


def test_time_index_plunit(swipl):
    """The time index that postponed matches wait in (prolog_runtime/rtl_time_index.pl)
    against a list model on random add/remove/take sequences."""
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(Path(__file__).resolve().parent.parent / "prolog_runtime" / "tests"
                               / "test_time_index.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout
