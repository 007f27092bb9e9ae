"""Clock lines (`{"op": "clock", "t": T}`): a heartbeat written in the input itself, read by
every line reader (`swipl OUT.pl`, `retalisc run`, `Engine.feed_lines`). The clock moves to T
without an event and the timers it passes fire, as with `Engine.advance_clock(T)`."""
import json
import subprocess

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine

from timer_support import fresh

PROGRAM = ("alarm(check(R), 30) <- door_closed(R).\n"
           "empty(R) <- not(seen(_, R)).[door_closed(R), 10].\n")
LINES = [{"event": "door_closed(r1)", "t": 0},
         {"op": "clock", "t": 12},                       # the absence (10 s + max_delay 1) is decided
         {"op": "clock", "t": 5},                         # not later: changes nothing
         {"op": "clock", "t": [31, 0]},                   # the alarm at 30
         {"op": "clock", "event": "x", "t": 40},
         {"op": "clock"}]


def text(lines):
    return "".join(json.dumps(line) + "\n" for line in lines)


def test_clock_lines_fire_timers_in_feed_lines():
    engine = fresh(Engine.from_source(PROGRAM, "clock.rtl"))
    out, rejected = engine.feed_lines(text(LINES))
    assert [(o.event, o.start, o.end) for o in out] == [("empty(r1)", 0, 10), ("check(r1)", 0, 30)]
    assert [(r.line, r.reason) for r in rejected] == [
        (5, 'a clock line ("op": "clock") has no "event"'),
        (6, 'missing time: give "t", or "start" and "end"')]
    assert engine.stats()["events"] == 1                  # clock lines are not events


def test_clock_lines_in_the_standalone_program(tmp_path, swipl):
    program = tmp_path / "clock.pl"
    program.write_text(compile_source(PROGRAM, "clock.rtl", output_name="clock.pl").prolog)
    done = subprocess.run([swipl, str(program), "-"], input=text(LINES), capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0
    assert [json.loads(line) for line in done.stdout.splitlines()] == [
        {"event": "empty(r1)", "start": 0, "end": 10}, {"event": "check(r1)", "start": 0, "end": 30}]
    assert "<stdin>:5: rejected: a clock line" in done.stderr
    assert "1 events in, 2 derived, 2 rejected" in done.stderr


def test_pending_timers_are_capped_and_the_refusals_counted(tmp_path, swipl):
    engine = fresh(Engine.from_source("alarm(check(R), 30) <- door_closed(R).\n", "cap.rtl"))
    engine.set_flag("max_timers", "2")
    try:
        out, rejected = engine.feed_lines(text([{"event": f"door_closed(r{i})", "t": i} for i in range(4)]
                                               + [{"op": "clock", "t": 40}]))
        assert [o.event for o in out] == ["check(r0)", "check(r1)"]     # r2 and r3 found no room
        assert engine.stats()["timers_refused"] == 2
        assert [(w.line, w.text) for w in engine.take_warnings()] == [(3, "2 timers pending (max_timers): a timer due at 32 was not set"),
                                          (4, "2 timers pending (max_timers): a timer due at 33 was not set")]
    finally:
        engine.set_flag("max_timers", "100000")
    program = tmp_path / "cap.pl"
    program.write_text(compile_source("alarm(check(R), 30) <- door_closed(R).\n", "cap.rtl",
                                      output_name="cap.pl").prolog)
    lines = text([{"event": f"door_closed(r{i})", "t": i} for i in range(3)])
    done = subprocess.run([swipl, str(program), "--max-timers=2", "-"], input=lines, capture_output=True,
                          text=True, timeout=60)
    assert "<stdin>:3: warning: 2 timers pending (max_timers): a timer due at 32 was not set" in done.stderr
    assert "1 timers not set (max_timers)" in done.stderr
    bad = subprocess.run([swipl, str(program), "--max-timers=0", "-"], input="", capture_output=True, text=True,
                         timeout=60)
    assert bad.returncode == 2 and "--max-timers=0: expected a positive integer or inf" in bad.stderr
