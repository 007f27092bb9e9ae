"""The one feed loop (retalisc/driver/feed.py, docs/architecture.md "The event road"): every
Python road feeds the Engine through it and its text (problems, summary) is made there only; a
road that bypasses it, or writes a rejection or a summary of its own, fails here. And the loop's
pieces behave: the summary text is the runtime's rtl_summary/2, a delivery is printed once on
the recording roads, crash recovery wraps any source."""
from __future__ import annotations

import ast
import io
import json
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retalisc.driver import feed
from retalisc.driver.engine import Engine, OutputEvent

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "retalisc"
FEED = PACKAGE / "driver" / "feed.py"

#: The Engine's feeding calls; only feed.py (the loop's sources) makes them, and the sources that
#: feed something other than an Engine's event road: explain.py's event log (rtl_trace.pl); and
#: the update script of active queries (`ScriptSource`, `retalisc aq` with or without --state).
FEEDING_CALLS = {"feed_lines", "feed_batch", "feed_paced", "advance_clock", "end_of_input", "run_script_batch"}
#: Text only the loop makes: a problem's kind after a place, the summary's words.
RUN_TEXT = [re.compile(r"(^|:)\s*rejected:\s*$"), re.compile(r"events in, "),
            re.compile(r"^\s*derived, $"), re.compile(r"retalis: cannot write")]


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        yield path, ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _docstrings(tree):
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                found.add(id(first.value))
    return found


def test_only_the_loop_feeds_the_engine():
    outside = []
    for path, tree in _modules():
        if path in (FEED, PACKAGE / "driver" / "engine.py"):
            continue
        for node in ast.walk(tree):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr in FEEDING_CALLS):
                outside.append(f"{path.relative_to(ROOT)}:{node.lineno}: .{node.func.attr}(...)")
    assert outside == [], "feed the Engine through retalisc/driver/feed.py (a source of FeedLoop):\n" + \
        "\n".join(outside)


def test_the_text_of_a_run_is_made_by_the_loop_only():
    outside = []
    for path, tree in _modules():
        if path == FEED:
            continue
        docstrings = _docstrings(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
                if any(pattern.search(node.value) for pattern in RUN_TEXT):
                    outside.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.value!r}")
    assert outside == [], "make a run's text with feed.problem_text / where_text / summary_line:\n" + \
        "\n".join(outside)


def test_the_guard_sees_a_road_of_its_own(tmp_path):
    """The check above finds a rejection message written outside the loop."""
    tree = ast.parse('def report(name, n, why):\n    print(f"{name}:{n}: rejected: {why}")\n')
    constants = [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant)]
    assert any(pattern.search(value) for value in constants for pattern in RUN_TEXT)


def test_every_road_runs_the_loop():
    """run_event_file, run_recoverable, the aq script (plain and recoverable), replay_bag,
    explain and the live nodes' consumer all end in FeedLoop.run."""
    roads = {"driver/run.py": "run_event_file", "driver/recovery.py": "run_recoverable",
             "robot_io/replay.py": "replay_bag", "driver/explain.py": "_feed",
             "driver/active_queries.py": "run_script", "live/node.py": "_loop"}
    for relative, function in roads.items():
        tree = ast.parse((PACKAGE / relative).read_text(encoding="utf-8"))
        [definition] = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == function]
        names = {n.id for n in ast.walk(definition) if isinstance(n, ast.Name)}
        assert "FeedLoop" in names, f"{relative}:{function} does not run feed.FeedLoop"
    command = ast.parse((PACKAGE / "commands" / "aq.py").read_text(encoding="utf-8"))
    names = {n.id for n in ast.walk(command) if isinstance(n, ast.Name)}
    modules = {alias.name for n in ast.walk(command) if isinstance(n, ast.Import) for alias in n.names}
    assert "run_script" in names and "subprocess" not in modules, \
        "retalisc aq runs its script through active_queries.run_script (the loop), not a process of its own"
    tree = ast.parse((PACKAGE / "driver" / "recovery.py").read_text(encoding="utf-8"))
    for function in ("run_aq_recoverable",):
        [definition] = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == function]
        assert "FeedLoop" in {n.id for n in ast.walk(definition) if isinstance(n, ast.Name)}


@settings(max_examples=40, deadline=None)
@given(st.fixed_dictionaries({name: st.integers(0, 3_000_000) for name in
                              ("events", "derived", "rejected", "failed", "retracted", "too_late", "late",
                               "timers_refused")}),
       st.floats(0, 10_000, allow_nan=False))
def test_the_summary_is_the_runtimes(counts, seconds):
    """feed.summary_line writes what rtl_summary/2 (the runtime's own roads) writes, for any counts."""
    engine = _engine()
    for name, value in counts.items():
        engine.bridge.once(f"nb_setval(rtl_stat_{name}, {value})")
    try:
        runtime = engine.bridge.call_text(f"rtl_feed:rtl_summary({seconds!r}, S)", "S")
    finally:
        for name in counts:
            engine.bridge.once(f"nb_setval(rtl_stat_{name}, 0)")
    assert feed.summary_line(dict(counts), seconds) == runtime


_ENGINE = []


def _engine():
    if not _ENGINE:
        _ENGINE.append(Engine.from_source("b(X) <- a(X).\n", "summary.rtl"))
    return _ENGINE[0]


def _event(text, start, end, consumer=None, op="add"):
    line = json.dumps({"event": text, "start": start, "end": end, **({"consumer": consumer} if consumer else {})})
    return OutputEvent(text, start, end, consumer, op, line)


def test_a_delivery_of_a_derived_event_is_written_once():
    derived = _event("alarm(k)", 1, 2)
    delivered = _event("alarm(k)", 1, 2, "ops")
    other = _event("look_at(k)", 1, 2, "cam")             # a template instance: not the event
    assert feed.once_per_delivery([derived, other, delivered]) == [other, delivered]
    assert feed.once_per_delivery([derived, _event("b", 1, 1), delivered]) == [derived, _event("b", 1, 1), delivered]
    later = _event("alarm(k)", 1, 3, "ops")               # other times: another event
    assert feed.once_per_delivery([derived, later]) == [derived, later]
    stream = io.StringIO()
    sinks = feed.Sinks([feed.TextSink(stream, "out", owned=False)], once=True)
    sinks.write([derived, delivered])
    assert stream.getvalue() == delivered.line + "\n"
    stream = io.StringIO()
    feed.Sinks([feed.TextSink(stream, "out", owned=False)]).write([derived, delivered])
    assert stream.getvalue().splitlines() == [derived.line, delivered.line]      # the runtime's form


def test_a_line_source_reports_its_problems_through_the_loop(tmp_path, capsys):
    events = tmp_path / "ev.jsonl"
    events.write_text('{"event": "a(1)", "t": 1}\nnot json\n{"event": "a(2)", "t": 2}\n')
    engine = Engine.from_source("b(X) <- a(X).\n", "p.rtl")
    with open(events, "rb") as stream:
        source = feed.LineSource(str(events), feed.file_batches(stream, 2))
        out = io.StringIO()
        status = feed.FeedLoop(engine, source, feed.Sinks([feed.TextSink(out, "out", owned=False)]),
                               signals=False).run()
    assert status == 0
    assert [json.loads(line)["event"] for line in out.getvalue().splitlines()] == ["b(1)", "b(2)"]
    err = capsys.readouterr().err
    assert f"{events}:2: rejected: invalid JSON" in err
    assert err.rstrip().splitlines()[-1].startswith("retalis: 2 events in, 2 derived, 1 rejected, ")


def test_file_batches_positions_let_a_run_go_on_where_it_stopped(tmp_path):
    data = b"".join(f'{{"event": "a({n})", "t": {n}}}\n'.encode() for n in range(1, 12))
    path = tmp_path / "ev.jsonl"
    path.write_bytes(data)
    with open(path, "rb") as stream:
        whole = list(feed.file_batches(stream, 3, limit=1000))
    assert whole[-1].position == len(data) and [b.first for b in whole] == [1, 4, 7, 10]
    with open(path, "rb") as stream:
        rest = list(feed.file_batches(stream, 3, 1000, whole[1].position, whole[1].first + 3))
    assert [b.lines for b in rest] == [b.lines for b in whole[2:]]
    assert [b.first for b in rest] == [7, 10]


@pytest.mark.parametrize("where", ["7", "/odom#3"])
def test_problem_text(where):
    assert feed.problem_text("ev.jsonl", where, "rejected", "why") == f"ev.jsonl:{where}: rejected: why"
    assert feed.where_text(where, "rejected", "why") == f"{where}: rejected: why"
