"""SIGTERM and SIGINT in the middle of a run (issue 35, repro 8), on every road: `swipl OUT.pl
FILE > out`, standard input, `retalisc run` handed over to swipl (`> out`), `retalisc run --out
FILE` (the Python driver) and `--state`. The run ends with the status a shell reports for the
signal (128 + its number), the summary on standard error, and an output of whole JSON lines
only: each the output of one input event, in order (r(1), r(2), ... r(N)).
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RETALISC = [sys.executable, "-m", "retalisc"]
EVENTS = 150_000


def compiled_case(directory: Path, program_text: str, events_text: str):
    """(program, events, compiled program) of `program_text` and `events_text` in `directory`."""
    program = directory / "p.rtl"
    program.write_text(program_text)
    events = directory / "events.jsonl"
    events.write_text(events_text)
    compiled = directory / "p.pl"
    subprocess.run([*RETALISC, "compile", str(program), "-o", str(compiled)], check=True, env=_env())
    return program, events, compiled


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    directory = tmp_path_factory.mktemp("signals")
    events = "".join(f'{{"event": "a({i})", "t": {i}}}\n' for i in range(1, EVENTS + 1))
    return (directory, *compiled_case(directory, "r(X) <- a(X).\n", events))


def _env():
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def _stop_when_written(command, out: Path, signum, stdin=subprocess.DEVNULL, stdout=None):
    """Start `command`, send it `signum` once its output file holds more than 64 KB (beyond a
    stream buffer), and return (exit status, standard error)."""
    with open(out, "wb") if stdout is None else open(os.devnull, "wb") as sink:
        process = subprocess.Popen(command, stdin=stdin, stdout=sink if stdout is None else stdout,
                                   stderr=subprocess.PIPE, env=_env())
        deadline = time.monotonic() + 60
        while (not out.exists() or out.stat().st_size < 65536) and time.monotonic() < deadline:
            assert process.poll() is None, process.stderr.read()
            time.sleep(0.02)
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=60)
    return process.returncode, stderr.decode()


def assert_whole_lines(out: Path, status, stderr, signum):
    assert status == 128 + signum, stderr
    assert "Traceback" not in stderr
    assert stderr.splitlines()[-1].startswith("retalis: "), stderr
    data = out.read_bytes()
    assert data and data.endswith(b"\n"), data[-200:]
    lines = data.decode().splitlines()
    assert len(lines) < EVENTS                      # stopped in the middle
    assert [json.loads(line)["event"] for line in lines] == [f"r({i})" for i in range(1, len(lines) + 1)]


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_swipl_stopped_by_a_signal_flushes_whole_lines(case, swipl, signum):
    directory, _, events, compiled = case
    out = directory / f"swipl_{signum}.jsonl"
    status, stderr = _stop_when_written([swipl, str(compiled), str(events)], out, signum)
    assert_whole_lines(out, status, stderr, signum)


def test_swipl_reading_standard_input_stopped_by_a_signal(case, swipl):
    directory, _, events, compiled = case
    out = directory / "stdin.jsonl"
    with open(events, "rb") as stdin:
        status, stderr = _stop_when_written([swipl, str(compiled), "-"], out, signal.SIGTERM, stdin=stdin)
    assert_whole_lines(out, status, stderr, signal.SIGTERM)


# handed over to swipl; the runtime's loop run by the Python driver (a --memory is Python's)
@pytest.mark.parametrize("extra", [[], ["--memory", "c_mem(m1, a(_)-[], 5, 10)"]])
def test_retalisc_run_to_standard_output_stopped_by_a_signal(case, extra):
    directory, program, events, _ = case
    out = directory / f"stdout_{len(extra)}.jsonl"
    with open(out, "wb") as stdout:
        status, stderr = _stop_when_written([*RETALISC, "run", str(program), "--events", str(events), *extra],
                                            out, signal.SIGTERM, stdout=stdout)
    assert_whole_lines(out, status, stderr, signal.SIGTERM)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_retalisc_run_out_file_stopped_by_a_signal(case, signum):
    directory, program, events, _ = case
    out = directory / f"python_{signum}.jsonl"
    command = [*RETALISC, "run", str(program), "--events", str(events), "--out", str(out)]
    status, stderr = _stop_when_written(command, out, signum, stdout=subprocess.DEVNULL)
    assert_whole_lines(out, status, stderr, signum)


def test_retalisc_run_with_state_stopped_by_a_signal_goes_on_to_the_same_output(case, tmp_path):
    directory, program, events, _ = case
    out = tmp_path / "state.jsonl"
    command = [*RETALISC, "run", str(program), "--events", str(events), "--out", str(out),
               "--state", str(tmp_path / "state")]
    status, stderr = _stop_when_written(command, out, signal.SIGTERM, stdout=subprocess.DEVNULL)
    assert_whole_lines(out, status, stderr, signal.SIGTERM)
    again = subprocess.run(command, capture_output=True, text=True, env=_env(), timeout=300)
    assert again.returncode == 0, again.stderr
    lines = out.read_text().splitlines()
    assert [json.loads(line)["event"] for line in lines] == [f"r({i})" for i in range(1, EVENTS + 1)]


# A full disk (/dev/full takes no byte): one line saying so, the summary, status 1, no traceback.

def _assert_full_disk(run, name):
    assert run.returncode == 1, run.stderr
    assert "Traceback" not in run.stderr and "ERROR" not in run.stderr, run.stderr
    lines = run.stderr.splitlines()
    assert f"retalis: cannot write {name}: No space left on device" in lines, run.stderr
    assert lines[-1].startswith("retalis: ") and " events in" in lines[-1], run.stderr


def test_a_full_disk_under_swipl_is_one_line_and_status_1(case, swipl):
    directory, _, events, compiled = case
    with open("/dev/full", "wb") as full:
        run = subprocess.run([swipl, str(compiled), str(events)], stdout=full, stderr=subprocess.PIPE, text=True,
                             timeout=120)
    _assert_full_disk(run, "standard output")


def test_a_full_disk_under_the_python_driver_is_one_line_and_status_1(case):
    _, program, events, _ = case
    run = subprocess.run([*RETALISC, "run", str(program), "--events", str(events), "--out", "/dev/full"],
                         capture_output=True, text=True, env=_env(), timeout=120)
    _assert_full_disk(run, "/dev/full")


def test_a_full_disk_under_the_runtimes_loop_run_by_python_is_one_line_and_status_1(case):
    _, program, events, _ = case
    with open("/dev/full", "wb") as full:          # a --memory keeps the run in Python
        run = subprocess.run([*RETALISC, "run", str(program), "--events", str(events), "--memory",
                              "c_mem(m1, a(_)-[], 5, 10)"], stdout=full, stderr=subprocess.PIPE, text=True,
                             env=_env(), timeout=120)
    _assert_full_disk(run, "standard output")
