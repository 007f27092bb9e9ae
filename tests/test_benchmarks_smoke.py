"""Smoke tests of the benchmarks: they run (scaled down) and print every target line.
They check that the figures are produced, not that the targets are met."""
import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

SLR_TARGETS = [
    r"\(a\) \d+ irrelevant instances within 10% of none",
    r"\(a\) flat in the number of irrelevant instances",
    r"\(b\) size [\d,]+ vs [\d,]+ equal within 10% once full",
    r"\(c\) \d+ x tf\(head,cam,_,_\): .* per instance per event",
    r"\(d\) next on 16,384 vs 128 records under 2x",
    r"\(d\) prev on 16,384 vs 128 records under 2x",
    r"\(e\) updates/s net of matching >= 2x thesis",
    r"\(e\) updates/s net of baseline >= 2x thesis",
    r"\(e\) aim: updates/s net of matching >= 10x thesis",
    r"\(f\) 100 late: size [\d,]+ vs [\d,]+ within 10%",
    r"\(f\) cost grows with lateness",
]


def test_slr_memory_quick(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "slr_memory.py"), "--quick",
                           "--out-dir", str(tmp_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = [line for line in proc.stdout.splitlines() if line.startswith("target ")]
    for pattern in SLR_TARGETS:
        assert any(re.match(r"target (met|MISSED|figure) +" + pattern, line) for line in lines), \
            f"no target line for {pattern!r} in:\n" + "\n".join(lines)
    assert (tmp_path / "slr_memory_quick.json").exists()
    for name in ("instances", "sizes", "queries", "late"):
        assert (tmp_path / f"slr_memory_quick_{name}.png").exists()


def test_cep_vs_etalis_quick(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "cep_vs_etalis.py"), "--events", "300",
                           "--repeat", "1", "--only", "P3", "--out-dir", str(tmp_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    targets = [line for line in proc.stdout.splitlines() if line.startswith("target ")]
    assert any("P1 swipl end to end >= 100,000 events/s" in line for line in targets)
    assert sum("retalisc run within 1.3x of swipl" in line for line in targets) == 3      # P0, P1, P3
    assert "disagree" not in proc.stdout
    assert (tmp_path / "cep_vs_etalis.png").exists()


def test_cep_peers_quick(tmp_path):
    """benchmarks/cep_peers.py --quick: retalisc (and ETALIS where it is found) on 1,000 events, Flink
    skipped with its message; issue 42's targets printed against Esper's figures, the scaling lines."""
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "cep_peers.py"), "--quick",
                           "--out-dir", str(tmp_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = proc.stdout
    assert "Flink CEP peer skipped: --no-flink" in out
    targets = [line for line in out.splitlines() if line.startswith("target ")]
    assert any(re.match(r"target (met|MISSED) +P0 in memory >= Esper's 2.50M events/CPU-s \(", t) for t in targets)
    assert sum(bool(re.match(r"target (met|MISSED) +P[13] in memory within 1.5x of Esper's", t)) for t in targets) == 2
    assert any("P1 end to end at 1M events" in t for t in targets)
    assert any(re.match(r"target (met|MISSED) +max RSS end to end <= a quarter of Esper's .* ours \d+ MB\)", t)
               for t in targets)
    assert "| Esper 9.0.0 in memory (100k events, outside the project) | 2.50M | 357k | 263k |" in out
    assert "disagree" not in out
    assert re.search(r"P1:     1,000: +[\d.]+ us \(gc +[\d.]+ %, clause gc +[\d.]+ %, \d+ stored\)", out)
    summary = json.loads((tmp_path / "cep_peers.json").read_text())
    cells = summary["results"]["1000"]
    assert cells["P0"]["engine"]["derived"] == 0 and cells["P1"]["engine"]["derived"] > 0
    for key in ("P0", "P1", "P3"):
        assert cells[key]["engine"]["derived"] == cells[key]["swipl"]["derived"]
    assert (tmp_path / "cep_peers.png").exists()


def test_absence_quick(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "absence.py"), "--quick",
                           "--out-dir", str(tmp_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = [line for line in proc.stdout.splitlines() if line.startswith("target ")]
    assert any(re.match(r"target (met|MISSED) +absence rule >= 5x cheaper than the tick version .*: [\d.]+x$", line)
               for line in lines), lines
    assert "target met    the same situations detected by both" in lines
    assert (tmp_path / "absence_quick.json").exists() and (tmp_path / "absence_quick.png").exists()


def test_call_cost_quick(tmp_path):
    """benchmarks/call_cost.py: the fixed cost of a call on both roads, each targeted call's line."""
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "call_cost.py"), "--quick",
                           "--out-dir", str(tmp_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = [line for line in proc.stdout.splitlines() if line.startswith("target ")]
    for call in (r"Engine\.feed \(matches nothing\)", r"Engine\.query\('true'\)"):
        for road in ("handoff", "calling thread"):
            assert any(re.match(rf"target (met|MISSED) +{call} fixed cost on the {road} road: [\d.]+ us", line)
                       for line in lines), "\n".join(lines)
    assert "fixed cost + the query's own work" in proc.stdout
    assert (tmp_path / "call_cost.json").exists()
