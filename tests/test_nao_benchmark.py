"""Smoke test of benchmarks/nao.py (Fig 5.2 on a 2 s recording: it runs, prints its target
lines and draws the plot; it does not check that the goal is met), and the program variants of
the other figures compile."""
import importlib.util
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rosbags")
pytest.importorskip("numpy")

ROOT = Path(__file__).resolve().parent.parent


def load_benchmark():
    spec = importlib.util.spec_from_file_location("nao_benchmark", ROOT / "benchmarks" / "nao.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_variants_compile():
    from retalisc.compiler import compile_source

    bench = load_benchmark()
    sources = [bench.split_rules(), bench.with_memories(3, "a(X, Y, Z, W)", 2500, "irr"),
               bench.with_memories(2, "tf(_, _, V, Q)", 150000, "big"), bench.with_interpolations(4),
               bench.without_sync(), bench.with_waiting_copies(2, 1.5)]
    for k, source in enumerate(sources):
        assert compile_source(source, f"variant{k}.rtl").prolog
    assert "syncronized(" not in bench.without_sync()
    assert bench.with_waiting_copies(2, 1.5).count("syncronized(") == 3


def test_fig_5_2_quick(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "nao.py"), "--seconds", "2", "--only", "5.2",
                           "--out-dir", str(tmp_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    targets = [line for line in proc.stdout.splitlines() if line.startswith("target ")]
    assert any(re.match(r"target (met|MISSED) +whole application under 5% of one core in real time: [\d.]+ %", line)
               for line in targets), proc.stdout
    assert any("as fast as possible" in line for line in targets)
    result = json.loads((tmp_path / "nao.json").read_text())
    assert result["app_fast"]["events"] > 3000          # about 1,900 transforms/s were split
    assert result["app_realtime"]["series"]
    # every world pose written in real time, none before the messages it needs fell due
    latency = result["app_realtime"]["latency"]
    assert latency["count"] >= 5 and latency["min"] >= 0, latency
    assert any(line.startswith("  Fig 5.2 output latency, --tick 0.01:") for line in proc.stdout.splitlines())
    assert (tmp_path / "nao_application.png").exists()
