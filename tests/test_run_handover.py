"""`retalisc run` hands a run that needs nothing from Python over to `swipl` on the program
kept in the compile cache (retalisc/driver/swipl_handover.py): the two roads print the
same output, the same messages and summary, and end with the same status, whatever the
program, the input and the options; runs that need Python stay in Python."""
from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from retalisc.compile_cache import CompileCache, CompiledProgram
from retalisc.driver.swipl_handover import swipl_arguments

ROOT = Path(__file__).resolve().parent.parent
SWIPL = shutil.which("swipl")
pytestmark = pytest.mark.skipif(SWIPL is None, reason="needs swipl on the PATH")


def jsonl(*items) -> str:
    lines = []
    for item in items:
        if isinstance(item, str):
            lines.append(item)
        elif isinstance(item, tuple):
            lines.append(json.dumps({"event": item[0], "t": item[1]}))
        else:
            lines.append(json.dumps(item))
    return "\n".join(lines) + "\n"


PAIRS = "p(X) <- a(X) seq b(X).\nfire_alarm: q(X) <- b(X) and c(X).\n"
WINDOW = "pair(X) <- (a(X) seq b(X)).5.\nlate_pair(X) <- a(X) seq b(X).10.\n"     # a compile warning

CASES = {
    "matches, rejections, a late event": (PAIRS, jsonl(
        ("a(1)", 1), ("b(1)", 2), "not json", ("c(1)", 2), '{"event": "a(", "t": 3}', ("a(2)", 4),
        ("b(2)", 10), ("a(3)", 2), "", ("b(3)", 11)), []),
    "echo, delay bound, a compile warning": (WINDOW, jsonl(
        ("a(1)", 1), ("b(1)", 3), ("a(2)", 4), ("b(2)", 12), ("b(0)", 11.5)), ["--echo-input", "--max-delay", "0.5"]),
    "retractions, the horizon": (PAIRS, jsonl(
        ("a(1)", 1), ("b(1)", 2), {"event": "a(1)", "t": 1, "op": "retract"}, ("a(5)", 100),
        {"event": "b(1)", "t": 2, "op": "retract"}), ["--retraction-horizon", "3"]),
    "strict stops at a bad line": (PAIRS, jsonl(("a(1)", 1), ("b(1)", 2), "oops", ("a(2)", 3)), ["--strict"]),
    "control lines refused": (PAIRS, jsonl(
        ("a(1)", 1), {"op": "add_rule", "rule": "added: r(X) <- c(X)."}, ("c(1)", 2)), []),
    "control lines obeyed": (PAIRS, jsonl(
        ("a(1)", 1), {"op": "add_rule", "rule": "added: r(X) <- c(X)."}, ("c(1)", 2), ("c(2)", 3)),
        ["--allow-control"]),
    "absences at the end": ("gone(X) <- not(seen(X)).[door(X), 30].\n", jsonl(("door(1)", 1), ("door(2)", 50)),
                            ["--flush-timers"]),
    "pending dropped": ("gone(X) <- not(seen(X)).[door(X), 30].\n", jsonl(("door(1)", 1)), ["--drop-pending"]),
    "an event runs out of steps": ("slow(X) <- a(X) where (numlist(1, 100000, L), sum_list(L, X)).\n",
                                   jsonl(("a(1)", 1), ("a(5000050000)", 2)), ["--max-steps", "1000", "--max-timers", "5"]),
    "program code halts": ("null do halt <- stop.\np(X) <- a(X).\n", jsonl(("a(1)", 1), ("stop", 2), ("a(2)", 3)), []),
    "no rules": ("fact(1).\n", jsonl(("a(1)", 1)), []),
    "text: BOM, CRLF, UTF-8": (PAIRS, "\ufeff" + jsonl(("a('é')", 1), ("b('é')", 2)).replace("\n", "\r\n"), []),
}


def run(tmp_path: Path, program: str, events: str, options, handover: bool, stdin: bool = False):
    """`retalisc run` as a user runs it, through the compile cache (a second run, so that it
    hits) or with the cache off (the Python driver all along). Returns the completed process
    and whether swipl was started on the cached program (a `swipl` on the PATH that logs)."""
    (tmp_path / "p.rtl").write_text(program)
    (tmp_path / "events.jsonl").write_bytes(events.encode("utf-8"))
    log = tmp_path / "swipl.log"
    log.unlink(missing_ok=True)
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir(exist_ok=True)
    wrapper = bin_dir / "swipl"
    wrapper.write_text(f'#!/bin/sh\necho "$@" >> "{log}"\nexec "{SWIPL}" "$@"\n')
    wrapper.chmod(0o755)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}",
           "RETALISC_CACHE_DIR": str(tmp_path / "cache"), "RETALISC_NO_CACHE": "0" if handover else "1"}
    command = [sys.executable, "-m", "retalisc", "run", str(tmp_path / "p.rtl"), "--no-progress", *options]
    if stdin:
        command += ["--events", "-"]
    else:
        command += ["--events", str(tmp_path / "events.jsonl")]
    for _ in range(2 if handover else 1):
        with open(tmp_path / "events.jsonl", "rb") as source:
            done = subprocess.run(command, stdin=source if stdin else subprocess.DEVNULL, capture_output=True,
                                  env=env, timeout=120)
    handed = log.exists() and "--detections=" in log.read_text()
    return done, handed


def messages(stderr: bytes):
    """Standard error without the run's duration (the end of the summary line)."""
    return [line.rsplit(b",", 1)[0] if line.startswith(b"retalis: ") and line.endswith(b" s") else line
            for line in stderr.splitlines()]


@pytest.mark.parametrize("stdin", [False, True], ids=["file", "stdin"])
@pytest.mark.parametrize("case", list(CASES))
def test_both_roads_print_the_same(tmp_path, case, stdin):
    program, events, options = CASES[case]
    python, handed_python = run(tmp_path, program, events, options, handover=False, stdin=stdin)
    swipl, handed_swipl = run(tmp_path, program, events, options, handover=True, stdin=stdin)
    assert not handed_python and handed_swipl
    assert swipl.returncode == python.returncode, (python.stderr, swipl.stderr)
    assert swipl.stdout == python.stdout
    assert messages(swipl.stderr) == messages(python.stderr)
    assert messages(python.stderr)[-1].startswith(b"retalis: ")


def test_the_cases_cover_what_they_say(tmp_path):
    """The comparison above is worth something only if the runs do these things."""
    seen = {}
    for case in ("matches, rejections, a late event", "strict stops at a bad line", "control lines obeyed",
                 "program code halts", "an event runs out of steps", "echo, delay bound, a compile warning"):
        program, events, options = CASES[case]
        done, _ = run(tmp_path, program, events, options, handover=True)
        seen[case] = (done.returncode, done.stdout.decode(), done.stderr.decode())
    code, out, err = seen["matches, rejections, a late event"]
    assert code == 0 and "p(1)" in out and "rejected" in err and "late" in err
    assert "detections per rule: r1 3, fire_alarm 1" in err
    assert seen["strict stops at a bad line"][0] == 1 and "p(2)" not in seen["strict stops at a bad line"][1]
    assert "r(1)" in seen["control lines obeyed"][1] and "added 2" in seen["control lines obeyed"][2]
    assert seen["program code halts"][0] == 1 and "p(2)" not in seen["program code halts"][1]
    assert "failed" in seen["an event runs out of steps"][2]
    assert "warning" in seen["echo, delay bound, a compile warning"][2]


@pytest.mark.parametrize("options", [
    ["--out", "OUT"], ["--query", "5", "true"], ["--subscribe", "c=a(X)"], ["--heartbeat", "1"],
    ["--trace", "r1"], ["--progress"], ["--action-output", "ACTIONS"], ["--consumer-dir", "DIR"],
])
def test_runs_that_need_python_stay_there(tmp_path, options):
    options = [str(tmp_path / o) if o in ("OUT", "ACTIONS", "DIR") else o for o in options]
    done, handed = run(tmp_path, PAIRS, jsonl(("a(1)", 1), ("b(1)", 2)), options, handover=True)
    assert done.returncode == 0, done.stderr
    assert not handed


def test_arguments_the_runtime_cannot_say_keep_python():
    assert swipl_arguments("events.jsonl", ["r1", "fire_alarm"]) is not None
    assert swipl_arguments("-", ["r1"])[-1] == "-"
    assert swipl_arguments("--events.jsonl", ["r1"]) is None          # read as an option
    assert swipl_arguments("-e.jsonl", ["r1"]) is None
    assert swipl_arguments("events.jsonl", ["r1", "a,b"]) is None      # not a name
    assert swipl_arguments("ev\udcff.jsonl", ["r1"]) is None           # not UTF-8
    arguments = swipl_arguments("e.jsonl", [], echo_input=True, max_delay=float("inf"), retraction_horizon=2.5,
                                max_steps="inf", max_timers=7, drop_pending=True, flush_timers=True,
                                allow_control=True, strict=True)
    assert arguments == ["--echo-input", "--max-delay=inf", "--retraction-horizon=2.5", "--max-steps=inf",
                         "--max-timers=7", "--drop-pending", "--flush-timers", "--allow-control", "--strict",
                         "--detections=", "e.jsonl"]


def test_the_program_file_is_checked_like_an_entry(tmp_path):
    cache = CompileCache(tmp_path / "cache")
    program = CompiledProgram(":- module(m, []).\n% é\n", "m", ["r1"], [])
    assert cache.store("k", program)
    path = cache.program_file("k", program)
    assert path == tmp_path / "cache" / "k.pl" and path.read_text(encoding="utf-8") == program.prolog
    assert stat.S_IMODE(path.stat().st_mode) & 0o077 == 0
    written = path.stat().st_mtime_ns
    assert cache.program_file("k", program) == path and path.stat().st_mtime_ns == written     # used again
    path.write_text(":- module(m, []).\nevil.\n")                     # changed: written anew
    assert cache.program_file("k", program).read_text(encoding="utf-8") == program.prolog
    path.chmod(0o666)                                                 # others may write it: written anew
    assert cache.program_file("k", program) == path
    assert stat.S_IMODE(path.stat().st_mode) & 0o077 == 0
    path.unlink()
    path.symlink_to(tmp_path / "elsewhere.pl")                        # a link: not followed
    (tmp_path / "elsewhere.pl").write_text(program.prolog)
    assert cache.program_file("k", program) == path and not path.is_symlink()
    (tmp_path / "cache").chmod(0o777)                                 # a directory others may write
    try:
        assert cache.program_file("k", CompiledProgram("other", "m", [], [])) is None
    finally:
        (tmp_path / "cache").chmod(0o700)


@pytest.mark.parametrize("handover", [True, False], ids=["swipl", "python"])
def test_a_reader_that_goes_away_ends_the_run_quietly(tmp_path, handover):
    """`retalisc run ... | head -1`: status 1 and nothing on standard error, on both roads."""
    program, events = PAIRS, jsonl(*((f"a({n})", n) for n in range(20000)))
    run(tmp_path, program, events, [], handover=handover)                # fills the cache
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RETALISC_CACHE_DIR": str(tmp_path / "cache"),
           "RETALISC_NO_CACHE": "0" if handover else "1"}
    process = subprocess.Popen([sys.executable, "-m", "retalisc", "run", str(tmp_path / "p.rtl"), "--events",
                                str(tmp_path / "events.jsonl"), "--echo-input"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert process.stdout.readline().startswith(b'{"event": "a(0)"')
    process.stdout.close()
    stderr = process.stderr.read()
    assert process.wait(timeout=120) == 1
    assert stderr == b""
