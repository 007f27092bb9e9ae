"""The mechanisms that keep a live stream's latency low in `retalisc run --events -`: Prolog
runs in the calling thread (no handoff), the reader does not look with select() before each
line, each batch's output leaves in one write with nothing to flush, and the collector does
not walk the objects that existed before the stream started."""
from __future__ import annotations

import gc
import io
import os
import subprocess
import sys
from pathlib import Path

from click.testing import CliRunner

from retalisc import cli, commands
from retalisc.driver import run
from retalisc.driver.bridge import Bridge

ROOT = Path(__file__).resolve().parent.parent


def test_live_reader_reads_lines_one_by_one_without_select(monkeypatch):
    looked = []
    real_select = run.select.select
    monkeypatch.setattr(run.select, "select", lambda *args: looked.append(args) or real_select(*args))
    read, write = os.pipe()
    batches = run._live_batches(read, batch_size=2)
    for number in range(1, 4):                          # one line at a time, as a sensor sends them
        os.write(write, f'{{"n": {number}}}\n'.encode())
        assert next(batches) == (number, [f'{{"n": {number}}}'.encode()], 9)
    assert looked == []
    os.write(write, b"{a}\n{b}\n{c}\n")                # more than a batch waiting: the rest waits
    assert next(batches) == (4, [b"{a}", b"{b}"], 8)      # for a look at what arrived since
    os.write(write, b"{d}\n")
    assert next(batches) == (6, [b"{c}", b"{d}"], 8)
    assert len(looked) == 1
    os.close(write)
    assert list(batches) == []
    os.close(read)


def test_live_output_leaves_in_one_write_without_a_flush():
    read, write = os.pipe()
    with open(write, "w", encoding="utf-8") as sink:
        emit = run._unbuffered(sink)
        emit('{"event": "pong(1)"}\n{"event": "pong(2)"}\n')
        # nothing is left in the stream's buffer: the reader has it all, unflushed
        assert os.read(read, 1000) == b'{"event": "pong(1)"}\n{"event": "pong(2)"}\n'
    os.close(read)
    memory = io.StringIO()                              # a stream without a file descriptor
    run._unbuffered(memory)("x\n")
    assert memory.getvalue() == "x\n"


def test_the_collector_leaves_the_objects_made_before_alone():
    restore = run._quiet_collector()
    try:
        assert gc.get_freeze_count() > 1000
    finally:
        restore()
    assert gc.get_freeze_count() == 0


def test_only_the_retalisc_program_runs_prolog_in_its_own_thread(tmp_path, monkeypatch):
    claimed = []
    monkeypatch.setattr(Bridge, "run_in_calling_thread", lambda self: claimed.append(True) or True)
    (tmp_path / "p.rtl").write_text("pong(N) <- ping(N).\n")
    (tmp_path / "e.jsonl").write_text('{"event": "ping(1)", "t": 1}\n')
    args = ["run", str(tmp_path / "p.rtl"), "--events", str(tmp_path / "e.jsonl")]
    assert CliRunner().invoke(cli.main, args).exit_code == 0
    assert claimed == []                 # inside another program (here click's runner): other threads may call
    monkeypatch.setattr(commands, "COMMAND_LINE_PROCESS", True)
    assert CliRunner().invoke(cli.main, args).exit_code == 0
    assert claimed == [True]


SCRIPT = """\
import threading
from retalisc.driver.bridge import Bridge, PrologError
from retalisc.driver.engine import Engine

bridge = Bridge()
if {call_first}:
    bridge.once("true")
print("claimed", bridge.run_in_calling_thread(), bridge.run_in_calling_thread())
engine = Engine.from_source("pong(N) <- ping(N).\\n", "p.rtl")
print("fed", [e.event for e in engine.feed("ping(1)", 1)])
answers = []
def other():
    try:
        answers.append(str(engine.feed("ping(2)", 2)[0].event))
    except PrologError as error:
        answers.append(str(error))
thread = threading.Thread(target=other)
thread.start()
thread.join()
print("other thread:", answers[0])
"""


def test_bridge_runs_in_the_calling_thread_only_before_the_first_call():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    outputs = {}
    for call_first in (False, True):
        proc = subprocess.run([sys.executable, "-c", SCRIPT.format(call_first=call_first)], capture_output=True,
                              text=True, timeout=120, env=env, cwd=ROOT)
        assert proc.returncode == 0, proc.stderr
        outputs[call_first] = proc.stdout.splitlines()
    assert outputs[False] == ["claimed True True", "fed ['pong(1)']",
                              "other thread: this process runs Prolog in one thread only (a command-line run): "
                              "call from that thread"]
    # once a call ran in the bridge's own thread, that thread keeps the state: no change
    assert outputs[True] == ["claimed False False", "fed ['pong(1)']", "other thread: pong(2)"]


def test_standard_input_is_read_in_the_runtime_loop_only_when_python_has_nothing_to_do(monkeypatch):
    class Stderr:
        def __init__(self, terminal):
            self.terminal = terminal

        def isatty(self):
            return self.terminal

    monkeypatch.setattr(sys, "stderr", Stderr(False))
    assert run.in_prolog_loop("-", "-", None, None, None)
    assert run.in_prolog_loop("-", "-", None, False, None)
    for events, out, consumers, progress, heartbeat in [("e.jsonl", "-", None, None, None), ("-", "o.jsonl", None, None, None),
                                                        ("-", "-", "dir", None, None), ("-", "-", None, True, None),
                                                        ("-", "-", None, None, 0.1)]:
        assert not run.in_prolog_loop(events, out, consumers, progress, heartbeat)
    monkeypatch.setattr(sys, "stderr", Stderr(True))     # a progress line may be due: Python reads
    assert not run.in_prolog_loop("-", "-", None, None, None)
    assert run.in_prolog_loop("-", "-", None, False, None)


EVENTS = """\
{"event": "ping(1)", "t": 1}
not json
{"op": "add_rule", "rule": "x <- y."}
{"event": "ping(X)", "t": 2}
{"event": "ping(3)", "t": 3}
{"event": "ping(3)", "t": 3, "op": "retract"}
{"event": "ping(4)", "t": 1}
"""


def test_the_runtime_loop_on_standard_input_gives_what_the_python_loop_gives(tmp_path, capfd):
    """`retalisc run --events -` (the retalisc program: the runtime's loop) against the
    same lines from a file in this process (the Python loop), with --strict and without."""
    program = tmp_path / "loops.rtl"
    program.write_text("pong(N) <- ping(N).\nnull <- ping(N) where N > 3.\n")
    events = tmp_path / "events.jsonl"
    events.write_text(EVENTS)
    for options in (["--strict"], ["--allow-control", "--echo-input"]):
        piped = subprocess.run([sys.executable, "-m", "retalisc", "run", str(program), "--events", "-", *options],
                               input=EVENTS, capture_output=True, text=True, timeout=120, cwd=tmp_path,
                               env=dict(os.environ, PYTHONPATH=str(ROOT)))
        capfd.readouterr()
        result = CliRunner().invoke(cli.main, ["run", str(program), "--events", str(events), *options])
        written = capfd.readouterr()
        assert piped.stdout == result.stdout + written.out
        in_process = (written.err + result.stderr).replace(str(events), "<stdin>")
        assert piped.returncode == result.exit_code == (1 if options == ["--strict"] else 0)
        assert _without_times(piped.stderr) == _without_times(in_process)
        assert "<stdin>:2: rejected:" in piped.stderr


def _without_times(text: str) -> str:
    return "\n".join(line.rsplit(", ", 1)[0] if line.endswith(" s") else line for line in text.splitlines())
