"""Subscriptions (thesis 3.4, A.2.6): the Retalis, thesis and Python forms."""
import json
import subprocess

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.bridge import PrologError
from retalisc.driver.engine import Engine

RULES = """
r1 : alarm(X) <- (smoke(X) and heat(X)).10.
"""


def load(source):
    """An engine for `source`; runtime flags are per process: no input echo here."""
    engine = Engine.from_source(source)
    engine.set_flag("echo_input", "false")
    return engine


def deliveries(output, consumer=None):
    return [(o.event, o.start, o.end, o.op) for o in output
            if o.consumer is not None and (consumer is None or o.consumer == consumer)]


def test_retalis_subscribe_delivers_input_and_derived_events_in_processing_order():
    engine = load(RULES + "subscribe(alarm(X), [], _, ops, s1).\n"
                                        "subscribe(smoke(X), [], seen(X), ops, s2).\n")
    out = engine.feed_batch([("smoke(k)", 1), ("heat(k)", 2)])
    assert [(o.event, o.consumer) for o in out] == [
        ("seen(k)", "ops"),                       # the input event, as its template
        ("alarm(k)", None),                       # the derived event on the output
        ("alarm(k)", "ops"),                      # and delivered to the subscriber right after
    ]
    assert json.loads(out[2].line) == {"event": "alarm(k)", "start": 1, "end": 2, "consumer": "ops"}


def test_conditions_filter_and_template_shares_the_pattern_variables():
    engine = load(RULES + "subscribe(alarm(X), [X \\== kitchen], warn(room(X)), ops, s1).\n")
    out = engine.feed_batch([("smoke(kitchen)", 1), ("heat(kitchen)", 2), ("smoke(hall)", 3), ("heat(hall)", 4)])
    assert deliveries(out) == [("warn(room(hall))", 3, 4, "add")]


def test_conditions_may_call_static_predicates_and_yield_one_delivery_per_solution():
    engine = load(RULES + "watcher(hall, alice).\nwatcher(hall, bob).\n"
                                        "subscribe(alarm(X), [watcher(X, W)], tell(W, X), ops, s1).\n")
    out = engine.feed_batch([("smoke(hall)", 1), ("heat(hall)", 2), ("smoke(cellar)", 3), ("heat(cellar)", 4)])
    assert deliveries(out) == [("tell(alice,hall)", 1, 2, "add"), ("tell(bob,hall)", 1, 2, "add")]


def test_delete_subscription_stops_delivery():
    engine = load(RULES + "subscribe(smoke(X), [], _, ops, s1).\n"
                                        "null do delete_subscription(ops, s1) <- stop.\n")
    out = engine.feed_batch([("smoke(a)", 1), ("stop", 2), ("smoke(b)", 3)])
    assert deliveries(out) == [("smoke(a)", 1, 1, "add")]


def test_sub_with_now_only_sees_events_from_the_clock_on_and_unsub_ends_it():
    engine = load(RULES + "null do sub(100, camCtrl, smoke(L)-[], pos_goal(L), now) <- start.\n"
                                        "null do unsub(100, now) <- stop.\n")
    out = engine.feed_batch([("smoke(a)", 1), ("start", 5), ("smoke(b)", 4), ("smoke(c)", 6), ("stop", 7),
                             ("smoke(d)", 6.5), ("smoke(e)", 8)])
    # b occurred before the subscription's start (5), d before its end (7), e after it
    assert deliveries(out, "camCtrl") == [("pos_goal(c)", 6, 6, "add"), ("pos_goal(d)", 6.5, 6.5, "add")]


def test_sub_accepts_a_bare_event_as_query_as_in_the_thesis():
    engine = load(RULES + "sub(s_1, moving_objects, smoke(O), obj(O), 0).\n")
    out = engine.feed_batch([("smoke(x)", 1)])
    assert deliveries(out, "moving_objects") == [("obj(x)", 1, 1, "add")]


def test_subscribe_between_bounds_the_occurrence_interval():
    engine = load(RULES + "subscribe_between(ops, alarm(X)-[], X, 10, 20).\n")
    out = engine.feed_batch([("smoke(a)", 9), ("heat(a)", 11),     # [9, 11]: starts before 10
                             ("smoke(b)", 12), ("heat(b)", 15),    # [12, 15]: inside
                             ("smoke(c)", 19), ("heat(c)", 21)])   # [19, 21]: ends after 20
    assert deliveries(out) == [("b", 12, 15, "add")]


def test_deleted_events_are_delivered_with_op_retract():
    engine = load(RULES + "subscribe(alarm(X), [], gone(X), ops, s1).\n")
    engine.feed_batch([("smoke(a)", 1), ("heat(a)", 2)])
    out = engine.feed("heat(a)", 2, op="retract")
    assert deliveries(out) == [("gone(a)", 1, 2, "retract")]
    assert json.loads([o for o in out if o.consumer][0].line)["op"] == "retract"


def test_python_subscribe_with_callback_bounds_and_unsubscribe():
    engine = load(RULES)
    got = []
    sid = engine.subscribe("ui", "alarm(X)", "show(X)", "[X \\== quiet]", start=2, callback=got.append)
    engine.feed_batch([("smoke(a)", 1), ("heat(a)", 2),           # starts at 1 < 2: not delivered
                       ("smoke(b)", 3), ("heat(b)", 4),
                       ("smoke(quiet)", 5), ("heat(quiet)", 6)])
    engine.unsubscribe(sid)                                        # at the clock, 6
    engine.feed_batch([("smoke(c)", 7), ("heat(c)", 8)])
    assert [(o.event, o.start, o.end, o.consumer) for o in got] == [("show(b)", 3, 4, "ui")]


def test_python_subscription_ids_are_fresh_and_callbacks_only_see_their_consumer():
    engine = load(RULES)
    a, b = [], []
    id1 = engine.subscribe("one", "smoke(X)", callback=a.append)
    id2 = engine.subscribe("two", "heat(X)", end=5, callback=b.append)
    assert id1 != id2
    engine.feed_batch([("smoke(x)", 1), ("heat(x)", 2), ("heat(y)", 6)])
    assert [o.event for o in a] == ["smoke(x)"]
    assert [o.event for o in b] == ["heat(x)"]


@pytest.mark.parametrize("args, message", [
    (("ops", "alarm(X", None, "[]"), "Syntax error"),
    (("ops", "alarm(X)", None, "notalist"), "list_of_goals"),
    (("ops", "alarm(X)", None, "[1]"), "list_of_goals"),
    (("ops", "42", None, "[]"), "event_pattern"),
])
def test_bad_subscriptions_raise_a_clear_error_and_register_nothing(args, message):
    engine = load(RULES)
    with pytest.raises(PrologError, match=message):
        engine.subscribe(*args)
    out = engine.feed_batch([("smoke(a)", 1), ("heat(a)", 2)])
    assert deliveries(out) == []


def test_duplicate_id_and_unknown_unsubscribe_are_errors():
    engine = load(RULES)
    engine.subscribe("ops", "smoke(X)")
    bridge = engine.bridge
    bridge.once("retalis:subscribe(heat(X), [], _, ops, dup)")
    with pytest.raises(PrologError, match="subscription"):
        bridge.once("retalis:subscribe(heat(X), [], _, ops, dup)")
    with pytest.raises(PrologError, match="does not exist"):
        engine.unsubscribe("no_such_id")


def test_a_failing_condition_is_a_warning_not_a_crash():
    engine = load(RULES + "subscribe(smoke(X), [X > 1], _, ops, s1).\n")
    out = engine.feed_batch([("smoke(abc)", 1), ("smoke(5)", 2)])   # abc > 1 raises a type error
    assert deliveries(out) == [("smoke(5)", 2, 2, "add")]


def test_standalone_swipl_tags_deliveries_and_writes_consumer_files(tmp_path, swipl):
    program = tmp_path / "p.pl"
    program.write_text(compile_source(RULES + "subscribe(alarm(X), [], _, '/ops/alarms', s1).\n"
                                               "sub(7, log, smoke(X), X, 0).\n", "p.rtl").prolog)
    events = tmp_path / "events.jsonl"
    events.write_text('{"event": "smoke(k)", "t": 1}\n{"event": "heat(k)", "t": 2}\n')
    tagged = subprocess.run([swipl, str(program), str(events)], capture_output=True, text=True, check=True)
    assert [json.loads(line) for line in tagged.stdout.splitlines()] == [
        {"event": "k", "start": 1, "end": 1, "consumer": "log"},
        {"event": "alarm(k)", "start": 1, "end": 2},
        {"event": "alarm(k)", "start": 1, "end": 2, "consumer": "/ops/alarms"},
    ]
    split = subprocess.run([swipl, str(program), f"--consumer-dir={tmp_path / 'out'}", str(events)],
                           capture_output=True, text=True, check=True)
    assert split.stdout.splitlines() == ['{"event": "alarm(k)", "start": 1, "end": 2}']
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["log.jsonl", "ops_alarms.jsonl"]
    assert (tmp_path / "out" / "ops_alarms.jsonl").read_text() == \
        '{"event": "alarm(k)", "start": 1, "end": 2, "consumer": "/ops/alarms"}\n'


def test_cli_run_consumer_dir_and_subscribe_option(tmp_path, retalisc_cmd):
    program = tmp_path / "p.rtl"
    program.write_text(RULES + "subscribe(alarm(X), [], _, ops, s1).\n")
    events = tmp_path / "events.jsonl"
    events.write_text('{"event": "smoke(k)", "t": 1}\n{"event": "heat(k)", "t": 2}\n')
    run = subprocess.run(retalisc_cmd + ["run", str(program), "--events", str(events),
                                         "--subscribe", "mine=smoke(X)-[X == k]=>s(X)",
                                         "--consumer-dir", str(tmp_path / "c")],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ['{"event": "alarm(k)", "start": 1, "end": 2}']
    assert (tmp_path / "c" / "mine.jsonl").read_text() == '{"event": "s(k)", "start": 1, "end": 1, "consumer": "mine"}\n'
    assert (tmp_path / "c" / "ops.jsonl").read_text() == \
        '{"event": "alarm(k)", "start": 1, "end": 2, "consumer": "ops"}\n'
    bad = subprocess.run(retalisc_cmd + ["run", str(program), "--events", str(events), "--subscribe", "oops"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "CONSUMER=QUERY" in bad.stderr


def test_an_ended_subscription_is_dropped_once_the_clock_has_passed_its_end():
    engine = load(RULES)
    engine.set_flag("max_delay", "1.0")
    engine.subscribe("c", "smoke(X)", end=5)
    out = engine.feed_batch([("smoke(a)", 1), ("smoke(b)", 7)])
    assert deliveries(out) == [("smoke(a)", 1, 1, "add")]
    assert engine.bridge.all("retalis:rtl_subscription(I, C, _, _, _, _, _)", "I-C") == []
