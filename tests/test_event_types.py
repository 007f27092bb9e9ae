"""`--max-event-types N` (issue 35, 16): SWI-Prolog keeps the functor of each event type read
for good, so a run may cap the event types it takes; a line of a new type beyond the cap is
rejected on its line and counted, on every road (swipl, the handover, the Python driver, the
Engine), and a refused plain text makes no functor."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from retalisc.driver.engine import Engine
from test_signals import compiled_case

ROOT = Path(__file__).resolve().parent.parent
LINES = ['{"event": "t1(1)", "t": 1}', '{"event": "t2(1)", "t": 2}', '{"event": "t1(2)", "t": 3}',
         '{"event": "t3(1)", "t": 4}', '{"event": "t4(1) + x", "t": 5}', '{"event": "t2(1, 2)", "t": 6}',
         '{"event": "t2(5)", "t": 7}']
REJECTED = {4: "t3/1", 5: "(+)/2", 6: "t2/2"}


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    return compiled_case(tmp_path_factory.mktemp("types"), "r(X) <- t1(X).\n", "\n".join(LINES) + "\n")


def assert_capped(run, events):
    assert run.returncode == 0, run.stderr
    rejected = [line for line in run.stderr.splitlines() if ": rejected: " in line]
    assert rejected == [f"{events}:{n}: rejected: a new event type {t} beyond the 2 this run takes "
                        "(--max-event-types)" for n, t in sorted(REJECTED.items())], run.stderr
    assert "4 events in, 2 derived, 3 rejected" in run.stderr.splitlines()[-1]


def test_swipl_takes_at_most_n_event_types_and_makes_no_functor_for_a_refused_one(case, swipl):
    _, events, compiled = case
    goal = "at_halt(( current_functor(t3, 1) -> writeln(user_error, made) ; writeln(user_error, not_made) ))"
    run = subprocess.run([swipl, "-g", goal, str(compiled), "--max-event-types=2", str(events)],
                         capture_output=True, text=True, timeout=60)
    assert "not_made" in run.stderr.splitlines(), run.stderr
    run.stderr = "\n".join(line for line in run.stderr.splitlines() if line != "not_made")
    assert_capped(run, events)


@pytest.mark.parametrize("out", [[], ["--out", "OUT"]])      # handed over to swipl; the Python driver
def test_retalisc_run_takes_at_most_n_event_types(case, tmp_path, out):
    program, events, _ = case
    out = [str(tmp_path / "out.jsonl") if o == "OUT" else o for o in out]
    run = subprocess.run([sys.executable, "-m", "retalisc", "run", str(program), "--events", str(events),
                          "--max-event-types", "2", *out], capture_output=True, text=True, timeout=120,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert_capped(run, events)


def test_a_bad_max_event_types_is_a_usage_error(case, swipl):
    _, events, compiled = case
    run = subprocess.run([swipl, str(compiled), "--max-event-types=0", str(events)], capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 2
    assert run.stderr == "error: --max-event-types=0: expected a positive integer or inf\n"


def test_the_engine_takes_the_flag_and_a_new_engine_forgets_it():
    engine = Engine.from_source("r(X) <- t1(X).\n")
    engine.set_flag("max_event_types", "2")
    _, rejected = engine.feed_lines("\n".join(LINES) + "\n")
    assert {r.line: r.reason for r in rejected} == {
        n: f"a new event type {t} beyond the 2 this run takes (--max-event-types)" for n, t in REJECTED.items()}
    again = Engine.from_source("r(X) <- t1(X).\n")
    _, rejected = again.feed_lines("\n".join(LINES) + "\n")
    assert rejected == []
