"""Python API of active queries (retalisc.driver.active_queries) over the bridge, plus the
Prolog-level plunit tests of the runtime."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from retalisc.driver.active_queries import ActiveQueries

PROGRAM4 = """
path(X, Y) :- path(X, Z), edge(Z, Y).
path(X, Y) :- edge(X, Y).
edge(0, 1).
edge(1, 2).
"""

ROOT = Path(__file__).resolve().parent.parent

# live clauses of every runtime table and goal-record predicate (erased clauses excluded)
LIVE_RECORDS = ("aggregate_all(sum(N), ( member(M, [rtl_aq, user]), current_predicate(M:P/A), "
                "( M == rtl_aq ; sub_atom(P, 0, _, _, 'aq_w:') ), functor(H, P, A), "
                "predicate_property(M:H, dynamic), predicate_property(M:H, number_of_clauses(N)) ), C), "
                "format(string(Out), '~w', [C])")


@pytest.mark.parametrize("mode", ["tabled", "naive"])
def test_register_notify_unregister(mode):
    aq = ActiveQueries.from_source(PROGRAM4, "program4.pl", mode=mode)
    added, deleted = [], []
    aq.on_add(lambda q, a: added.append((q, a)))
    aq.on_delete(lambda q, a: deleted.append((q, a)))
    baseline = aq.stats()
    assert aq.register("q", "path(0, X)") == ["path(0,1)", "path(0,2)"]
    assert aq.register(7, "path(X, 2)") == ["path(0,2)", "path(1,2)"]
    aq.assert_fact("edge(2, 0)")
    assert set(added) == {("q", "path(0,0)"), (7, "path(2,2)")}
    assert aq.answers("q") == ["path(0,0)", "path(0,1)", "path(0,2)"]
    aq.retract_facts(["edge(1, 2)", "edge(2, 0)"])
    assert set(deleted) == {(7, "path(0,2)"), (7, "path(1,2)"), (7, "path(2,2)"),
                               ("q", "path(0,0)"), ("q", "path(0,2)")}
    assert aq.answers(7) == []
    aq.assert_facts(["edge(1, 2)", "edge(2, 3)"])
    assert ("q", "path(0,3)") in added
    aq.unregister("q")
    aq.unregister(7)
    after = aq.stats()
    # memory returns to the baseline: no table, answer, goal record or dependency is left
    for key in ("queries", "tables", "answers", "consumers", "fact_records", "cstates", "subgoals", "deps", "multi"):
        assert after[key] == baseline[key] == 0, (key, after)


def test_unregister_keeps_shared_tables():
    aq = ActiveQueries.from_source(PROGRAM4, "program4.pl", mode="tabled")
    aq.register("a", "path(0, X)")
    aq.register("b", "path(0, Y)")
    aq.unregister("a")
    assert aq.stats()["tables"] == 1
    assert aq.answers("b") == ["path(0,1)", "path(0,2)"]
    aq.unregister("b")
    assert aq.stats()["tables"] == 0


def test_memory_returns_to_baseline_on_a_large_chain():
    facts = "\n".join(f"edge({i}, {i + 1})." for i in range(300))
    source = "path(X, Y) :- edge(X, Z), path(Z, Y).\npath(X, Y) :- edge(X, Y).\n" + facts
    aq = ActiveQueries.from_source(source, "chain.pl")
    aq.register("warm", "path(299, X)")   # autoload every library the runtime uses
    aq.retract_fact("edge(299, 300)")
    aq.assert_fact("edge(299, 300)")
    aq.unregister("warm")
    aq.stats()
    used0 = int(aq.bridge.call_text(LIVE_RECORDS))
    assert len(aq.register("q", "path(0, X)")) == 300
    mid = aq.stats()
    assert mid["tables"] == 301 and mid["answers"] > 45000
    aq.retract_fact("edge(150, 151)")
    aq.unregister("q")
    assert all(v == 0 for v in aq.stats().values())
    used1 = int(aq.bridge.call_text(LIVE_RECORDS))
    assert used1 <= used0


def test_errors_are_reported():
    from retalisc.driver.bridge import PrologError
    aq = ActiveQueries.from_source(PROGRAM4, "program4.pl")
    with pytest.raises(PrologError):
        aq.assert_fact("path(1, 2)")  # not a dynamic predicate
    with pytest.raises(PrologError):
        aq.register("z", "nosuch(X)")
    aq.register("z", "path(1, X)")
    with pytest.raises(PrologError):
        aq.register("z", "path(1, X)")
    aq.unregister("z")


def test_plunit_runtime(tmp_path):
    import os
    from retalisc.compiler import AqOptions, compile_source
    program = tmp_path / "p4.pl"
    program.write_text(compile_source(PROGRAM4, "program4.pl", active_queries=AqOptions()).prolog)
    proc = subprocess.run(["swipl", "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_aq.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120,
                          env={**os.environ, "AQ_TEST_PROGRAM": str(program)})
    assert proc.returncode == 0, proc.stdout


def test_rules_added_and_removed_at_run_time():
    from retalisc.driver.bridge import PrologError
    aq = ActiveQueries.from_source(":- dynamic e/2.\ne(1, 2). e(2, 3).\nr(X, Y) :- e(X, Y).\n", "rules.pl")
    added, deleted = [], []
    aq.on_add(lambda q, a: added.append(a))
    aq.on_delete(lambda q, a: deleted.append(a))
    assert aq.register("q", "r(1, Y)") == ["r(1,2)"]
    aq.add_rule("r(X, Y) :- e(X, Z), r(Z, Y)")
    assert added == ["r(1,3)"]
    with pytest.raises(PrologError):
        aq.add_rule("r(X, Y) :- e(X, Y), shell('ls')")     # untrusted: refused, nothing runs
    aq.remove_rule("r(X, Y) :- e(X, Z), r(Z, Y)")
    assert deleted == ["r(1,3)"] and aq.answers("q") == ["r(1,2)"]
    with pytest.raises(PrologError):
        aq.remove_rule("r(X, Y) :- e(X, Z), r(Z, Y)")
