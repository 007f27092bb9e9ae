"""Run a benchmark program in a fresh `swipl` and read the `key value` lines it prints."""
from __future__ import annotations

import subprocess
import tempfile
from pathlib import Path
from typing import Dict


def run_swipl(text: str, timeout: float = 3600) -> Dict[str, str]:
    """Consult `text` in a fresh swipl, call main/0; return {key: value} from its output lines.
    Raises RuntimeError with the end of stderr when swipl fails or prints nothing."""
    with tempfile.TemporaryDirectory(prefix="aqbench_") as tmp:
        path = Path(tmp) / "bench.pl"
        path.write_text(text)
        proc = subprocess.run(["swipl", "--no-tty", "-q", "--stack-limit=8g", "--table-space=8g", "-g", "main",
                               "-t", "halt", str(path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, timeout=timeout)
    if proc.returncode != 0 or not proc.stdout.strip():
        raise RuntimeError((proc.stderr or proc.stdout or f"exit {proc.returncode}")[-3000:])
    out = {}
    for line in proc.stdout.splitlines():
        key, value = line.split()
        out[key] = value
    return out
