"""benchmarks/robapl.py runs (scaled down, --quick) and prints its figures and every target line."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_robapl_benchmark_quick(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "robapl.py"), "--quick", "--out-dir", str(tmp_path)],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    assert "monitored series" in proc.stdout and "idle series" in proc.stdout
    targets = [line for line in proc.stdout.splitlines() if line.startswith("target ")]
    assert len(targets) == 2, proc.stdout
    assert (tmp_path / "robapl.json").exists()
