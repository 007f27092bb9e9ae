"""The input limits (docs/runtime.md, "Input limits"): a line too long, a number too long, a time
beyond a float, an event too far in the future, a JSON surrogate escape. Each is rejected on its
line with a located reason, counted, and the lines after it are processed, on every road:
`swipl OUT.pl FILE`, `swipl OUT.pl -`, `retalisc run` (the runtime's loop and the Python
driver's), `Engine.feed_lines`/`feed`, with the C readers on and off."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine

ROOT = Path(__file__).resolve().parent.parent
PROGRAM = "p(X) <- a(X) seq b(X).\n"
SWIPL = shutil.which("swipl") or "swipl"
C_OFF = "rtl_io:rtl_use_fast_reader(false), retractall(rtl_lines:c_decoder)"
GOOD = b'{"event": "a(1)", "t": 1}\n{"event": "b(1)", "t": 2}\n'
AFTER = b'{"event": "a(2)", "t": 3}\n{"event": "b(2)", "t": 4}\n'


@pytest.fixture(scope="module")
def compiled(tmp_path_factory):
    directory = tmp_path_factory.mktemp("limits")
    source = directory / "program.rtl"
    source.write_text(PROGRAM)
    out = directory / "program.pl"
    out.write_text(compile_source(PROGRAM, str(source), output_name="program.pl").prolog, encoding="utf-8")
    return source, out


ROADS = ["swipl", "swipl-stdin", "swipl-no-c", "run", "run-out", "run-stdin-out"]


def run_road(road, compiled, tmp_path, data: bytes, *options: str):
    """(stdout, stderr, name of the input in messages) of one run over `data`."""
    source, program = compiled
    events = tmp_path / "events.jsonl"
    events.write_bytes(data)
    stdin = road.endswith("stdin") or road == "run-stdin-out"
    name = "-" if stdin else str(events)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RETALISC_NO_CACHE": "1"}
    if road.startswith("swipl"):
        command = [SWIPL, *(["-g", C_OFF] if road == "swipl-no-c" else []), str(program),
                   *[f"{o}={v}" for o, v in zip(options[::2], options[1::2])], name]
        out_file = None
    else:
        out_file = tmp_path / "out.jsonl" if road.endswith("out") else None
        command = [sys.executable, "-m", "retalisc", "run", str(source), "--events", name, "--no-progress",
                   *options, *(["--out", str(out_file)] if out_file else [])]
    done = subprocess.run(command, input=data if stdin else None, capture_output=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    stdout = out_file.read_bytes() if out_file else done.stdout
    return stdout.decode(), done.stderr.decode(), "<stdin>" if stdin else str(events)


def assert_rejected_and_went_on(stdout, stderr, name, line, reason):
    assert f"{name}:{line}: rejected: {reason}" in stderr, stderr[-2000:]
    events = [json.loads(text)["event"] for text in stdout.splitlines()]
    assert events == ["p(1)", "p(2)"], stdout[-2000:]
    assert ", 1 rejected" in stderr


# ---- 9: line length ----------------------------------------------------------------------

@pytest.mark.parametrize("road", ROADS)
def test_a_line_too_long_is_rejected_and_the_stream_goes_on(road, compiled, tmp_path):
    long_line = b'{"event": "a(9)", "t": 1.5, "pad": "' + b"x" * 5000 + b'"}\n'
    stdout, stderr, name = run_road(road, compiled, tmp_path, GOOD + long_line + AFTER, "--max-line-bytes", "1000")
    assert_rejected_and_went_on(stdout, stderr, name, 3, "line longer than 1,000 bytes (max_line_bytes)")


@pytest.mark.parametrize("road", ["swipl", "swipl-stdin", "run-out"])
def test_a_line_of_ten_megabytes_under_the_default_limit(road, compiled, tmp_path):
    long_line = b'{"event": "a(9)", "t": 1.5, "pad": "' + b"y" * (10 << 20) + b'"}\n'
    stdout, stderr, name = run_road(road, compiled, tmp_path, GOOD + long_line + AFTER)
    assert_rejected_and_went_on(stdout, stderr, name, 3, "line longer than 1,048,576 bytes (max_line_bytes)")


def test_feed_lines_rejects_a_line_too_long(tmp_path):
    engine = Engine.from_source(PROGRAM)
    engine.set_flag("max_line_bytes", "100")
    text = GOOD.decode() + '{"event": "a(\'' + "é" * 60 + '\')", "t": 1.5}\n' + AFTER.decode()
    output, rejected = engine.feed_lines(text)
    assert [(r.line, r.reason) for r in rejected] == [(3, "line longer than 100 bytes (max_line_bytes)")]
    assert [o.event for o in output] == ["p(1)", "p(2)"]
    output, rejected = engine.feed_lines(text.encode(), 10)        # bytes: the same
    assert [(r.line, r.reason) for r in rejected] == [(12, "line longer than 100 bytes (max_line_bytes)")]


# ---- 15: number size ---------------------------------------------------------------------

@pytest.mark.parametrize("road", ["swipl", "swipl-no-c", "run-out"])
def test_a_number_of_a_million_digits_is_rejected_before_it_is_read(road, compiled, tmp_path):
    line = b'{"event": "a(' + b"7" * 1_000_000 + b')", "t": 1.5}\n'
    stdout, stderr, name = run_road(road, compiled, tmp_path, GOOD + line + AFTER, "--max-line-bytes", "inf")
    assert_rejected_and_went_on(stdout, stderr, name, 3, "more than 4,300 digits in a row at column 14 (max_digits)")


@pytest.mark.parametrize("road", ["swipl", "swipl-no-c"])
def test_the_c_reader_and_the_prolog_reader_agree_on_the_digit_limit(road, compiled, tmp_path):
    line = b'{"event": "a(123456)", "t": 1.5}\n'        # plain: the C reader's case
    stdout, stderr, name = run_road(road, compiled, tmp_path, GOOD + line + AFTER, "--max-digits", "5")
    assert_rejected_and_went_on(stdout, stderr, name, 3, "more than 5 digits in a row at column 14 (max_digits)")


def test_feed_rejects_an_event_text_with_too_many_digits():
    engine = Engine.from_source(PROGRAM)
    with pytest.raises(Exception, match="max_digits"):
        engine.feed("a(" + "1" * 5000 + ")", 1)
    assert [o.event for o in engine.feed("a(1)", 1) + engine.feed("b(1)", 2)] == ["p(1)"]


# ---- 7: a time beyond a float --------------------------------------------------------------

@pytest.mark.parametrize("time", ["1" + "0" * 400, "[1" + "0" * 400 + ", 0]"])
@pytest.mark.parametrize("road", ["swipl", "run-out"])
def test_a_time_beyond_a_float_is_rejected_and_the_clock_stays(road, time, compiled, tmp_path):
    line = b'{"event": "a(9)", "t": ' + time.encode() + b'}\n'
    stdout, stderr, name = run_road(road, compiled, tmp_path, line + GOOD + AFTER)
    assert_rejected_and_went_on(stdout, stderr, name, 1, '"t" must be a finite number of seconds or [secs, nsecs] '
                                                        '(beyond a float)')
    assert "late" not in stderr and "failed" not in stderr


# ---- 14: far in the future ---------------------------------------------------------------

@pytest.mark.parametrize("road", ["swipl", "swipl-no-c", "run-out", "run-stdin-out"])
def test_an_event_far_in_the_future_is_rejected_and_later_ones_are_not_late(road, compiled, tmp_path):
    far = b'{"event": "a(9)", "t": 1e300}\n'
    clock = b'{"op": "clock", "t": 1e300}\n'
    stdout, stderr, name = run_road(road, compiled, tmp_path, far + GOOD + clock + AFTER)
    assert f"{name}:1: rejected: time 1.0e+300 is more than 86,400 seconds after the clock (max_future)" in stderr
    assert f"{name}:4: rejected: time 1.0e+300 is more than 86,400 seconds after the clock (max_future)" in stderr
    assert [json.loads(text)["event"] for text in stdout.splitlines()] == ["p(1)", "p(2)"]
    assert "late" not in stderr and ", 2 rejected" in stderr


def test_max_future_measures_from_the_later_of_the_clock_and_the_wall_clock(compiled, tmp_path):
    import time
    now = int(time.time())
    times = [1, now + 50, now + 140, now + 300, now + 200]   # the 4th: 160 s after the clock
    data = b"".join(b'{"event": "%s(1)", "t": %d}\n' % (b"ab"[k % 2:k % 2 + 1], t) for k, t in enumerate(times))
    stdout, stderr, name = run_road("swipl", compiled, tmp_path, data, "--max-future", "100")
    assert f"{name}:4: rejected: time {now + 300} is more than 100 seconds after the clock (max_future)" in stderr
    assert ", 1 rejected" in stderr, stderr


def test_feed_rejects_a_time_far_in_the_future():
    engine = Engine.from_source(PROGRAM)
    with pytest.raises(ValueError, match="max_future"):
        engine.feed("a(9)", 1e300)
    assert engine.clock() != 1e300
    assert [o.event for o in engine.feed("a(1)", 1) + engine.feed("b(1)", 2)] == ["p(1)"]


def test_late_events_after_one_far_in_the_future_cost_what_the_others_do(compiled, tmp_path):
    """With --max-future inf, an event at 1e300 makes every later one late: the stores are
    swept every so many late events, so each is matched against a bounded store (before:
    against every event since, quadratic)."""
    lines = [b'{"event": "a(%d)", "t": %d}' % (i % 7, i + 2) for i in range(3000)]
    windowed = tmp_path / "windowed.pl"
    windowed.write_text(compile_source("p(X) <- (a(X) seq b(X)).10.\n", str(tmp_path / "w.rtl"),
                                       output_name="windowed.pl").prolog, encoding="utf-8")
    data = b'{"event": "a(1)", "t": 1e300}\n' + b"\n".join(lines) + b"\n"
    events = tmp_path / "late.jsonl"
    events.write_bytes(data)
    program = windowed
    script = tmp_path / "stores.pl"
    script.write_text(f":- set_prolog_flag(retalis_embedded, true).\n:- consult('{program}').\n"
                      "main :- rtl_ele:rtl_set_flag(max_future, inf),\n"
                      f"    retalis:rtl_run_event_file('{events}', false, false, _),\n"
                      "    rtl_ele:rtl_store_size(S), format(user_error, 'store ~w~n', [S]).\n")
    done = subprocess.run([SWIPL, "-g", "main", "-t", "halt", str(script)], capture_output=True, timeout=120)
    size = int(done.stderr.decode().rsplit("store ", 1)[1])
    assert size < 500, done.stderr[-1000:]


# ---- 10: surrogate escapes ---------------------------------------------------------------

@pytest.mark.parametrize("road", ["swipl", "swipl-no-c", "run-out"])
def test_surrogate_pairs_read_as_the_character_and_a_lone_one_is_rejected(road, compiled, tmp_path):
    long_a = json.dumps({"event": "a('" + "z" * 1200 + "\U0001f525')", "t": 1}).encode()
    long_b = json.dumps({"event": "b('" + "z" * 1200 + "\U0001f525')", "t": 2}, ensure_ascii=False).encode()
    lone = b'{"event": "a(\'\\ud83d\')", "t": 2.5}'
    data = long_a + b"\n" + long_b + b"\n" + lone + b"\n" + GOOD.replace(b'"t": 1}', b'"t": 3}').replace(
        b'"t": 2}', b'"t": 3.5}') + AFTER.replace(b'"t": 3}', b'"t": 5}').replace(b'"t": 4}', b'"t": 6}')
    stdout, stderr, name = run_road(road, compiled, tmp_path, data)
    assert f"{name}:3: rejected: invalid JSON (a lone surrogate \\uD83D)" in stderr, stderr
    events = [json.loads(text)["event"] for text in stdout.splitlines()]
    assert events == ["p('" + "z" * 1200 + "\U0001f525')", "p(1)", "p(2)"]


def read_all_roads(lines):
    """The parse of each line by the Prolog reader and with the C reader (two output lines)."""
    script = ROOT / "prolog_runtime" / "rtl_io"
    goal = ("set_stream(user_input, encoding(utf8)), read_term(user_input, Lines, []), forall(member(L, Lines), ("
            " rtl_use_fast_reader(false), rtl_parse_event_line(L, 1000, A),"
            " rtl_use_fast_reader(true), rtl_parse_event_line(L, 1000, B),"
            " print(A), nl, print(B), nl))")
    done = subprocess.run([SWIPL, "-g", f"use_module('{script}')", "-g", goal, "-t", "halt"],
                          input=("[" + ",".join(json.dumps(line, ensure_ascii=False) for line in lines) + "].\n").encode(),
                          capture_output=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return done.stdout.decode("utf-8").splitlines()


TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc")), max_size=20)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(TEXT, min_size=1, max_size=5))
def test_json_escaped_text_reads_as_the_raw_utf8_text(texts):
    """Any text in a quoted atom of an event, its line written by json.dumps with and
    without ensure_ascii (surrogate pairs for the characters beyond U+FFFF), gives the same
    event on the Prolog reader and the C reader, the one it gives as raw UTF-8."""
    lines = []
    for text in texts:
        quoted = text.replace("\\", "\\\\").replace("'", "\\'")
        for ascii_only in (True, False):
            lines.append(json.dumps({"event": f"a('{quoted}')", "t": 1}, ensure_ascii=ascii_only))
    parsed = read_all_roads(lines)
    assert len(parsed) == 2 * len(lines)
    for k, text in enumerate(texts):
        escaped_slow, escaped_fast, raw_slow, raw_fast = parsed[4 * k:4 * k + 4]
        assert escaped_slow == escaped_fast == raw_slow == raw_fast
        assert escaped_slow.startswith("event(add,"), escaped_slow
