"""Smoke test of benchmarks/robot_io.py: it runs scaled down and prints every target line
(that the figures are produced, not that the targets are met)."""
import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

TARGETS = [
    r"\(a\) TFMessage \(3 transforms\): generated converter >= 3x the generic walk",
    r"\(a\) PoseStamped: generated converter",
    r"\(a\) MarkerArray \(10 markers\): generated converter",
    r"\(b\) conversion CPU share at 1,900 transforms/s below the thesis's 40%",
    r"\(b\) input pipeline .* in real time below 10%",
    r"\(b\) whole pipeline with the tf program .* below 40%",
] + [rf"\(c\) {fmt}: bag input alone" for fmt in ("ros1", "ros2", "mcap")] \
  + [rf"\(c\) {fmt}: the NAO program keeps up" for fmt in ("ros1", "ros2", "mcap")]


def test_robot_io_benchmark_quick(tmp_path, capsys):
    pytest.importorskip("rosbags", reason="the benchmark needs the 'ros' extra (rosbags)")
    spec = importlib.util.spec_from_file_location("robot_io_benchmark", ROOT / "benchmarks" / "robot_io.py")
    benchmark = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(benchmark)         # in this process: no second interpreter and Prolog to start
    assert benchmark.run(quick=True, out_dir=tmp_path, with_live=False) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("target ")]
    for pattern in TARGETS:
        assert any(re.match(r"target (met|MISSED|figure) +" + pattern, line) for line in lines), \
            f"no target line for {pattern!r} in:\n" + "\n".join(lines)
    assert (tmp_path / "robot_io_quick.json").exists() and (tmp_path / "robot_io_quick.png").exists()
