"""The runtime's flags and counters (prolog_runtime/rtl_flags.pl): its plunit suite,
prolog_runtime/tests/test_flags.pl, with the module loaded alone; and, through an Engine, the
counters in their prefixed globals (`rtl_stat_<Name>`) kept by snapshots and out of reach of
untrusted goals (prolog_runtime/rtl_sandbox.pl)."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from retalisc.driver.bridge import PrologError
from retalisc.driver.engine import Engine, QueryError

ROOT = Path(__file__).resolve().parent.parent


def test_plunit_rtl_flags(swipl):
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_flags.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout


# ---- the counters through an Engine: prefixed globals, snapshots, the goal boundary ----------

PROGRAM = "alarm(X) <- smoke(X) seq heat(X).\n"


@pytest.fixture
def engine():
    e = Engine.from_source(PROGRAM, "flags.rtl")
    e.set_flag("max_delay", "inf")
    return e


def test_counters_survive_a_snapshot(engine, tmp_path):
    engine.feed_batch([("smoke(a)", 1), ("heat(a)", 2), ("smoke(b)", 3)])
    before = engine.stats()
    assert before["events"] == 3 and before["derived"] == 1
    engine.save_state(tmp_path / "s.state")
    saved = (tmp_path / "s.state").read_text()
    assert "global(rtl_stat_events,3)." in saved
    assert "global(events," not in saved                 # no unprefixed counter left
    engine.feed_batch([("heat(b)", 4)])
    assert engine.stats()["events"] == 4
    engine.restore_state(tmp_path / "s.state")
    assert engine.stats() == before


@pytest.mark.parametrize("goal", [
    "nb_getval(rtl_stat_events, X)",
    "nb_setval(rtl_stat_events, 0)",
    "b_getval(rtl_stat_derived, X)",
    "nb_current(rtl_stat_events, X)",
    "nb_getval(rtl_clock, X)",
])
def test_untrusted_goals_reach_no_global(engine, goal):
    with pytest.raises(QueryError, match="unsafe goal") as refused:
        engine.query(goal)
    assert refused.value.kind == "unsafe"


def test_a_rule_added_at_run_time_reads_no_counter(engine):
    with pytest.raises(PrologError, match="unsafe goal"):
        engine.add_rules("peek(N) <- smoke(X) where nb_getval(rtl_stat_events, N).\n")
    assert engine.query("rtl_stat(events, N)") == {"N": "0"}
