"""`retalisc run --events FILE` reads a plain UTF-8 file in the runtime's own loop (that of
`swipl PROGRAM.pl FILE`) and any other file in Python: both loops give the same output and
the same messages (`--out FILE` keeps the Python loop)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from retalisc.driver.run import plain_text_file

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = "p(X) <- a(X) seq b(X).\n"


@pytest.mark.parametrize("data, plain", [
    (b'{"event": "a(1)", "t": 1}\n', True),
    (b'\xef\xbb\xbf{"event": "a(\xc3\xa9)", "t": 1}\r\n{"event": "b(1)", "t": 2}', True),
    (b"", True),
    (b'{"event": "a(1)",\r"t": 1}\n', False),                  # Python reads two lines here
    (b'{"event": "a(1)", "t": 1}\r', False),
    (b'{"event": "a(\xff)", "t": 1}\n', False),                # not UTF-8
    (b'{"event": "a(\xc3)", "t": 1}\n', False),
    (b'{"event": "a(1)", "t": 1}\n\xc3', False),               # cut inside a character
])
def test_plain_text_file(tmp_path, data, plain):
    path = tmp_path / "events.jsonl"
    path.write_bytes(data)
    assert plain_text_file(str(path)) is plain
    assert plain_text_file(str(path), chunk_size=1) is plain      # chunk ends anywhere


def test_only_regular_files_are_plain(tmp_path):
    assert not plain_text_file(str(tmp_path))
    assert not plain_text_file(str(tmp_path / "missing"))
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "fifo")
        assert not plain_text_file(str(tmp_path / "fifo"))


LINES = [b'{"event": "a(1)", "t": 1}', b'{"event": "b(1)", "t": 2}', b"not json",
         b'{"event": "a(\xc3\xa9)", "t": 3}', b'{"event": "b(\xc3\xa9)", "t": 4}', b'{"event": "c", "t": 0.5}',
         b'{"event": "a(2)", "t": 5}', b'{"event": "b(2)", "t": 6}']


@pytest.mark.parametrize("data", [
    b"\xef\xbb\xbf" + b"\r\n".join(LINES),                        # the runtime's loop
    b"\n".join(LINES).replace(b'"t": 1}', b'"t":\r1}'),            # Python's: a lone \r
    b"\n".join(LINES).replace(b"\xc3\xa9", b"\xe9"),               # Python's: not UTF-8
])
def test_both_loops_say_the_same(tmp_path, data):
    program = tmp_path / "program.rtl"
    program.write_text(PROGRAM)
    events = tmp_path / "events.jsonl"
    events.write_bytes(data)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    command = [sys.executable, "-m", "retalisc", "run", str(program), "--events", str(events), "--no-progress"]
    in_runtime = subprocess.run(command, capture_output=True, env=env, timeout=60)
    in_python = subprocess.run(command + ["--out", str(tmp_path / "out.jsonl")], capture_output=True, env=env,
                               timeout=60)
    assert in_runtime.returncode == in_python.returncode == 0
    assert in_runtime.stdout == (tmp_path / "out.jsonl").read_bytes()
    assert b"p(2)" in in_runtime.stdout and b"rejected" in in_runtime.stderr
    assert _without_time(in_runtime.stderr) == _without_time(in_python.stderr)


def _without_time(stderr: bytes):
    return [line.rsplit(b",", 1)[0] if line.startswith(b"retalis: ") else line for line in stderr.splitlines()]
