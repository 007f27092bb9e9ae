"""The loop over the lines of an event file or standard input (`swipl P.pl EVENTS`,
prolog_runtime/retalis.pl) reads the lines already in the input buffer in blocks, in C
(rtl_fast_read_lines/4 in prolog_runtime/c/rtl_fastread.c), and the others one at a time
with read_line_to_string/2. Whatever the lines, the output, the messages about lines (with
their numbers) and the summary are those of the runtime without its C helpers, which reads
every line in Prolog: that runtime is the oracle. Also: live standard input still gets each
event's output before the next line is sent, and the runtime's precompiled .qlf files are
used only when they are up to date, silently."""
import json
import os
import re
import select
import shutil
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from test_fast_reader import lines as random_lines

ROOT = Path(__file__).resolve().parent.parent
RUNTIME = ROOT / "prolog_runtime"
LIBRARY = RUNTIME / "foreign" / "rtl_fastread.so"

pytestmark = pytest.mark.skipif(not LIBRARY.exists(),
                                reason="the C reader is not built (bash prolog_runtime/c/build.sh)")

PROGRAM = """\
both(X, Y) <- a(X) seq b(Y).
big(X) <- c(X) where (X > 50).
"""


@pytest.fixture(scope="module")
def setup(tmp_path_factory, swipl):
    from retalisc.compiler import compile_source

    work = tmp_path_factory.mktemp("line_loop")
    prolog_only = work / "runtime"                 # the runtime without its C helpers
    shutil.copytree(RUNTIME, prolog_only, ignore=shutil.ignore_patterns("foreign", "tests", "c"))
    program = work / "p.pl"
    program.write_text(compile_source(PROGRAM, "p.rtl", output_name="p.pl").prolog)
    return swipl, program, prolog_only


def run(setup, data: bytes, c_reader: bool, stdin: bool, options=()):
    swipl, program, prolog_only = setup
    env = dict(os.environ)
    if not c_reader:
        env["RETALIS_RUNTIME"] = str(prolog_only)
    if stdin:
        done = subprocess.run([swipl, str(program), *options, "-"], input=data, capture_output=True,
                              timeout=60, env=env)
    else:
        events = program.parent / "events.jsonl"
        events.write_bytes(data)
        done = subprocess.run([swipl, str(program), *options, str(events)], capture_output=True,
                              timeout=60, env=env)
    stderr = re.sub(rb", [0-9.]+ s$", b"", done.stderr.rstrip(b"\n"))       # the summary's time
    return done.returncode, done.stdout, stderr


def common(draw_int, t):
    kind = "abc"[draw_int(0, 2)]
    return json.dumps({"event": f"{kind}({draw_int(1, 100)})", "t": t})


@st.composite
def streams(draw):
    """Event lines, mostly of the common case, mixed with every other kind of line."""
    out = []
    t = 0
    for _ in range(draw(st.integers(150, 300))):
        t += draw(st.integers(0, 2))
        kind = draw(st.integers(0, 19))
        if kind < 12:
            line = common(lambda a, b: draw(st.integers(a, b)), t)
        elif kind == 12:
            line = draw(random_lines()).replace("\n", " ")
        elif kind == 13:
            line = draw(st.sampled_from(["", "  ", "not json", "{}", '{"event": "a(1)"}', "\t",
                                        '{"op": "clock", "t": %d}' % t,
                                        '{"op": "add_rule", "rule": "x <- y."}',
                                        '{"event": "c(zz)", "t": %d}' % t,       # fails in the condition
                                        '{"event": "d(\'é\', \\"ü\\")", "t": %d}' % t,
                                        '{"event": "d(1)", "t": %d}\x00' % t,
                                        '{"event": "a(%d)", "start": %d, "end": %d}' % (t, t - 1, t)]))
        elif kind == 14 and out:
            previous = draw(st.sampled_from(out))
            try:
                fields = json.loads(previous)
                fields["op"] = "retract"
                line = json.dumps(fields)
            except (ValueError, TypeError):
                line = previous
        elif kind == 15:
            line = "\r" + common(lambda a, b: draw(st.integers(a, b)), t) + "\r"
        elif kind == 16:
            line = common(lambda a, b: draw(st.integers(a, b)), t).replace(" ", "  ")
        else:
            line = common(lambda a, b: draw(st.integers(a, b)), t - draw(st.integers(0, 5)))
        out.append(line)
    text = "\n".join(out)
    if draw(st.booleans()):
        text += "\n"
    data = text.encode("utf-8", "surrogatepass")
    if draw(st.integers(0, 4)) == 0:
        data = b"\xef\xbb\xbf" + data
    return data


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                  HealthCheck.too_slow,
                                                                  HealthCheck.data_too_large])
@given(streams(), st.booleans(), st.booleans())
def test_the_line_loop_in_c_gives_what_the_prolog_loop_gives(setup, data, stdin, strict):
    options = ("--strict",) if strict else ()
    fast = run(setup, data, c_reader=True, stdin=stdin, options=options)
    slow = run(setup, data, c_reader=False, stdin=stdin, options=options)
    assert fast == slow
    assert b"events in" in fast[2]


def test_lines_of_every_kind_and_their_numbers(setup):
    lines = [json.dumps({"event": f"{'ab'[t % 2]}({t})", "t": t}) for t in range(1, 200)]   # over 4 KB
    lines[3] = "not json"
    lines[150] = '{"event": "c(zz)", "t": 150}'
    lines[151] = '{"event": "a(\'é\')", "t": 151}'
    lines[152] = "\r" + lines[152] + "\r"
    data = ("\n".join(lines) + "\n").encode()
    for stdin in (False, True):
        fast = run(setup, data, c_reader=True, stdin=stdin)
        assert fast == run(setup, data, c_reader=False, stdin=stdin)
        errors = fast[2].decode().splitlines()
        assert re.match(r".*:4: rejected: ", errors[0])
        assert re.match(r".*:151: error: ", errors[1])
        assert re.match(r"retalis: 198 events in, [0-9,]+ derived, 1 rejected, 1 failed", errors[2])


def test_live_standard_input_gets_each_output_before_the_next_line(setup):
    swipl, program, _ = setup
    proc = subprocess.Popen([swipl, str(program), "-"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    try:
        def read_line():
            ready, _, _ = select.select([proc.stdout], [], [], 20)
            assert ready, "no output while the input stays open"
            return proc.stdout.readline()

        proc.stdin.write(b'{"event": "a(1)", "t": 1}\n{"event": "b(2)", "t": 2}\n')
        proc.stdin.flush()
        assert read_line().startswith(b'{"event": "both(1,2)"')
        proc.stdin.write(b'{"event": "b(3)", "t": 3}\n')
        proc.stdin.flush()
        assert read_line().startswith(b'{"event": "both(1,3)"')
    finally:
        proc.stdin.close()
        proc.wait(timeout=20)


# ---- precompiled runtime ------------------------------------------------------------------

# Loaded from a file (from a .qlf file, the load context is that file, not the module's).
QLF_CHECK = """\
:- use_module('{runtime}/retalis').
main :-
    ( rtl_io:fast_reader -> writeln(c_reader) ; writeln(no_c_reader) ),
    ( catch(rtl_io:from_source, _, fail) -> writeln(from_source) ; writeln(from_qlf) ).
"""


def test_an_out_of_date_qlf_file_is_not_used_and_nothing_is_printed_or_written(tmp_path, swipl):
    runtime = tmp_path / "runtime"
    shutil.copytree(RUNTIME, runtime, ignore=shutil.ignore_patterns("*.qlf", "tests", "c"))
    done = subprocess.run([swipl, "-q", "-g", "qcompile(rtl_io)", "-t", "halt"], cwd=runtime,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    qlf = runtime / "rtl_io.qlf"
    check = tmp_path / "check.pl"
    check.write_text(QLF_CHECK.format(runtime=runtime))
    command = [swipl, "-g", "main", "-t", "halt", str(check)]

    fresh = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert fresh.stdout.split() == ["c_reader", "from_qlf"]         # the C reader loads from a .qlf
    assert fresh.stderr == ""

    # The source changes after the .qlf file was made: the source is what runs.
    source = runtime / "rtl_io.pl"
    source.write_text(source.read_text() + "\nfrom_source.\n")
    later = qlf.stat().st_mtime + 10
    os.utime(source, (later, later))
    before = qlf.read_bytes(), qlf.stat().st_mtime
    stale = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert stale.stdout.split() == ["c_reader", "from_source"]
    assert stale.stderr == ""
    assert (qlf.read_bytes(), qlf.stat().st_mtime) == before                # not rewritten


# ---- a block of plain event lines ------------------------------------------------------------

# Events that fail in a condition, run out of steps, raise events, set timers or halt, in the
# middle of a block of plain event lines (which the C reader takes at once and the loop
# processes as one block, retalis.pl run_atomic/7): each still fails, is stopped, or ends the
# run with its own line number, as in the loop of the runtime without its C helpers.
BLOCK_PROGRAM = """\
both(X, Y) <- a(X) seq b(Y).
big(X) <- c(X) where (X > 50).
spin(X) <- s(X) where (between(1, inf, _), fail).      % runs until its step limit
echoed(X) do new_event(e(X)) <- d(X).
again(X) <- e(X).
quiet(X) <- not(b(X)).[a(X), 5].
stopped(X) do halt <- h(X).
"""


@pytest.fixture(scope="module")
def block_setup(tmp_path_factory, swipl):
    from retalisc.compiler import compile_source

    work = tmp_path_factory.mktemp("line_loop_block")
    prolog_only = work / "runtime"
    shutil.copytree(RUNTIME, prolog_only, ignore=shutil.ignore_patterns("foreign", "tests", "c"))
    program = work / "p.pl"
    program.write_text(compile_source(BLOCK_PROGRAM, "p.rtl", output_name="p.pl").prolog)
    return swipl, program, prolog_only


@st.composite
def block_streams(draw):
    out = []
    t = 0
    for _ in range(draw(st.integers(100, 600))):
        t += draw(st.integers(0, 2))
        kind = draw(st.sampled_from("aaabbbccddes") if draw(st.integers(0, 30)) else st.sampled_from(["s", "h"]))
        value = "zz" if kind == "c" and draw(st.integers(0, 5)) == 0 else draw(st.integers(1, 100))
        out.append(json.dumps({"event": f"{kind}({value})", "t": t}))
    return ("\n".join(out) + "\n").encode()


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                  HealthCheck.too_slow,
                                                                  HealthCheck.data_too_large])
@given(block_streams(), st.booleans(), st.booleans(), st.sampled_from([(), ("--max-timers=3",)]))
def test_failures_limits_and_halts_inside_a_block_keep_their_lines(block_setup, data, stdin, strict, timers):
    options = ("--max-steps=5000", *timers) + (("--strict",) if strict else ())
    fast = run(block_setup, data, c_reader=True, stdin=stdin, options=options)
    slow = run(block_setup, data, c_reader=False, stdin=stdin, options=options)
    assert fast == slow
    assert b"events in" in fast[2]


def test_an_event_out_of_steps_in_a_block_is_reported_with_its_line(block_setup):
    lines = [json.dumps({"event": f"{'ab'[t % 2]}({t})", "t": t}) for t in range(1, 100)]
    lines[9] = json.dumps({"event": "s(1)", "t": 10})
    lines[19] = json.dumps({"event": "c(zz)", "t": 20})
    lines[29] = json.dumps({"event": "d(7)", "t": 30})
    data = ("\n".join(lines) + "\n").encode()
    code, out, err = run(block_setup, data, c_reader=True, stdin=False, options=("--max-steps=5000",))
    assert code == 0
    errors = err.decode().splitlines()
    assert re.match(r".*:10: error: more than 5,000 steps \(--max-steps\) while processing s\(1\)$", errors[0])
    assert re.match(r".*:20: error: .* while processing c\(zz\)$", errors[1])
    assert errors[2].startswith("retalis: 100 events in, ") and errors[2].endswith(", 2 failed")   # e(7) raised
    assert b'"again(7)"' in out and b'"both(2,3)"' in out and b'"both(12,13)"' in out
    lines[39] = json.dumps({"event": "h(1)", "t": 40})
    data = ("\n".join(lines) + "\n").encode()
    code, out, err = run(block_setup, data, c_reader=True, stdin=False, options=("--max-steps=5000",))
    assert err.decode().splitlines()[-1].startswith("retalis: 41 events in, ")
    assert code == 1
    assert re.match(r".*:40: error: the program called halt \(in the action halt\) while processing h\(1\)$",
                    err.decode().splitlines()[2])
    assert b'"both(38,39)"' in out and b'"both(42,43)"' not in out
