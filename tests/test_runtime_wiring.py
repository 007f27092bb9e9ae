"""How the runtime's Prolog modules use each other: prolog_runtime/tests/test_wiring.pl (no
circle of modules importing each other, no `Module:Goal` naming a predicate Module does not
export, one loader of the C helpers)."""
from __future__ import annotations

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_plunit(swipl):
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_wiring.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout
