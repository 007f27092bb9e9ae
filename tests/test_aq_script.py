"""The update-script interpreter of active queries (prolog_runtime/rtl_aq_script.pl): its
plunit suite, prolog_runtime/tests/test_aq_script.pl, run on Program 4 of the thesis compiled
in each transformation that terminates on its left recursion (the notifications a script
prints do not depend on the mode; `optimized` makes a fresh table for every call and does not
terminate here, tests/golden_aq/left_recursion/modes.txt)."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from retalisc.compiler import AqOptions, compile_source

ROOT = Path(__file__).resolve().parent.parent

PROGRAM4 = """
path(X, Y) :- path(X, Z), edge(Z, Y).
path(X, Y) :- edge(X, Y).
edge(0, 1).
edge(1, 2).
"""


@pytest.mark.parametrize("mode", ["tabled", "naive"])
def test_plunit_rtl_aq_script(tmp_path, swipl, mode):
    program = tmp_path / "p4.pl"
    program.write_text(compile_source(PROGRAM4, "program4.pl", active_queries=AqOptions(mode)).prolog)
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_aq_script.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120,
                          env={**os.environ, "AQ_TEST_PROGRAM": str(program)})
    assert proc.returncode == 0, proc.stdout
