"""Actions and raising events (thesis Listing A.1): new_event/1,2,3 queue new input events
that are processed after the current event, in the order they were raised; ETALIS library
predicates callable from programs."""
import json
import subprocess

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine

SPLIT = """
% Listing A.1: a tf message carries a list of transforms; each becomes a single event
null do split_tf(Transforms) <- tf_message(Transforms).
split_tf([]).
split_tf([tf(Parent, Child, S, NS)|Rest]) :-
    new_event(tf(Parent, Child), S, NS),
    split_tf(Rest).
chain(A, C) <- tf(A, B) seq tf(B, C).
"""


def load(source, echo_input=False):
    """An engine for `source`; runtime flags are per process, so set echo_input each time."""
    engine = Engine.from_source(source)
    engine.set_flag("echo_input", "true" if echo_input else "false")
    return engine


def events(output):
    return [(o.event, o.start, o.end) for o in output if o.consumer is None]


def test_listing_a1_splits_a_list_event_into_single_events_with_their_ros_stamps():
    engine = load(SPLIT, echo_input=True)
    out = engine.feed("tf_message([tf(odom, base, 10, 500000000), tf(base, head, 11, 0)])", 12)
    assert events(out) == [
        ("tf_message([tf(odom,base,10,500000000),tf(base,head,11,0)])", 12, 12),
        ("tf(odom,base)", 10.5, 10.5),
        ("tf(base,head)", 11, 11),
        ("chain(odom,head)", 10.5, 11),
    ]


def test_raised_events_wait_until_the_current_event_is_finished_and_keep_their_order():
    engine = load("""
        null do (new_event(x1), new_event(x2)) <- a.
        after_a <- a.
        null do new_event(y1) <- x1.
        seen(E) <- (x1 or x2 or y1) where E = ok.
        got_x1 <- x1.
    """, echo_input=True)
    out = engine.feed("a", 5)
    # everything `a` derives comes first; then x1 with its derivations, x2, and y1, which
    # x1 raised after x2 had been queued
    assert [e for e, _, _ in events(out)] == ["a", "after_a", "x1", "seen(ok)", "got_x1", "x2", "seen(ok)",
                                              "y1", "seen(ok)"]
    assert {(s, e) for _, s, e in events(out)} == {(5, 5)}       # new_event/1: the clock


def test_new_event_with_an_interval_a_time_and_a_datime():
    engine = load("""
        null do (new_event(span, [2, 3]), new_event(at, 4.5), new_event(ros, [[7, 250000000], [8, 0]])) <- go.
        out(E) <- (span or at or ros) where E = y.
        null do new_event(dt, datime(2014, 10, 19, 20, 10, 5, 0)) <- go2.
        was_dt <- dt.
    """)
    out = engine.feed_batch([("go", 9), ("go2", 10)])
    assert events(out) == [("out(y)", 2, 3), ("out(y)", 4.5, 4.5), ("out(y)", 7.25, 8),
                           ("was_dt", 1413749405, 1413749405)]


def test_new_event_from_a_where_condition_and_a_static_rule():
    engine = load("""
        echo(X) :- new_event(echoed(X)).
        r(X) <- ping(X) where echo(X).
        pong(X) <- echoed(X).
    """)
    assert [e for e, _, _ in events(engine.feed("ping(1)", 1))] == ["r(1)", "pong(1)"]


def test_new_event_in_a_directive_is_processed_before_the_first_input(tmp_path, swipl):
    source = ":- new_event(boot, 0).\nstarted <- boot.\nafter_boot(X) <- boot seq x(X).\n"
    engine = load(source)
    assert [e for e, _, _ in events(engine.feed("x(1)", 1))] == ["started", "after_boot(1)"]
    program = tmp_path / "p.pl"
    program.write_text(compile_source(source, "p.rtl").prolog)
    (tmp_path / "e.jsonl").write_text('{"event": "x(1)", "t": 1}\n')
    run = subprocess.run([swipl, str(program), str(tmp_path / "e.jsonl")], capture_output=True, text=True,
                         check=True)
    assert [json.loads(line)["event"] for line in run.stdout.splitlines()] == ["started", "after_boot(1)"]


def test_a_bad_new_event_is_a_warning_and_processing_goes_on():
    engine = load("""
        null do new_event(half(_)) <- a.
        null do new_event(bad, not_a_time) <- a.
        fine <- a.
    """)
    assert [e for e, _, _ in events(engine.feed("a", 1))] == ["fine"]
    assert [e for e, _, _ in events(engine.feed("a", 2))] == ["fine"]


def test_min_max_and_datime_minus_datime():
    engine = load("""
        m(Lo, Hi) <- v(X, Y) where (min(X, Y, Lo), max(X, Y, Hi)).
        d(S) <- two(T1, T2) where datime_minus_datime(T1, T2, S).
    """)
    out = engine.feed_batch([
        ("v(5, 2)", 1),
        ("v(1.5, 1.5)", 2),
        ("two(datime(2020,1,1,0,0,10,999), datime(2020,1,1,0,1,0,0))", 3),   # counter ignored, T1 - T2 (ETALIS)
        ("two([100, 900000000], [40, 0])", 4),                                # ROS stamps
        ("two(datime(1000, 3), datime(990, 1))", 5),                          # ETALIS compact datime/2
    ])
    assert [e for e, _, _ in events(out)] == ["m(2,5)", "m(1.5,1.5)", "d(-50)", "d(60)", "d(10)"]


def test_ins_static_rule_and_del_static_rule_change_what_conditions_see():
    engine = load("""
        :- dynamic trusted/1, vip/1.
        null do ins_static_rule(trusted(X)) <- trust(X).
        null do del_static_rule(trusted(X)) <- distrust(X).
        null do ins_static_rule((vip(X) :- trusted(X), X \\== nobody)) <- upgrade.
        ok(X) <- req(X) where trusted(X).
        vip_req(X) <- req(X) where vip(X).
    """)
    out = engine.feed_batch([("req(a)", 1), ("trust(a)", 2), ("req(a)", 3), ("upgrade", 4), ("req(a)", 5),
                             ("distrust(a)", 6), ("req(a)", 7)])
    assert [(e, s) for e, s, _ in events(out)] == [("ok(a)", 3), ("ok(a)", 5), ("vip_req(a)", 5)]


def test_ins_static_rule_on_a_static_predicate_says_to_declare_it_dynamic():
    engine = load("fixed(1).\nnull do ins_static_rule(fixed(2)) <- go.\nf(X) <- q where fixed(X).\n")
    engine.feed("go", 1)                                    # reported as a warning
    assert [e for e, _, _ in events(engine.feed("q", 2))] == ["f(1)"]
    with pytest.raises(Exception, match="dynamic"):
        engine.bridge.once("retalis:ins_static_rule(fixed(3))")
