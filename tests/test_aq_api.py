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


def shop_source(users, artists=20, shows_per_artist=10, likes_per_user=8, seed=3):
    """Program 6 of the thesis (users, artists' shows, likes) at a small size."""
    import random
    rng = random.Random(seed)
    facts = [f"show({a}, {rng.randint(1, 10)}, [{rng.randint(0, 10)}, {rng.randint(0, 10)}])."
             for a in range(artists) for _ in range(shows_per_artist)]
    for u in range(users):
        facts.append(f"loc({u}, [{rng.randint(0, 10)}, {rng.randint(0, 10)}]).")
        facts += [f"likes({u}, {a}, {rng.randint(1, 10)}, {rng.randint(1, 15)})."
                  for a in rng.sample(range(artists), likes_per_user)]
    rule = ("notify(User, Artist, Price, [LX, LY]) :- show(Artist, Price, [LX, LY]), "
            "likes(User, Artist, MaxPrice, MaxDistance), Price < MaxPrice, loc(User, [Lx, Ly]), "
            "sqrt((LX - Lx) * (LX - Lx) + (LY - Ly) * (LY - Ly)) < MaxDistance.\n")
    return rule + "\n".join(dict.fromkeys(facts)) + "\n"


# the indexes of the stored facts and goal records, without their sizes
INDEXES = ("findall(N/A-Is, ( user:'$aq_fact_pred'(F), ( G = F ; user:'$aq_whead'(F, _, G) ), "
           "functor(G, N, A), ( predicate_property(user:G, indexed(L)) -> true ; L = [] ), "
           "findall(I, member(I-_, L), Is) ), Out0), msort(Out0, Out1), format(string(Out), '~q', [Out1])")


def test_updates_after_many_registrations_build_no_index():
    """Registration builds the indexes that updates use (the first update after registering a
    query per user once paid for indexing every goal record and fact), also for goal records
    that grew from a few (no index worth building) to many over the registrations."""
    aq = ActiveQueries.from_source(shop_source(users=300), "shop.pl")
    for u in range(300):
        aq.register(f"u{u}", f"notify({u}, A, P, L)")
    before = aq.bridge.call_text(INDEXES)
    assert "'aq_w:show/3'/4-[single(1)" in before
    assert aq.bridge.once("nb_getval(aq_ground, true)")
    liked = aq.bridge.call_text("once(user:likes(7, A, P, D)), format(string(Out), '~q', [likes(7, A, P, D)])")
    before_answers = aq.answers("u7")
    aq.retract_fact(liked)
    aq.assert_fact(liked)
    assert aq.answers("u7") == before_answers
    assert aq.bridge.call_text(INDEXES) == before


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


def test_register_with_unsorted_answers():
    """aq_register/4 with answers(unsorted): each answer once, in the table's order; the same
    set as the sorted list of aq_register/3 (a fact listed twice is one answer)."""
    from retalisc.compiler import AqOptions, compile_source
    from aq_support import _run
    facts = "".join(f"edge({(7 * i) % 50}, {(7 * i + 3) % 50}).\n" for i in range(60))
    source = PROGRAM4 + facts + "edge(0, 1).\n"
    generated = compile_source(source, "unsorted.pl", active_queries=AqOptions("tabled")).prolog
    main = ("main :- aq_register(s, path(0, X), Sorted), aq_unregister(s),\n"
            "    aq_register(u, path(0, X), Unsorted, [answers(unsorted)]), aq_answers(u, Now),\n"
            "    msort(Unsorted, U1), length(Unsorted, N),\n"
            "    aq_register(f, edge(0, Y), Fs, [answers(unsorted)]),\n"
            "    catch(aq_register(g, edge(0, Y), _, [answers(random)]), error(E, _), true),\n"
            "    ( U1 == Sorted -> B1 = same ; B1 = differ ), ( Now == Sorted -> B2 = same ; B2 = differ ),\n"
            "    format('~w ~w ~w ~q ~q~n', [N, B1, B2, Fs, E]).\n")
    out = _run(generated + main)[-1].split(" ")
    assert int(out[0]) > 20 and out[1:3] == ["same", "same"], out
    assert out[3] in ("[edge(0,1),edge(0,3)]", "[edge(0,3),edge(0,1)]"), out
    assert out[4].startswith("type_error"), out
