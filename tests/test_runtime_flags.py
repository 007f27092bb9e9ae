"""The runtime's flags and counters (prolog_runtime/rtl_flags.pl): its plunit suite,
prolog_runtime/tests/test_flags.pl, with the module loaded alone."""
from __future__ import annotations

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_plunit_rtl_flags(swipl):
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_flags.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout
