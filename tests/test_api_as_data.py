"""The Python API passes values to Prolog as data: no text handed to an Engine method runs as
code. Each test tries to smuggle a goal (`shell('touch MARKER')`, `halt`)
through one argument; the marker file must never appear and the engine must stay usable."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.bridge import Bridge, GoalFailed, PrologError
from retalisc.driver.engine import Engine, QueryError

PROGRAM = """
located(s1, kitchen).
pair(X) <- a(X) seq b(X).
echo(X) <- ping(X).
"""


@pytest.fixture
def engine():
    e = Engine.from_source(PROGRAM, "as_data.rtl")
    e.set_flag("max_delay", "inf")
    e.set_flag("echo_input", "false")
    return e


def smuggle(marker: Path) -> str:
    return f"shell('touch {marker}')"


def usable(engine: Engine, t: float = 100.0) -> None:
    """The engine still processes events and derives from them."""
    out = engine.feed("ping(ok)", t)
    assert [(o.event, o.start) for o in out] == [("echo(ok)", t)]


def test_feed_text_that_closes_the_term_runs_nothing(engine, tmp_path):
    marker = tmp_path / "fed"
    # Before: the event text was pasted into `rtl_feed_events([event(add, TEXT, 1, 1)], Out)`,
    # so this text completed that goal, ran shell/1 and opened a second call.
    injection = f"a(1), 1, 1)], _), {smuggle(marker)}, retalis:rtl_feed_events([event(add, b(1)"
    with pytest.raises(PrologError, match="[Ss]yntax"):
        engine.feed(injection, 1)
    with pytest.raises(PrologError, match="[Ss]yntax"):
        engine.feed(f"a(1)), {smuggle(marker)}", 1)
    assert not marker.exists()
    usable(engine)


def test_the_other_feeding_paths_are_data_too(engine, tmp_path):
    marker = tmp_path / "lines"
    out, rejected = engine.feed_lines(f'{{"event": "a(1)", "t": 1}}\n", 1, Out), {smuggle(marker)}, x("')
    assert out == [] and rejected and rejected[0].line == 2
    with pytest.raises(PrologError):
        engine.set_flag("max_delay", f"1), {smuggle(marker)}, retalis:rtl_set_flag(max_delay, 1")
    assert not marker.exists()
    usable(engine)


@pytest.mark.parametrize("text, message", [
    ("a(1). halt", "[Ss]yntax"),            # trailing text after the term
    ("a(1). b(2)", "[Ss]yntax"),
    ("a(X)", "ground"),                     # not ground
    ("smoke(_)", "ground"),
    ("X", "ground"),
    ("42", "event"),                        # not callable
    ("", "[Ss]yntax"),
    ("   ", "[Ss]yntax"),
])
def test_feed_rejects_what_is_not_one_ground_event(engine, text, message):
    with pytest.raises(PrologError, match=message):
        engine.feed(text, 1)
    usable(engine)


def test_a_final_full_stop_and_comments_are_fine(engine):
    assert engine.feed("a(1).", 1) == []
    out = engine.feed("b(1) . % the partner", 2)
    assert [o.event for o in out] == ["pair(1)"]


def test_a_bad_item_stops_the_whole_batch_before_anything_runs(engine, tmp_path):
    marker = tmp_path / "batch"
    with pytest.raises(PrologError, match="event 1 of the batch"):
        engine.feed_batch([("a(1)", 1), (f"b(1)), {smuggle(marker)}", 2), ("b(1)", 3)])
    assert not marker.exists()
    assert engine.stats()["events"] == 0                # a(1) was not processed either
    assert engine.clock() == -math.inf


@pytest.mark.parametrize("start, end, error", [
    (math.inf, None, ValueError), (math.nan, None, ValueError), (-math.inf, 1, ValueError),
    ("1", None, TypeError), (True, None, TypeError), (None, None, TypeError), (3, 2, ValueError),
])
def test_bad_times_are_refused_before_prolog_sees_them(engine, start, end, error):
    with pytest.raises(error):
        engine.feed("a(1)", start, end)
    assert engine.stats()["events"] == 0
    usable(engine)


def test_prolog_checks_the_values_too(engine):
    # The API predicates do not rely on the Python checks.
    bridge = engine.bridge
    for item in (["add", "a(1)", math.inf, math.inf], ["add", "a(1)", 2, 1], ["shell", "a(1)", 1, 1],
                 ["add", 42, 1, 1], ["add", "a(1)", "1", 1], ["add", "a(1)", 1]):
        with pytest.raises(PrologError, match="event 0 of the batch"):
            bridge.apply("rtl_api", "rtl_api_feed_events", [item])
    assert engine.stats()["events"] == 0
    usable(engine)


def test_set_flag_name_and_value_are_data(engine, tmp_path):
    marker = tmp_path / "flag"
    with pytest.raises(PrologError):
        engine.set_flag("max_delay", f"1), {smuggle(marker)}, x(1")
    with pytest.raises(PrologError):
        engine.set_flag(f"max_delay, 1), {smuggle(marker)}, x(y", "1")
    with pytest.raises(PrologError, match="[Ss]yntax"):
        engine.set_flag("max_delay", "2. halt")
    assert not marker.exists()
    usable(engine)


def test_subscribe_arguments_are_data(engine, tmp_path):
    marker = tmp_path / "sub"
    attempts = [
        ("ops", f"a(X)), {smuggle(marker)}, b(X", None, "[]"),
        ("ops", "a(X)", f"X), {smuggle(marker)}, t(X", "[]"),
        ("ops", "a(X)", None, f"[]), {smuggle(marker)}, x(["),
        ("ops", "a(X)", None, f"[{smuggle(marker)}]"),              # parses, but the sandbox refuses it
        (f"ops\"), {smuggle(marker)}, x(\"", "a(X)", None, "[]"),
    ]
    for consumer, pattern, template, conditions in attempts[:-1]:
        with pytest.raises(PrologError):
            engine.subscribe(consumer, pattern, template, conditions)
    odd = engine.subscribe(attempts[-1][0], "a(X)")        # an odd consumer name is just a name
    out = engine.feed("a(7)", 1)
    assert [(o.event, o.consumer) for o in out] == [("a(7)", attempts[-1][0])]
    with pytest.raises(PrologError):
        engine.unsubscribe(f"{odd}), {smuggle(marker)}, x(1")
    engine.unsubscribe(odd)
    assert not marker.exists()
    usable(engine)


def test_subscription_texts_share_variables_by_name(engine):
    engine.subscribe("ui", "a(X)", "seen(X, Y)", "[located(X, Y)]")
    out = engine.feed_batch([("a(s1)", 1), ("a(s9)", 2)])
    assert [(o.event, o.consumer) for o in out] == [("seen(s1,kitchen)", "ui")]


def test_rule_labels_and_rule_text_are_data(engine, tmp_path):
    marker = tmp_path / "rule"
    with pytest.raises(PrologError, match="does not exist"):
        engine.remove_rule(f"r1), {smuggle(marker)}, x(1")
    with pytest.raises(Exception):
        engine.add_rules(f"x(X) <- a(X)), {smuggle(marker)}, y(X).")
    assert not marker.exists()
    usable(engine)


@pytest.mark.parametrize("goal", [
    "true), shell('touch {m}'), (true",
    "true. shell('touch {m}')",
    "located(A, B)\n.\nshell('touch {m}').",
])
def test_queries_are_read_as_one_term(engine, tmp_path, goal):
    marker = tmp_path / "query"
    with pytest.raises(QueryError) as refused:
        engine.query(goal.format(m=marker))
    assert refused.value.kind == "syntax"
    with pytest.raises(QueryError):
        engine.query_all(goal.format(m=marker))
    with pytest.raises(QueryError):
        engine.post_synchronized(goal.format(m=marker), 1.0)
    assert not marker.exists()
    assert engine.query("located(s1, R).") == {"R": "kitchen"}


def test_query_ids_and_memory_requests_are_data(engine, tmp_path):
    marker = tmp_path / "memory"
    out = engine.post_synchronized("located(s1, R)", 1.0, query_id=f"q'), {smuggle(marker)}, x('")
    assert out[0].query["query"] == f"q'), {smuggle(marker)}, x('"
    with pytest.raises(QueryError):
        engine.memory(f"d_mem(x)), {smuggle(marker)}, x(1")
    with pytest.raises(QueryError):
        engine.memory(f"c_mem(m, a(_)-{smuggle(marker)}, 1, inf)")     # conditions not in a list
    assert not marker.exists()
    usable(engine)


def test_bridge_apply_passes_values_not_source():
    bridge = Bridge()
    text = "a), shell('touch /nonexistent/x'), atom_length(b"
    assert bridge.apply("system", "atom_length", text) == str(len(text))
    assert bridge.apply("lists", "sum_list", [1, 2, 3.5]) == "6.5"
    assert bridge.apply("system", "string_concat", "héllo ", "wörld ✓") == "héllo wörld ✓"
    assert bridge.apply("lists", "append", [["x"], [1, [2.5]]]) == "[x,1,[2.5]]"
    assert bridge.apply("system", "atom_length", "x" * 100_000) == "100000"
    with pytest.raises(GoalFailed):
        bridge.apply("lists", "last", [])
    with pytest.raises(PrologError, match="Unknown procedure"):
        bridge.apply("user", "no_such_api_predicate", 1)
    for bad in (None, True, object(), {"a": 1}):
        with pytest.raises(TypeError):
            bridge.apply("system", "atom_length", bad)
    with pytest.raises(ValueError):
        bridge.apply("system", "atom_length", 2 ** 70)


FRAGMENTS = ["a(1)", "b(", ")", "(", ",", ".", " ", "\n", "'", '"', "%", "/*", "*/", "X", "_", "[", "]", ":-",
             "halt", "shell('touch MARKER')", "assertz(p)", "0'", "\\", "|", "{", "}", "`", "ü", "-", "1.0Inf"]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.sampled_from(FRAGMENTS), min_size=1, max_size=8).map("".join))
def test_no_text_given_to_the_api_runs_code(engine, tmp_path, text):
    marker = tmp_path / "MARKER"
    text = text.replace("MARKER", str(marker))
    for attempt in (lambda: engine.feed(text, 1),
                    lambda: engine.set_flag("max_delay", text),
                    lambda: engine.query(text),
                    lambda: engine.subscribe("c", text),
                    lambda: engine.memory(text),
                    lambda: engine.remove_rule(text)):
        try:
            attempt()
        except (PrologError, QueryError):
            pass
    assert not marker.exists()
    engine.set_flag("max_delay", "inf")
    engine.clear()
    usable(engine)


def test_active_query_goals_facts_and_ids_are_data(tmp_path):
    from retalisc.driver.active_queries import ActiveQueries

    marker = tmp_path / "aq"
    aq = ActiveQueries.from_source("path(X, Y) :- edge(X, Y).\nedge(0, 1).\n", "aq_data.pl")
    for goal in (f"path(0, X)), {smuggle(marker)}, path(0, (X", f"path(0, X). {smuggle(marker)}", smuggle(marker)):
        with pytest.raises(PrologError):
            aq.register("q", goal)
    with pytest.raises(PrologError):
        aq.assert_fact(f"edge(1, 2)), {smuggle(marker)}, edge((3")
    odd = "q'), shell('x"                        # an id is a name, whatever its characters
    assert aq.register(odd, "path(0, X)") == ["path(0,1)"]
    added = []
    aq.on_add(lambda q, a: added.append((q, a)))
    aq.assert_fact("edge(0, 2)")
    assert added == [(odd, "path(0,2)")]
    aq.unregister(odd)
    assert not marker.exists()
