"""The plunit tests of the runtime's Prolog modules (prolog_runtime/tests/test_*.pl): each file
not run by another test of this suite is run here, and every runtime module with behaviour
of its own at Prolog level has a plunit file (or says below why it has none)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RUNTIME = ROOT / "prolog_runtime"
PLUNIT = sorted((RUNTIME / "tests").glob("test_*.pl"))

#: Runtime modules with no plunit file of their own, and where their behaviour is tested.
WITHOUT_PLUNIT = {
    "retalis": "the entry points: the line loop end to end (tests/test_run_file_loop.py, test_run_handover.py, "
               "test_signals.py); its argument reader is rtl_arguments (test_arguments.pl)",
    "rtl_api": "the Python boundary, tested from Python (tests/test_boundary.py, test_api_as_data.py)",
    "rtl_aq_api": "the active queries' API, tested from Python (tests/test_aq_api.py) and test_aq.pl",
    "rtl_aq_rules": "rules of active queries added at run time (tests/test_aq_api.py)",
    "rtl_ele": "the event engine, tested against the model of tests/ele_oracle.py (test_ele_semantics.py) "
               "and through every module test that feeds events (test_seen.pl, test_sliding.pl, ...)",
    "rtl_feed": "the line loops, tested end to end (tests/test_line_loop.py, test_run_file_loop.py, "
                "test_stream_errors.py)",
    "rtl_foreign": "the loader of the C helpers: the C and Prolog roads compared in test_lines.pl",
    "rtl_horizon": "the retraction horizon, tested from Python (tests/test_policy_deletion.py, "
                   "test_negation_store.py)",
    "rtl_load": "loading the .qlf files when up to date (tests/test_runtime_location.py, setup)",
    "rtl_load_check": "`retalisc check` loading a program (tests/test_check_loads.py)",
    "rtl_ros1": "ROS 1 messages in C (tests/test_ros1_terms.py)",
    "rtl_rules": "rules added at run time (tests/test_control_lines.py, test_rules_in_process.py)",
    "rtl_state": "snapshots (tests/test_recovery_state.py, test_recovery_crafted.py)",
    "rtl_trace": "`retalisc run --trace`, `explain` (tests/test_explain_constructs.py, test_bag_trace.py)",
}

#: A plunit file tests the modules it loads from `..` (`:- use_module('../rtl_x')`), and
#: test_x.pl tests rtl_x.
_LOADS = re.compile(r"use_module\('\.\./(\w+)'")


def runtime_modules():
    return sorted(p.stem for p in RUNTIME.glob("*.pl"))


def modules_with_plunit():
    tested = set()
    for path in PLUNIT:
        tested.update(name for name in _LOADS.findall(path.read_text(encoding="utf-8"))
                      if name != "retalis")        # the whole runtime, loaded to test a module of it
        tested.add("rtl_" + path.stem[len("test_"):])
    return tested


def run_elsewhere(path: Path) -> bool:
    """Whether another test file of the suite runs this plunit file."""
    for test in (ROOT / "tests").glob("*.py"):
        if test.name != Path(__file__).name and path.name in test.read_text(encoding="utf-8"):
            return True
    return False


HERE = [path for path in PLUNIT if not run_elsewhere(path)]


@pytest.mark.parametrize("path", HERE, ids=[path.stem for path in HERE])
def test_plunit_file(swipl, path):
    env = {**os.environ, "RETALISC_PYTHON": sys.executable,      # compiled_program.pl compiles with it
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    done = subprocess.run([swipl, "--no-tty", "-g", "run_tests", "-t", "halt", str(path)],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stdout
    assert re.search(r"All \d+ tests passed", done.stdout), done.stdout     # not a halt half-way


def test_every_runtime_module_has_plunit_tests_or_says_where_it_is_tested():
    modules = set(runtime_modules())
    tested = modules_with_plunit() & modules
    assert not (tested & set(WITHOUT_PLUNIT)), "listed as untested but has a plunit file"
    missing = modules - tested - set(WITHOUT_PLUNIT)
    assert not missing, f"runtime modules with neither plunit tests nor a note here: {sorted(missing)}"
    assert set(WITHOUT_PLUNIT) <= modules, f"gone: {sorted(set(WITHOUT_PLUNIT) - modules)}"
    for module, where in WITHOUT_PLUNIT.items():         # the notes name tests that exist
        for name in re.findall(r"(test_\w+\.(?:py|pl))", where):
            folder = ROOT / "tests" if name.endswith(".py") else RUNTIME / "tests"
            assert (folder / name).exists(), (module, name)
