"""Rules added while events flow (a control line `add_rule`, ins_event_rule/1 in an action) compile
in the Python process when the runtime runs inside one (an Engine serves the compiler to
rtl_rules.pl through retalisc_bridge:python_call/4), and in a `retalisc compile-rules` subprocess
in a standalone `swipl PROGRAM.pl`. The subprocess is found through RETALISC_PYTHON first: set to
a script that leaves a canary and fails, it shows whether a process was started. The standalone
run (with this Python as RETALISC_PYTHON) is the oracle for what the in-process road derives and
rejects."""
import json
import os
import re
import subprocess
import sys
import threading

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.bridge import Bridge
from retalisc.driver.engine import Engine
from retalisc.driver.swipl_handover import hand_over

from stream_paths import jsonl

PROGRAM = ("r1 : seen(X) <- a(X).\n"
           'null do ins_event_rule("late2 : both(X) <- a(X) and b(X)") <- start.\n')

EVENTS = jsonl(
    ("a(1)", 1),
    {"op": "add_rule", "rule": "late : ab(X) <- a(X) seq b(X)."},
    ("b(1)", 2), ("a(2)", 3), ("b(2)", 4),
    {"op": "add_rule", "rule": "bad(Y) <- a(X)."},
    ("start", 5), ("a(3)", 6), ("b(3)", 7),
    {"op": "delete_rule", "rule": "late"},
    {"op": "add_rule", "rule": "late : ab(X) <- b(X) seq a(X)."},
    ("b(4)", 8), ("a(4)", 9),
    {"op": "add_rule", "rule": "r1 : again(X) <- a(X)."},              # the label is in use
)


@pytest.fixture
def canary(tmp_path, monkeypatch):
    """RETALISC_PYTHON is a script that leaves a file and fails: the file shows whether the
    runtime started the compiler as a process."""
    marker = tmp_path / "started"
    script = tmp_path / "python"
    script.write_text(f"#!/bin/sh\necho \"$@\" >> '{marker}'\nexit 3\n")
    script.chmod(0o755)
    monkeypatch.setenv("RETALISC_PYTHON", str(script))
    return marker


def _engine_run(events: str):
    engine = Engine.from_source(PROGRAM, "in_process.rtl")
    produced, rejected = engine.feed_lines(events, allow_control=True)
    return [(o.event, o.start, o.end) for o in produced], [(r.line, r.reason) for r in rejected]


def _standalone_run(tmp_path, events: str):
    program, events_file = tmp_path / "standalone.pl", tmp_path / "events.jsonl"
    program.write_text(compile_source(PROGRAM, "standalone.rtl").prolog, encoding="utf-8")
    events_file.write_text(events, encoding="utf-8")
    env = {**os.environ, "RETALISC_PYTHON": sys.executable}
    run = subprocess.run(["swipl", str(program), "--allow-control", str(events_file)], capture_output=True,
                         text=True, timeout=120, cwd=tmp_path, env=env)
    assert run.returncode == 0, run.stderr
    derived = [(d["event"], d["start"], d["end"]) for d in map(json.loads, run.stdout.splitlines())]
    rejected = [(int(line), reason) for line, reason in
                re.findall(rf"^{re.escape(str(events_file))}:(\d+): rejected: (.*)$", run.stderr, re.M)]
    return derived, rejected


def test_an_in_process_control_line_starts_no_process(canary):
    derived, rejected = _engine_run(EVENTS)
    assert not canary.exists(), canary.read_text()
    assert ("ab(2)", 3, 4) in derived and ("both(3)", 6, 7) in derived and ("ab(4)", 8, 9) in derived
    assert [line for line, _ in rejected] == [6, 14]
    assert "ins_event_rule:1:5: error: variable Y of the rule head does not occur in the pattern" in rejected[0][1]


def test_in_process_and_standalone_derive_and_reject_alike(tmp_path, canary):
    in_process = _engine_run(EVENTS)
    assert not canary.exists()
    assert in_process == _standalone_run(tmp_path, EVENTS)


def test_a_command_line_run_in_python_compiles_in_process(tmp_path, canary):
    """`retalisc run` served by Python (here: --out) runs Prolog in its one thread
    (Bridge.run_in_calling_thread): the compiler is called back in that thread."""
    program, events, out = tmp_path / "p.rtl", tmp_path / "e.jsonl", tmp_path / "out.jsonl"
    program.write_text(PROGRAM)
    events.write_text(EVENTS)
    run = subprocess.run([sys.executable, "-m", "retalisc", "run", str(program), "--events", str(events),
                          "--allow-control", "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert not canary.exists()
    assert [json.loads(line)["event"] for line in out.read_text().splitlines()].count("ab(2)") == 1
    assert ":6: rejected: ins_event_rule/1: the event rule does not compile: ins_event_rule:1:5:" in run.stderr


def test_served_functions_from_any_thread():
    bridge = Bridge()
    if not bridge.serve("test_join", lambda *parts: "+".join(parts)):
        pytest.skip("the janus backend serves no Python functions")
    calls = []

    def raises(*_):
        calls.append(threading.current_thread().name)
        raise ValueError("no")

    bridge.serve("test_raises", raises)
    bridge.serve("test_calls_back", lambda: bridge.once("true") and "called")
    goal = 'retalisc_bridge:python_call({}, {}, S, R)'
    results = []
    worker = threading.Thread(target=lambda: results.append(bridge.once(goal.format("test_join", '["a", b]'), "S-R")))
    worker.start()
    worker.join(30)
    assert results == ['ok-"a+b"']
    assert bridge.once(goal.format("test_raises", "[]"), "S-R") == "error-\"test_raises: ValueError: no\""
    assert calls
    assert bridge.once(goal.format("nothing_served", "[]"), "S") == "unknown"
    status = bridge.once(goal.format("test_calls_back", "[]"), "S-R")        # refused, not a deadlock
    assert status.startswith("error-") and "cannot call Prolog" in status
    assert bridge.once(goal.format("test_join", "[1]"), "S") == "error"              # strings only


@pytest.mark.parametrize("given", ["", "/opt/other/python"])
def test_the_hand_over_to_swipl_compiles_rules_with_this_python(monkeypatch, given):
    """`retalisc run` handed over to `swipl` runs `retalisc compile-rules` with the Python that
    runs `retalisc` (RETALISC_PYTHON), unless RETALISC_PYTHON says another."""
    started = []
    monkeypatch.setenv("RETALISC_PYTHON", given)
    monkeypatch.setattr(os, "execve", lambda path, argv, env: started.append(env))
    hand_over(["/bin/true"])
    assert [env["RETALISC_PYTHON"] for env in started] == [given or sys.executable]
