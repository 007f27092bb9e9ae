"""benchmarks/recovery.py --quick runs and writes its figures."""
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_recovery_benchmark_quick(tmp_path):
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "recovery.py"), "--quick",
                           "--out-dir", str(tmp_path)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    results = json.loads((tmp_path / "recovery_quick.json").read_text())
    assert set(results) == {"throughput", "snapshot_costs", "restart", "aq_snapshot_costs", "aq_throughput"}
    assert results["aq_snapshot_costs"][0]["answers"] == 465 and results["aq_snapshot_costs"][0]["bytes"] > 0
    assert "target <= 10%" in done.stderr
    sizes = [row["bytes"] for row in results["snapshot_costs"]]
    assert sizes == sorted(sizes) and sizes[0] > 0       # more records, a larger snapshot
    assert results["restart"]["records"] == 10_000
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return
    assert (tmp_path / "recovery_quick.png").exists()
