"""The two loops over the lines of an event input, the runtime's (that of `swipl PROGRAM.pl
FILE`, prolog_runtime/retalis.pl, which `retalisc run` uses for a file or standard input
going to standard output) and the Python driver's (`--out FILE`, a live input, --state):
whatever the bytes (a lone carriage return, CRLF, bytes that are not UTF-8, NUL bytes, a
byte order mark, a last line without a newline, long lines), both give the same output, the
same messages with the same line numbers, and the same counts (docs/runtime.md, "Event
input")."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = "p(X) <- a(X) seq b(X).\n"


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


# ---- any bytes ---------------------------------------------------------------------------

EVENT_LINES = [b'{"event": "a(1)", "t": 1}', b'{"event": "b(1)", "t": 2}', b'{"event": "a(\'\xc3\xa9\')", "t": 3}',
               b'{"event": "b(\'\xc3\xa9\')", "t": 4}', b'{"event": "a(2)", "t": 5}', b'{"event": "b(2)", "t": 6}',
               b'{"event": "a(1)", "t": 1, "op": "retract"}', b'{"event": "b(1)",\r"t": 7}']
PIECES = [b"\n", b"\r", b"\r\n", b"\x00", b"\xff", b"\xc3", b"\xc3\xa9", b"\xef\xbb\xbf", b"\xed\xa0\x80",
          b"\xf4\x90\x80\x80", b"\xe2\x82", b"\xf0\x9f\x98\x80", b" ", b'"', b"{", b"a" * 3000]

byte_inputs = st.lists(st.one_of(st.sampled_from(EVENT_LINES).map(lambda line: line + b"\n"), st.sampled_from(PIECES),
                                 st.binary(max_size=6)), max_size=14).map(b"".join)


@pytest.fixture(scope="module")
def loops(tmp_path_factory):
    from retalisc.compiler import compile_source

    work = tmp_path_factory.mktemp("loops")
    (work / "p.rtl").write_text(PROGRAM)
    (work / "p.pl").write_text(compile_source(PROGRAM, "p.rtl", output_name="p.pl").prolog)
    return work


def runtime_loop(work: Path, data: bytes, stdin: bool):
    """`swipl p.pl EVENTS`, with the detections line `retalisc run` writes."""
    events = work / "events.jsonl"
    events.write_bytes(data)
    command = [shutil.which("swipl"), str(work / "p.pl"), "--detections=r1", "-" if stdin else str(events)]
    done = subprocess.run(command, input=data if stdin else None, capture_output=True, timeout=60)
    return done.returncode, done.stdout, _without_time(done.stderr)


def python_loop(work: Path, data: bytes, stdin: bool, batch_size: int):
    """`retalisc run --out FILE`: the Python driver reads the lines (in batches of
    `batch_size` from a file, as they arrive from standard input)."""
    events = work / "events.jsonl"
    events.write_bytes(data)
    out = work / "out.jsonl"
    command = [sys.executable, "-m", "retalisc", "run", str(work / "p.rtl"), "--events", "-" if stdin else str(events),
               "--out", str(out), "--batch-size", str(batch_size), "--no-progress"]
    done = subprocess.run(command, input=data if stdin else None, capture_output=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    return done.returncode, out.read_bytes(), _without_time(done.stderr)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=byte_inputs, stdin=st.booleans(), batch_size=st.integers(1, 4))
def test_both_loops_read_any_bytes_alike(loops, data, stdin, batch_size):
    assert python_loop(loops, data, stdin, batch_size) == runtime_loop(loops, data, stdin)


def test_the_documented_reading_of_lines(loops):
    """Lines end at newlines only; carriage returns at a line's ends go, one inside stays; a
    byte order mark opens the input only; a line that is not UTF-8 is rejected with the
    column of its first bad byte, one with a NUL byte with the column of that, and the input
    goes on; a last line needs no newline."""
    data = (b"\xef\xbb\xbf" + EVENT_LINES[0] + b"\r\n"         # 1: CRLF after a mark
            + b'{"event": "a(\xff)", "t": 2}\n'                   # 2: not UTF-8, column 14
            + b"\r\r\n"                                            # 3: blank
            + EVENT_LINES[7] + b"\n"                               # 4: a lone CR inside: JSON layout
            + b'{"event": "a(3)", "t": 8}\x00\n'                   # 5: a NUL (column 26)
            + b"\xef\xbb\xbf" + EVENT_LINES[0] + b"\n"             # 6: a mark inside the input
            + b'{"event": "x\xed\xa0\x80", "t": 9}\n'             # 7: an encoded surrogate, column 13
            + b'{"event": "a(4)", "t": 10}\r')                     # 8: no newline at the end
    for stdin in (False, True):
        status, out, messages = runtime_loop(loops, data, stdin)
        assert (status, out, messages) == python_loop(loops, data, stdin, 3)
        name = b"<stdin>" if stdin else str(loops / "events.jsonl").encode()
        assert status == 0
        assert out == b'{"event": "p(1)", "start": 1, "end": 7}\n'
        assert [m for m in messages if m.startswith(name)] == [
            name + b":2: rejected: not UTF-8 text (byte 0xFF at column 14)",
            name + b":5: rejected: a NUL byte at column 26",
            name + b":6: rejected: invalid JSON (illegal_json)",
            name + b":7: rejected: not UTF-8 text (byte 0xED at column 13)"]
        assert messages[-1] == b"retalis: 3 events in, 1 derived, 4 rejected"


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.sampled_from(PIECES[:-1]), st.binary(max_size=4)), max_size=8).map(b"".join))
def test_the_runtime_reads_a_line_as_python_would(data):
    """rtl_read_line/2, decoding in C and in Prolog, against Python's UTF-8 codec: the line
    up to the first newline, without the carriage returns at its ends."""
    line = data.split(b"\n")[0].strip(b"\r")
    try:
        expected = ("ok " + " ".join(str(ord(c)) for c in line.decode("utf-8"))).rstrip(" ")
    except UnicodeDecodeError as error:
        column = len(line[:error.start].decode("utf-8")) + 1
        expected = f"not UTF-8 text (byte 0x{line[error.start]:02X} at column {column})"
    assert _read_lines(data.split(b"\n")[0]) == [expected, expected]


def _read_lines(line: bytes):
    """The line read twice by rtl_read_line/2, first decoded in C, then in Prolog."""
    goal = ("use_module(rtl_lines), set_stream(user_input, encoding(iso_latin_1)), "
            "forall(member(C, [true, false]), "
            "( ( C == false -> retractall(rtl_lines:c_decoder) ; true ), rtl_read_line(user_input, L), "
            "( L = not_text(R) -> format('~s~n', [R]) "
            "; string_codes(L, Cs), atomic_list_concat(Cs, ' ', T), format('ok ~w~n', [T]) ) ))")
    done = subprocess.run([shutil.which("swipl"), "-q", "-g", goal, "-t", "halt"], input=line + b"\n" + line + b"\n",
                          capture_output=True, timeout=60, cwd=ROOT / "prolog_runtime")
    assert done.returncode == 0, done.stderr
    return [line.rstrip(" ") for line in done.stdout.decode("ascii").splitlines()]
