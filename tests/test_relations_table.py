"""The operators' temporal relations are written once (prolog_runtime/rtl_relations.pl): the
compiler reads the table (retalisc/frontend/relations.py) and compiles its goals into every
step; the runtime loads it for `retalisc explain`. The plunit suite
prolog_runtime/tests/test_relations.pl (the table's meaning, on sample intervals) is run from
here too; tests/test_explain_agrees.py checks that explain and the program agree."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from retalisc.compiler import compile_source
from retalisc.frontend import relations as reader
from retalisc.frontend.terms import Compound, Var, to_prolog

ROOT = Path(__file__).resolve().parent.parent


def test_the_compiler_reads_each_relation_over_the_canonical_interval_names():
    table = reader.relation_table()
    assert set(table.relations) == {"seq", "and", "par", "equals", "meets", "during", "starts", "finishes", "cnot"}
    goals, start, end = table.relations["during"]
    assert [to_prolog(g) for g in goals] == ["<(S2, S1)", "<(E1, E2)"] and (start, end) == (Var("S2"), Var("E2"))
    assert [to_prolog(g) for g in table.blockers["cnot"]] == ["<(E1, SN)", "<(EN, S2)"]
    assert table.blocker_windows["fnot"] == (Var("SN"), Var("E1"))
    assert table.absence_result == (Var("S1"), Compound("+", (Var("E1"), Var("D"))))
    assert to_prolog(table.window) == "=<(-(To, From), W)"


def test_the_names_of_a_fact_are_renamed_by_position(tmp_path, monkeypatch):
    """A fact may name its variables as it likes: the compiler goes by the argument positions."""
    runtime = tmp_path / "runtime"
    runtime.mkdir()
    text = (ROOT / "prolog_runtime" / reader.RELATIONS_FILE).read_text()
    text = text.replace("rtl_relation(seq, S1-E1, S2-E2, [E1 < S2], S1, E2).",
                        "rtl_relation(seq, A-B, C-D, [B < C], A, D).")
    (runtime / reader.RELATIONS_FILE).write_text(text)
    monkeypatch.setattr(reader, "bundled_runtime_dir", lambda: runtime)
    reader.relation_table.cache_clear()
    try:
        goals, start, end = reader.relation_table().relations["seq"]
        assert [to_prolog(g) for g in goals] == ["<(E1, S2)"] and (start, end) == (Var("S1"), Var("E2"))
    finally:
        reader.relation_table.cache_clear()


@pytest.mark.parametrize("fact", ["rtl_relation(seq, S1, S2-E2, [S1 < S2], S1, E2).", "rtl_other(1).",
                                  "rtl_blocker(Op, S1-E1, none, SN-EN, [])."])
def test_a_fact_the_compiler_cannot_read_is_refused(fact, tmp_path, monkeypatch):
    runtime = tmp_path / "runtime"
    runtime.mkdir()
    text = (ROOT / "prolog_runtime" / reader.RELATIONS_FILE).read_text() + "\n" + fact + "\n"
    (runtime / reader.RELATIONS_FILE).write_text(text)
    monkeypatch.setattr(reader, "bundled_runtime_dir", lambda: runtime)
    reader.relation_table.cache_clear()
    try:
        with pytest.raises(ValueError, match="rtl_relations.pl"):
            reader.relation_table()
    finally:
        reader.relation_table.cache_clear()


def test_a_changed_relation_changes_the_compiled_rules(tmp_path, monkeypatch):
    """The compiled `seq` is the table's: another relation in the table, other goals."""
    runtime = tmp_path / "runtime"
    runtime.mkdir()
    text = (ROOT / "prolog_runtime" / reader.RELATIONS_FILE).read_text()
    text = text.replace("rtl_relation(seq, S1-E1, S2-E2, [E1 < S2], S1, E2).",
                        "rtl_relation(seq, S1-E1, S2-E2, [E1 =< S2], S1, E2).")
    (runtime / reader.RELATIONS_FILE).write_text(text)
    before = compile_source("h(X) <- a(X) seq b(X).\n", "rel.rtl").prolog
    monkeypatch.setattr(reader, "bundled_runtime_dir", lambda: runtime)
    reader.relation_table.cache_clear()
    try:
        after = compile_source("h(X) <- a(X) seq b(X).\n", "rel.rtl").prolog
    finally:
        reader.relation_table.cache_clear()
    assert "LEnd<RStart" in before.replace(" ", "") and "LEnd=<RStart" in after.replace(" ", "")


def test_plunit_rtl_relations():
    proc = subprocess.run(["swipl", "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_relations.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout
