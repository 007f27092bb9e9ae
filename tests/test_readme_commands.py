"""The README's set-up command (make the NAO recording, run the NAO application on it) and the
sample-recording command, each run twice in a row on the same files, as a user repeating them
would: `--force` replaces what the first run wrote. Cheap version: a 2-second recording, the
set-up script left out (the test runs in the installed environment)."""
from __future__ import annotations

import json
import shlex
import subprocess
import sys

import pytest

from robot_io_support import ROOT  # noqa: F401  (skips without the 'ros' extra)


def readme_setup_command() -> str:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    line = next(line.strip() for line in readme.splitlines() if "make_bag.py" in line and "bash setup.sh" in line)
    return line


def test_the_readme_setup_command_runs_twice_in_a_row(tmp_path):
    steps = [shlex.split(part) for part in readme_setup_command().split("&&")]
    assert steps[0] == ["bash", "setup.sh"]
    bag = str(tmp_path / "nao.bag")
    commands = []
    for step in steps[1:]:
        words = [bag if word == "/tmp/nao.bag" else word for word in step]
        if words[0] == ".venv/bin/python":
            words[0] = sys.executable
        elif words[0] == ".venv/bin/retalisc":
            words[:1] = [sys.executable, "-m", "retalisc"]
        if "--seconds" in words:
            words[words.index("--seconds") + 1] = "2"
        commands.append(words)
    outputs = []
    for _ in range(2):
        for words in commands:
            done = subprocess.run(words, capture_output=True, text=True, cwd=ROOT, timeout=300)
            assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
        outputs.append(done.stdout)
    poses = [json.loads(line) for line in outputs[0].splitlines()]
    # the world poses in odom, the frame they are expressed in: marker_pose(Marker, PoseStamped)
    # derived, its PoseStamped delivered to the marker's consumer
    assert poses and all(p["event"].startswith("marker_pose(" if "consumer" not in p else "geometry_msgs__0__PoseStamped(")
                         and "],odom)," in p["event"] for p in poses)
    assert outputs[0] == outputs[1]          # the same recording again, the same world poses


@pytest.mark.parametrize("name", ["nao.bag", "nao_mcap"])
def test_the_sample_recording_command_replaces_with_force(tmp_path, name):
    from retalisc.robot_io.bags import Recording
    from retalisc.robot_io.samples import main

    out = str(tmp_path / name)
    fmt = ["--format", "mcap"] if name.endswith("mcap") else []
    assert main([out, "--seconds", "2", *fmt]) == 0
    with pytest.raises(SystemExit) as refused:         # without --force: a usage error
        main([out, "--seconds", "2", *fmt])
    assert refused.value.code == 2
    assert main([out, "--seconds", "1.5", "--force", *fmt]) == 0
    with Recording(out) as bag:
        assert (bag.end_ns - bag.start_ns) / 1e9 < 1.6       # the second recording, not the first
    other = tmp_path / "not_a_bag"
    (other / "keep.txt").parent.mkdir()
    (other / "keep.txt").write_text("mine")
    with pytest.raises(SystemExit):
        main([str(other), "--force"])
    assert (other / "keep.txt").read_text() == "mine"
