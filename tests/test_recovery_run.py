"""`retalisc run --state DIR` and `retalisc aq --state DIR`: a run killed (SIGKILL) at random
points and started again with the same DIR ends with an output file byte-identical to a run
that never stopped; crashes while a snapshot is written, a journal line cut short, a corrupt
snapshot and a full disk do not change that.

The fault-injection test's size (each restart costs a new process, ~1 s CPU, which dominates):
the event program (a windowed seq, a negation, an SLR memory read by prev/next in conditions, a
synchronized rule) runs over RETALISC_FAULT_EVENTS=100000 events and is killed at
RETALISC_FAULT_KILLS=20 seeded random points; the active-query script (recursion, negation,
rules added and removed, queries unregistered) has RETALISC_FAULT_AQ_COMMANDS=6000 commands and
is killed at RETALISC_FAULT_AQ_KILLS=20 points; snapshots every 1500 events (100 commands), so
the kills land between snapshots (about 60 s on an idle 2-core machine). `RETALISC_FAULT_SMALL=1`
gives a quick local run: 10,000 events and 6 kills, 1,000 commands and 5 kills."""
import errno
import io
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from retalisc.cli import main
from retalisc.driver import recovery
from retalisc.driver.engine import Engine

ROOT = Path(__file__).resolve().parent.parent
SMALL = os.environ.get("RETALISC_FAULT_SMALL") == "1"
FAULT_EVENTS = int(os.environ.get("RETALISC_FAULT_EVENTS", 10_000 if SMALL else 100_000))
FAULT_KILLS = int(os.environ.get("RETALISC_FAULT_KILLS", 6 if SMALL else 20))
FAULT_AQ_COMMANDS = int(os.environ.get("RETALISC_FAULT_AQ_COMMANDS", 1000 if SMALL else 6000))
FAULT_AQ_KILLS = int(os.environ.get("RETALISC_FAULT_AQ_KILLS", 5 if SMALL else 20))

# a windowed seq, a negation, an SLR memory read with prev/next in conditions, a synchronized rule
PROGRAM = """\
c(X) <- (a(X) seq b(X)).2.
d(X) <- (not(n(X)).[a(X), b(X)]).3.
c_mem(v, v(_)-[], 5, inf).
e(X, V) <- b(X) where prev(v, v(V)^T, inf).
f(X, V) <- a(X) where (prev(v, v(V)^T1, inf), \\+ next(v, v(_)^T2, T1, inf)).
memorize(tf(odom, base, V), [], tf(V), odom_base, 100).
memorize(tf(base, cam, V), [], tf(V), base_cam, 100).
at(Id, T, V) :- prev(Id, tf(V1)^T1, T), ( next(Id, tf(V2)^T2, T, inf) -> time_fraction(T1, T2, T, F), V is V1 + F * (V2 - V1) ; V = V1 ).
place(Rel, T, X) :- at(odom_base, T, A), at(base_cam, T, B), X is A + B + Rel.
syncronized(pose(Name, X), place(Rel, T, X), [[odom_base, T], [base_cam, T]]) <- marker(Name, Rel)^T.
"""


def write_events(path, n, seed):
    rng = random.Random(seed)
    t = 0.0
    with open(path, "w", encoding="utf-8") as stream:
        for i in range(n):
            t = round(t + rng.choice([0.1, 0.2, 0.5, 1.0]), 1)
            kind = rng.choice(["a", "b", "n", "v", "ob", "bc", "m"])
            if kind == "ob":
                event = f"tf(odom, base, {rng.randint(0, 9)})"
            elif kind == "bc":
                event = f"tf(base, cam, {rng.randint(0, 9)})"
            elif kind == "m":
                event = f"marker(m{i}, {rng.randint(0, 9)})"
            else:
                event = f"{kind}({rng.randint(0, 3)})"
            stream.write(json.dumps({"event": event, "t": t}) + "\n")


def run_cmd(program, events, out, state=None, every=300):
    cmd = [sys.executable, "-m", "retalisc", "run", str(program), "--events", str(events), "--out", str(out),
           "--batch-size", "100"]
    if state is not None:
        cmd += ["--state", str(state), "--snapshot-every", str(every)]
    return cmd


def _env():
    return dict(os.environ, PYTHONPATH=str(ROOT))


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("recovery")
    program = tmp / "program.rtl"
    program.write_text(PROGRAM, encoding="utf-8")
    events = tmp / "events.jsonl"
    write_events(events, 5_000, 19)
    expected = tmp / "expected.jsonl"
    subprocess.run(run_cmd(program, events, expected), check=True, env=_env(), capture_output=True)
    assert expected.stat().st_size > 20_000
    return tmp, program, events, expected.read_bytes()


def kill_and_restart(cmd, out, expected, kills, seed):
    """Run `cmd` (a recoverable run writing `out`), kill it with SIGKILL when `out` reaches each
    of `kills` seeded random sizes, start it again each time, and let the last start finish.
    Returns how many kills happened (a kill point the run passed before it was seen is not)."""
    rng = random.Random(seed)
    targets = sorted(rng.sample(range(len(expected) // 20, len(expected) * 19 // 20), kills))
    done = 0
    for target in targets + [None]:
        process = subprocess.Popen(cmd, env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        while target is not None and process.poll() is None:
            if out.exists() and out.stat().st_size >= target:
                os.kill(process.pid, signal.SIGKILL)
                done += 1
                break
            time.sleep(0.002)
        _, stderr = process.communicate(timeout=600)
        if target is None:
            assert process.returncode == 0, stderr.decode()
        else:
            assert process.returncode in (0, -signal.SIGKILL), stderr.decode()
    return done


def test_kill_9_at_random_points_then_restart_gives_the_uninterrupted_output(fault_setup):
    tmp, program, events, expected = fault_setup
    out, state = tmp / "killed.jsonl", tmp / "killed-state"
    kills = kill_and_restart(run_cmd(program, events, out, state, every=1500), out, expected, FAULT_KILLS, 2026)
    assert kills >= FAULT_KILLS * 2 // 3        # most kill points were reached before the run ended
    assert out.read_bytes() == expected


@pytest.fixture(scope="module")
def fault_setup(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fault")
    program = tmp / "program.rtl"
    program.write_text(PROGRAM, encoding="utf-8")
    events = tmp / "events.jsonl"
    write_events(events, FAULT_EVENTS, 20)
    expected = tmp / "expected.jsonl"
    subprocess.run(run_cmd(program, events, expected), check=True, env=_env(), capture_output=True)
    return tmp, program, events, expected.read_bytes()


def test_kill_9_an_active_query_script_then_restart_gives_the_uninterrupted_output(tmp_path):
    from test_recovery_aq import PROGRAM as AQ_PROGRAM, write_script

    program, script = tmp_path / "program.pl", tmp_path / "script.txt"
    program.write_text(AQ_PROGRAM, encoding="utf-8")
    write_script(script, FAULT_AQ_COMMANDS, 11)
    expected, out, state = tmp_path / "expected.jsonl", tmp_path / "killed.jsonl", tmp_path / "state"
    aq = [sys.executable, "-m", "retalisc", "aq", str(program), "--script", str(script)]
    subprocess.run(aq + ["--out", str(expected)], check=True, env=_env(), capture_output=True)
    expected = expected.read_bytes()
    kills = kill_and_restart(aq + ["--out", str(out), "--state", str(state), "--snapshot-every", "100"],
                             out, expected, FAULT_AQ_KILLS, 7)
    assert kills >= FAULT_AQ_KILLS * 2 // 3
    assert out.read_bytes() == expected


def run_here(program, events, out, state, every, log=None):
    """One run of `retalisc run --state` in this process (a process that stops after it)."""
    log = log or io.StringIO()
    status = recovery.run_recoverable(Engine.load(program), str(events), str(out), state, batch_size=100,
                                      snapshot_events=every, log=log)
    return status, log.getvalue()


def _snapshot_numbers(state):
    return sorted(int(p.stem.split("-")[1]) for p in Path(state).glob("snapshot-*.json"))


def test_crash_while_writing_a_snapshot_and_a_cut_journal_line(setup):
    tmp, program, events, expected = setup
    out, state = tmp / "torn.jsonl", tmp / "torn-state"
    run_here(program, events, out, state, 1500)
    newest = _snapshot_numbers(state)[-1]
    # as after a SIGKILL in the middle of the next snapshot: its state file without manifest,
    # a temporary file, and a journal line cut short
    (state / f"snapshot-{newest + 1:08d}.state").write_bytes(b"\x00half a snapshot")
    (state / f"snapshot-{newest + 1:08d}.json.tmp").write_text('{"format": "retal', encoding="utf-8")
    with open(state / "journal.jsonl", "a", encoding="utf-8") as journal:
        journal.write('{"input_bytes": 12')
    with open(out, "ab") as stream:
        stream.write(b'{"event": "c(1)", "sta')        # output written after the snapshot
    status, log = run_here(program, events, out, state, 1500)
    assert status == 0, log
    assert out.read_bytes() == expected
    assert not list(state.glob("*.tmp"))
    journal = recovery.StateDir(state).journal_records()       # since the newest snapshot, cut line gone
    assert journal and journal[-1]["input_line"] == 5001
    assert all(set(record) == {"input_bytes", "input_line", "out_bytes"} for record in journal)


def test_corrupt_snapshot_is_refused_and_the_previous_one_used(setup):
    tmp, program, events, expected = setup
    out, state = tmp / "corrupt.jsonl", tmp / "corrupt-state"
    run_here(program, events, out, state, 1200)
    numbers = _snapshot_numbers(state)
    assert len(numbers) == 2
    newest = state / f"snapshot-{numbers[-1]:08d}.state"
    data = bytearray(newest.read_bytes())
    data[len(data) // 2] ^= 0xFF
    newest.write_bytes(bytes(data))
    status, stderr = run_here(program, events, out, state, 1200)
    assert status == 0
    assert f"snapshot-{numbers[-1]:08d}.json: not used" in stderr and "corrupt" in stderr
    assert f"restored snapshot {numbers[0]}" in stderr
    assert out.read_bytes() == expected


def test_snapshot_of_another_program_is_refused(setup, tmp_path):
    tmp, program, events, _ = setup
    state = tmp_path / "state"
    run_here(program, events, tmp_path / "a.jsonl", state, 2500)
    other = tmp_path / "other.rtl"
    other.write_text("c(X) <- (a(X) seq b(X)).3.\n", encoding="utf-8")
    done = CliRunner().invoke(main, run_cmd(other, events, tmp_path / "b.jsonl", state)[3:])
    assert done.exit_code == 2
    assert "another program or runtime version" in done.output
    assert "Traceback" not in done.output


def test_full_disk_while_snapshotting_keeps_the_run_and_the_previous_snapshot(setup, tmp_path, monkeypatch):
    _, program, events, expected = setup
    engine = Engine.load(program)
    calls = []
    real_save = engine.save_state

    def failing_save(path):
        calls.append(path)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        real_save(path)

    monkeypatch.setattr(engine, "save_state", failing_save)
    log = io.StringIO()
    state, out = tmp_path / "state", tmp_path / "out.jsonl"
    status = recovery.run_recoverable(engine, str(events), str(out), state, batch_size=100, snapshot_events=1500,
                                      log=log)
    assert status == 0
    assert "No space left on device" in log.getvalue() and "the run goes on" in log.getvalue()
    assert out.read_bytes() == expected
    assert len(calls) == 4                  # at the start, then every 1500 lines
    assert _snapshot_numbers(state) == [1, 2]
    assert not list(state.glob("*.tmp")) and len(list(state.glob("*.state"))) == 2


@pytest.mark.parametrize("args, message", [
    (["--heartbeat", "0.5"], "--state does not go with --heartbeat"),
    (["--out", "-"], "--state needs --out FILE"),
])
def test_state_needs_files(setup, tmp_path, args, message):
    _, program, events, _ = setup
    cmd = run_cmd(program, events, tmp_path / "o.jsonl", tmp_path / "s")
    for option, value in zip(args[::2], args[1::2]):
        if option in cmd:
            cmd[cmd.index(option) + 1] = value
        else:
            cmd += [option, value]
    done = CliRunner().invoke(main, cmd[3:])
    assert done.exit_code == 2 and message in done.output


def test_an_output_file_shorter_than_the_snapshot_says_is_refused(setup, tmp_path):
    _, program, events, _ = setup
    state, out = tmp_path / "state", tmp_path / "out.jsonl"
    run_here(program, events, out, state, 2500)
    out.write_bytes(b"")
    with pytest.raises(recovery.RecoveryError, match="fewer than the .* it had at snapshot"):
        run_here(program, events, out, state, 2500)


# ---- standard input: the journal holds the events themselves ---------------------------------

class Crash(Exception):
    """Stands for the process dying in the middle of a batch."""


def _stdin_from(monkeypatch, tmp_path, data: bytes):
    path = tmp_path / f"stdin-{len(data)}"
    path.write_bytes(data)
    monkeypatch.setattr(sys, "stdin", open(path, "r", encoding="utf-8"))


def test_stdin_lines_journaled_before_a_crash_are_not_lost(setup, tmp_path, monkeypatch):
    _, program, events, expected = setup
    lines = events.read_bytes().splitlines(keepends=True)[:3000]
    whole = tmp_path / "whole.jsonl"
    whole.write_bytes(b"".join(lines))
    reference = tmp_path / "reference.jsonl"
    subprocess.run(run_cmd(program, whole, reference), check=True, env=_env(), capture_output=True)
    out, state = tmp_path / "out.jsonl", tmp_path / "state"
    engine = Engine.load(program)
    calls = []
    real_feed = engine.feed_lines

    def crashing_feed(text, first, **options):
        calls.append(first)
        if len(calls) == 9:            # batch 9 is in the journal, not yet processed
            raise Crash()
        return real_feed(text, first, **options)

    monkeypatch.setattr(engine, "feed_lines", crashing_feed)
    _stdin_from(monkeypatch, tmp_path, b"".join(lines[:1500]))
    with pytest.raises(Crash):
        recovery.run_recoverable(engine, "-", str(out), state, batch_size=100, snapshot_events=300,
                                 log=io.StringIO())
    assert calls[-1] == 801 and _snapshot_numbers(state) == [1, 2]     # at lines 1, 301 and 601
    journal = recovery.EventJournal(recovery.StateDir(state))
    assert [number for number, _ in journal.segments()] == [1, 2]      # after the snapshots kept
    assert journal.replay(2) == [line.rstrip(b"\n") for line in lines[600:900]]  # batches 7-9
    # started again, with standard input going on after what was read: nothing lost, nothing twice
    _stdin_from(monkeypatch, tmp_path, b"".join(lines[900:]))
    log = io.StringIO()
    status = recovery.run_recoverable(Engine.load(program), "-", str(out), state, batch_size=100,
                                      snapshot_events=300, log=log)
    assert status == 0
    assert "restored snapshot 2" in log.getvalue() and "input line 601" in log.getvalue()
    assert out.read_bytes() == reference.read_bytes()


def test_kill_9_on_standard_input_then_restart_gives_the_uninterrupted_output(setup, tmp_path):
    _, program, events, _ = setup
    lines = events.read_bytes().splitlines(keepends=True)[:2500]
    whole = tmp_path / "whole.jsonl"
    whole.write_bytes(b"".join(lines))
    reference = tmp_path / "reference.jsonl"
    subprocess.run(run_cmd(program, whole, reference), check=True, env=_env(), capture_output=True)
    out, state = tmp_path / "out.jsonl", tmp_path / "state"
    cmd = run_cmd(program, "-", out, state, every=400)
    process = subprocess.Popen(cmd, env=_env(), stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE)
    process.stdin.write(b"".join(lines[:1250]))
    process.stdin.flush()
    journal = state / "journal.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:             # until the 1250 lines are processed
        records = recovery.StateDir(state).journal_records() if journal.exists() else []
        if records and records[-1]["input_line"] == 1251:
            break
        time.sleep(0.01)
    os.kill(process.pid, signal.SIGKILL)            # standard input still open: a live source
    process.communicate(timeout=60)
    again = subprocess.run(cmd, env=_env(), input=b"".join(lines[1250:]), capture_output=True, timeout=300)
    assert again.returncode == 0, again.stderr.decode()
    assert b"restored snapshot" in again.stderr
    assert out.read_bytes() == reference.read_bytes()


def test_a_second_process_on_the_same_state_directory_is_refused_and_a_killed_one_does_not_block(
        setup, tmp_path):
    """The state directory is locked (an OS lock, recovery.StateDir.lock) while a run uses it: a
    second run with the same DIR is refused on each road (exit status 2) and changes nothing;
    once the first is killed with SIGKILL its lock is gone and a restart goes on."""
    _, program, events, _ = setup
    lines = events.read_bytes().splitlines(keepends=True)[:40]
    out, state = tmp_path / "out.jsonl", tmp_path / "state"
    cmd = run_cmd(program, "-", out, state, every=1000)
    first = subprocess.Popen(cmd, env=_env(), stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE)
    try:
        first.stdin.write(b"".join(lines[:20]))
        first.stdin.flush()
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:          # until the 20 lines are processed
            journal = state / "journal.jsonl"
            records = recovery.StateDir(state).journal_records() if journal.exists() else []
            if records and records[-1]["input_line"] == 21:
                break
            time.sleep(0.01)
        files = sorted((p.name, p.stat().st_size) for p in state.iterdir())
        second = subprocess.run(cmd, env=_env(), input=b"".join(lines[20:]), capture_output=True, timeout=120)
        assert second.returncode == 2, second.stderr.decode()
        assert f"is in use by another process (pid {first.pid})" in second.stderr.decode()
        assert "Traceback" not in second.stderr.decode()
        aq_program, script = tmp_path / "p.pl", tmp_path / "s.txt"
        aq_program.write_text("edge(1, 2).\n", encoding="utf-8")
        script.write_text("?q edge(X, Y).\n", encoding="utf-8")
        done = CliRunner().invoke(main, ["aq", str(aq_program), "--script", str(script), "--out",
                                         str(tmp_path / "aq.jsonl"), "--state", str(state)])
        assert done.exit_code == 2 and "in use by another process" in done.output, done.output
        assert sorted((p.name, p.stat().st_size) for p in state.iterdir()) == files
        assert first.poll() is None                     # the first run goes on
    finally:
        os.kill(first.pid, signal.SIGKILL)
        first.communicate(timeout=60)
    again = subprocess.run(cmd, env=_env(), input=b"".join(lines[20:]), capture_output=True, timeout=300)
    assert again.returncode == 0, again.stderr.decode()
    assert b"restored snapshot 0" in again.stderr


# ---- a recording (--bag): the input position is the number of messages replayed --------------

@pytest.mark.parametrize("name", ["nao_markers.rtl", "nao_markers_tf.rtl"])     # memories; the tf library's store
def test_kill_9_a_bag_replay_then_restart_gives_the_uninterrupted_output(tmp_path, name):
    from retalisc.robot_io.samples import write_nao_bag

    bag = write_nao_bag(tmp_path / "nao.bag", "ros1", seconds=8.0)
    program = ROOT / "examples" / "nao_markers" / name
    run = [sys.executable, "-m", "retalisc", "run", str(program), "--bag", str(bag), "--batch-size", "100"]
    expected = tmp_path / "expected.jsonl"
    subprocess.run(run + ["--out", str(expected)], check=True, env=_env(), capture_output=True)
    expected = expected.read_bytes()
    assert len(expected) > 20_000
    out, state = tmp_path / "out.jsonl", tmp_path / "state"
    kills = kill_and_restart(run + ["--out", str(out), "--state", str(state), "--snapshot-every", "200"],
                             out, expected, 2, 5)
    assert kills >= 1
    assert out.read_bytes() == expected
    manifest = json.loads(sorted(state.glob("snapshot-*.json"))[-1].read_text(encoding="utf-8"))
    assert manifest["input_messages"] > 0 and json.loads(manifest["bag"])["bag"] == str(bag)


def test_state_with_a_paced_bag_replay_is_refused(tmp_path):
    done = CliRunner().invoke(main, ["run", str(ROOT / "examples" / "nao_markers" / "nao_markers.rtl"),
                                     "--bag", str(ROOT / "README.md"), "--rate", "1", "--out",
                                     str(tmp_path / "o.jsonl"), "--state", str(tmp_path / "s")])
    assert done.exit_code == 2 and "not with --rate" in done.output
