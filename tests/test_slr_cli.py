"""`retalisc run --memory` and subscriptions to memory events."""
import json
import subprocess
import sys


def _retalisc(*args, cwd):
    return subprocess.run([sys.executable, "-m", "retalisc", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=120)


def test_run_memory_option_and_a_subscription_to_its_events(tmp_path):
    (tmp_path / "p.rtl").write_text("opened(D) <- door(D, open).\n")
    (tmp_path / "e.jsonl").write_text('{"event": "door(a, open)", "t": 1}\n{"event": "door(b, shut)", "t": 2}\n')
    run = _retalisc("run", "p.rtl", "--events", "e.jsonl", "--memory", "c_mem(doors, door(_, S)-[S == open], 5, inf)",
                    "--subscribe", "log=memory_updated(I, T)", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert {"event": "memory_updated(doors,1)", "start": 1, "end": 1, "consumer": "log"} in lines
    assert not any("memory_updated(doors,2)" in line["event"] for line in lines)   # door(b, shut) is not kept
    assert {"event": "opened(a)", "start": 1, "end": 1} in lines


def test_run_memory_option_refuses_unsafe_conditions(tmp_path):
    (tmp_path / "p.rtl").write_text("x.\n")
    (tmp_path / "e.jsonl").write_text("")
    run = _retalisc("run", "p.rtl", "--events", "e.jsonl", "--memory",
                    "c_mem(m, door(_, S)-[shell('touch hacked')], 5, inf)", cwd=tmp_path)
    assert run.returncode == 2
    assert "unsafe" in run.stderr and "shell" in run.stderr
    assert not (tmp_path / "hacked").exists()
