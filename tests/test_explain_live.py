"""`retalisc explain` (how a derived event came about, why a pattern was not detected) and
live input (each event's output leaves as it is processed, before the input ends)."""
from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from retalisc.cli import main
from retalisc.driver.run import _live_batches

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = """\
alarm(X, Y) <- (smoke(X) seq heat(X, Y)).10.
big(X) <- alarm(X, Y) where Y > 50.
gone(X) <- not(back(X)).[leave(X), check(X)].
"""
EVENTS = """\
{"event": "smoke(k1)", "t": 1}
{"event": "smoke(k2)", "t": 2}
{"event": "heat(k1, 90)", "t": 4}
{"event": "heat(k2, 30)", "t": 20}
{"event": "leave(a)", "t": 30}
{"event": "back(a)", "t": 31}
{"event": "check(a)", "t": 32}
"""


@pytest.fixture()
def files(tmp_path):
    (tmp_path / "house.rtl").write_text(PROGRAM)
    (tmp_path / "events.jsonl").write_text(EVENTS)
    return tmp_path


def explain(files, *args):
    result = CliRunner().invoke(main, ["explain", str(files / "house.rtl"), "--events", str(files / "events.jsonl"),
                                       *args])
    return result.exit_code, result.stdout, result.stderr


def test_explain_gives_the_rule_and_the_input_lines_recursively(files):
    code, out, _ = explain(files, "big(X)")
    assert code == 0
    assert out.splitlines() == [
        "big(k1) over [1, 4]  derived by rule r2 (house.rtl:2)",
        "  alarm(k1,90) over [1, 4]  derived by rule r1 (house.rtl:1)",
        "    smoke(k1) at 1  input line 1",
        "    heat(k1,90) at 4  input line 3",
    ]


def test_explain_of_an_event_not_derived(files):
    code, out, _ = explain(files, "big(k2)")
    assert code == 0 and out.strip() == "no derived event matches big(k2); try --why-not"


def test_why_not_names_the_window_that_rejected(files):
    code, out, _ = explain(files, "--why-not", "alarm(k2, _)")
    assert code == 0
    assert out.splitlines() == [
        "rule r1 (house.rtl:1), for alarm(k2,Y):",
        "  window 10 s: 0 of 1 short enough   <- stops here",
        "    seq: 1 pair with equal shared variables, 1 of them in order (the first ends before the second starts)",
        "      smoke(k2): 1 match",
        "      heat(k2,Y): 1 match",
    ]


def test_why_not_through_a_hierarchy_and_a_negation(files):
    _, out, _ = explain(files, "--why-not", "big(k2)")
    assert "alarm(k2,Y): 0 matches   <- stops here" in out
    assert "where Y>50: 0 of 0 pass" in out
    _, out, _ = explain(files, "--why-not", "gone(a)")
    assert "not back(a) in between: 0 of 1 sequences have none   <- stops here" in out


def test_why_not_with_no_rule_and_with_a_detection(files):
    assert explain(files, "--why-not", "flood(_)")[1].strip() == "no rule derives an event of the form flood(_)"
    _, out, _ = explain(files, "--why-not", "big(k1)")
    assert out.startswith("1 derived event matches big(k1) (see explain)")
    assert "every part matches" in out


def test_explain_reads_lines_as_run_does(files):
    """The same line numbers and reasons as `retalisc run`, whatever the bytes: a mark, CRLF,
    a lone carriage return, a line that is not UTF-8, a NUL."""
    data = (b"\xef\xbb\xbf" + EVENTS.encode().replace(b"\n", b"\r\n", 2).replace(b'"t": 20', b'"t":\r20')
            + b'{"event": "smoke(\xff)", "t": 33}\n{"event": "smoke(k3)",\x00 "t": 34}\nnot json\n')
    (files / "events.jsonl").write_bytes(data)
    code, out, err = explain(files, "big(X)")
    assert code == 0 and "big(k1)" in out
    runner = CliRunner().invoke(main, ["run", str(files / "house.rtl"), "--events", str(files / "events.jsonl")])
    rejected = [line for line in runner.stderr.splitlines() if ": rejected: " in line]
    assert err.splitlines() == rejected
    assert [line.split(":", 2)[1] for line in rejected] == ["8", "9", "10"]
    assert "not UTF-8 text (byte 0xFF at column 18)" in rejected[0] and "a NUL byte" in rejected[1]


def test_explain_usage_errors(files):
    code, _, err = explain(files)
    assert code == 2 and "give an EVENT" in err
    code, _, err = explain(files, "big(")
    assert code == 2 and "retalisc explain: error: 'big('" in err and "\n" not in err.strip()


# ---- live input --------------------------------------------------------------------------


def test_live_batches_hold_only_what_is_waiting():
    read, write = os.pipe()
    batches = _live_batches(read, batch_size=3)
    os.write(write, "\ufeff{a}\n{b}\n{c".encode())
    # the lines as read (the runtime drops the mark); bytes read, the mark too; the partial line waits
    assert next(batches) == (1, ["\ufeff{a}".encode(), b"{b}"], 11)
    os.write(write, b"}\n{d}\n{e}\n{f}\n")
    assert next(batches) == (3, [b"{c}", b"{d}", b"{e}"], 12)   # at most batch_size lines
    os.write(write, b"{g}")
    os.close(write)
    assert list(batches) == [(6, [b"{f}", b"{g}"], 7)]                 # the last line needs no newline
    os.close(read)


def first_output_while_input_open(command, env):
    """The first output line of `command` after one input line, read while its standard
    input is still open, and the seconds it took."""
    proc = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            env=env, bufsize=0)
    try:
        proc.stdin.write(b'{"event": "ping(1)", "t": 1}\n')
        started = time.monotonic()
        ready, _, _ = select.select([proc.stdout], [], [], 60)
        assert ready, "no output while the input is open"
        line = proc.stdout.readline().decode()
        return line, time.monotonic() - started
    finally:
        proc.kill()
        proc.wait()


@pytest.mark.parametrize("path", ["run", "standalone"])
def test_each_event_is_written_as_it_arrives(tmp_path, path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    program = tmp_path / "pingpong.rtl"
    program.write_text("pong(N) <- ping(N).\n")
    if path == "run":
        command = [sys.executable, "-m", "retalisc", "run", str(program), "--events", "-"]
    else:
        subprocess.run([sys.executable, "-m", "retalisc", "compile", str(program), "-o", str(tmp_path / "p.pl")],
                       check=True, env=env)
        command = [shutil.which("swipl"), str(tmp_path / "p.pl"), "-"]
    line, _ = first_output_while_input_open(command, env)
    assert line == '{"event": "pong(1)", "start": 1, "end": 1}\n'


# ---- run --trace RULE and --late FILE ------------------------------------------------------

TRACED = """\
{"event": "smoke(k1)", "t": 1}
{"event": "smoke(k2)", "t": 2}
{"event": "heat(k1, 90)", "t": 4}
{"event": "smoke(k1)", "t": 1, "op": "retract"}
{"event": "heat(k2, 30)", "t": 40}
{"event": "smoke(k3)", "t": 20}
{"event": "heat(k3, 1)", "t": 21}
"""


def test_trace_reports_created_retracted_expired_and_counts(tmp_path, capfd):
    (tmp_path / "p.rtl").write_text("alarm(X, Y) <- (smoke(X) seq heat(X, Y)).10.\n")
    (tmp_path / "e.jsonl").write_text(TRACED)
    late = tmp_path / "late.jsonl"
    result = CliRunner().invoke(main, ["run", str(tmp_path / "p.rtl"), "--events", str(tmp_path / "e.jsonl"),
                                       "--trace", "r1", "--late", str(late)])
    assert result.exit_code == 0
    # the runtime writes trace lines to standard error itself (file descriptor 2), as they happen
    written = capfd.readouterr().err + result.stderr
    trace = [line for line in written.splitlines() if line.startswith("trace r1")]
    assert trace[0] == "trace r1 at 1: created step 1 left (smoke(X) waiting for heat(X, Y)) [k1] over [1, 1]"
    assert "trace r1 at 4: retracted step 1 left (smoke(X) waiting for heat(X, Y)) [k1] over [1, 1]" in trace
    assert "trace r1 at 40: expired step 1 left (smoke(X) waiting for heat(X, Y)) [k2] over [2, 2]" in trace
    assert trace[-1] == ("trace r1 (alarm/2): 2 detections; partial matches: 6 created, 0 consumed, 2 expired, "
                         "0 dropped, 0 replaced, 1 retracted")
    assert result.stderr.splitlines()[-1].startswith("retalis: 6 events in, 2 derived")
    lines = [json.loads(line) for line in late.read_text().splitlines()]
    assert [(x["event"], x["lateness"], x["may_have_missed_partners_in"]) for x in lines] == \
        [("smoke(k3)", 20, ["r1"]), ("heat(k3,1)", 19, ["r1"])]


def test_trace_consumed_under_a_policy_and_unknown_rule(tmp_path, capfd):
    (tmp_path / "p.rtl").write_text(":- set_etalis_flag(event_consumption_policy, chronological).\n"
                                    "r(K) <- a(K) seq b(K).\n")
    (tmp_path / "e.jsonl").write_text('{"event": "a(1)", "t": 1}\n{"event": "b(1)", "t": 3}\n')
    args = ["run", str(tmp_path / "p.rtl"), "--events", str(tmp_path / "e.jsonl")]
    result = CliRunner().invoke(main, args + ["--trace", "r1"])
    written = capfd.readouterr().err + result.stderr
    assert "trace r1 at 3: consumed step 1 left (a(K) waiting for b(K)) [1] over [1, 1]" in written
    bad = CliRunner().invoke(main, args + ["--trace", "r9"])
    assert bad.exit_code == 2 and "no rule 'r9' in the program (its rules: r1)" in bad.stderr
