"""The clock without events: Engine.advance_clock (a heartbeat), the live
heartbeat of `retalisc run --events - --heartbeat SECONDS`, and `--flush-timers` at the end
of the input (retalisc run and the standalone program)."""
import os
import subprocess
import sys

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine
from retalisc.driver.run import WallClock

PROGRAM = "empty(Room) <- not(seen(_, Room)).[door_closed(Room), 1].\nalarm(check(R), 0.5) <- door_closed(R).\n"


def test_advance_clock_fires_the_timers_it_passes_and_never_goes_back():
    engine = Engine.from_source(PROGRAM, "live.rtl")
    engine.clear()
    engine.set_flag("max_delay", "0.2")
    assert engine.feed_batch([("door_closed(k)", 100)]) == []
    assert [o.event for o in engine.advance_clock(100.5)] == ["check(k)"]
    assert engine.advance_clock(99) == [] and engine.clock() == 100.5
    assert engine.advance_clock(101.2) == []                      # 100 + 1 + 0.2 not passed
    assert [(o.event, o.start, o.end) for o in engine.advance_clock(101.3)] == [("empty(k)", 100, 101)]
    with pytest.raises(ValueError):
        engine.advance_clock(float("nan"))
    engine.set_flag("max_delay", "1.0")     # flags are shared by the engines of a process


def test_the_wall_clock_estimate_follows_the_latest_event_that_moved_the_clock():
    now = [1000.0]
    wall = WallClock(lambda: now[0])
    assert wall.estimate() is None
    wall.saw(50.0)
    now[0] += 2.5
    assert wall.estimate() == 52.5
    wall.saw(49.0)                        # a late event does not move the anchor back
    assert wall.estimate() == 52.5
    wall.saw(float("-inf"))
    assert wall.estimate() == 52.5


def _env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in [os.getcwd(), os.environ.get("PYTHONPATH")] if p))


def test_a_live_source_gets_its_absence_while_the_input_is_still_open(tmp_path):
    program = tmp_path / "live.rtl"
    program.write_text(PROGRAM)
    run = subprocess.Popen([sys.executable, "-m", "retalisc", "run", str(program), "--events", "-",
                            "--heartbeat", "0.05", "--max-delay", "0.2"], stdin=subprocess.PIPE,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    try:
        run.stdin.write('{"event": "door_closed(k)", "t": 100}\n')
        run.stdin.flush()
        first, second = run.stdout.readline(), run.stdout.readline()    # nothing else arrives
        assert first.strip() == '{"event": "check(k)", "start": 100, "end": 100.5}'
        assert second.strip() == '{"event": "empty(k)", "start": 100, "end": 101}'
    finally:
        run.stdin.close()
        assert run.wait(timeout=30) == 0


def test_flush_timers_at_the_end_of_the_input(tmp_path, swipl):
    program = tmp_path / "p.rtl"
    program.write_text(PROGRAM)
    events = tmp_path / "e.jsonl"
    events.write_text('{"event": "door_closed(k)", "t": 0}\n')
    compiled = tmp_path / "p.pl"
    compiled.write_text(compile_source(PROGRAM, str(program), output_name="p.pl").prolog)
    expected = ['{"event": "check(k)", "start": 0, "end": 0.5}', '{"event": "empty(k)", "start": 0, "end": 1}']
    runs = [([swipl, str(compiled), str(events)], []),
            ([swipl, str(compiled), "--flush-timers", str(events)], expected),
            ([sys.executable, "-m", "retalisc", "run", str(program), "--events", str(events), "--flush-timers"],
             expected)]
    for command, output in runs:
        result = subprocess.run(command, capture_output=True, text=True, timeout=60, env=_env())
        assert result.returncode == 0, result.stderr
        assert result.stdout.splitlines() == output
