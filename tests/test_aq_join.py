"""Join states (docs/active_queries.md, "Fifth round: states"): a state after a call literal
that waits on a fact literal (`path(X, Y) :- path(X, Z), edge(Z, Y)`) keeps no goal record; it is
the join of its consumer state with that state's table, found when a fact arrives or goes.
Random graphs and rule shapes with point queries, edges added and deleted (single, batches,
retract/re-assert cycles) and left-recursive rules added and removed at run time: after every
step the answers equal SWI-Prolog's `:- table` and a registration from scratch."""
from __future__ import annotations

import os

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import aq_support as support
from test_aq_oracle import run_updates
from retalisc.compiler import AqOptions, compile_source

NODES = [str(n) for n in range(5)]
EDGE = st.tuples(st.sampled_from(NODES), st.sampled_from(NODES)).map(lambda t: f"edge({t[0]}, {t[1]})")

# rule shapes: joins (a call followed by a fact), a join after a builtin (no join state), a
# join whose fact literal binds nothing new, a join of a join, and right recursion beside them
RULES = {
    "left": "path(X, Y) :- path(X, Z), edge(Z, Y).\npath(X, Y) :- edge(X, Y).\n",
    "left_filtered": "path(X, Y) :- path(X, Z), Z =< 3, edge(Z, Y).\npath(X, Y) :- edge(X, Y).\n",
    "left_check": "path(X, Y) :- path(X, Z), edge(Z, Y).\npath(X, Y) :- edge(X, Y).\n"
                  "back(X, Y) :- path(X, Y), edge(Y, X).\n",
    "two_hops": "path(X, Y) :- path(X, Z), edge(Z, W), edge(W, Y).\npath(X, Y) :- edge(X, Y).\n",
    "mixed": "path(X, Y) :- edge(X, Z), path(Z, Y).\npath(X, Y) :- path(X, Z), edge(Z, Y).\n"
             "path(X, Y) :- edge(X, Y).\n",
}
GOALS = ["path(0, X)", "path(X, Y)", "path(0, 3)", "path(1, 1)", "path(X, 2)", "path(X, X)"]
ADDED_RULE = "(path(X, Y) :- path(X, Z), edge(Y, Z))"


@st.composite
def case(draw):
    name = draw(st.sampled_from(sorted(RULES)))
    rules = RULES[name]
    edges = draw(st.lists(EDGE, min_size=2, max_size=10, unique=True))
    again = draw(st.lists(st.sampled_from(edges), max_size=2))
    delete = st.sampled_from(edges).map(lambda e: ("-", e))
    add = EDGE.map(lambda e: ("+", e))
    steps = draw(st.lists(st.one_of(delete, delete, add), min_size=1, max_size=8))
    if draw(st.booleans()):     # a rule added at run time (its own states), later removed
        at = draw(st.integers(0, len(steps)))
        steps[at:at] = [("+", ADDED_RULE)]
        steps += draw(st.lists(st.one_of(delete, add), max_size=3)) + [("-", ADDED_RULE)]
        steps += draw(st.lists(st.one_of(delete, add), max_size=2))
    goals = ["back(X, Y)"] if name == "left_check" else []
    goals += draw(st.lists(st.sampled_from(GOALS), min_size=1, max_size=3, unique=True))
    source = ":- dynamic edge/2.\n" + rules + "\n".join(e + "." for e in edges + again) + "\n"
    return source, goals, steps


SETTINGS = settings(max_examples=int(os.environ.get("AQ_EXAMPLES", "25")), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def check(source, goals, steps, mode="tabled", subsumption=False, dred="primary"):
    inc, orc, scr, stats = support.run_all(source, goals, steps, mode, subsumption, dred=dred)
    for key in orc:
        assert inc[key] == orc[key], f"step {key}: incremental {inc[key]} != SWI tabling {orc[key]}\n{source}"
        assert scr[key] == orc[key], f"step {key}: scratch {scr[key]} != SWI tabling {orc[key]}\n{source}"
    for key in ("tables", "consumers", "fact_records", "cstates"):
        assert f"{key}=0" in stats, stats


@SETTINGS
@given(case(), st.sampled_from([("tabled", False, "primary"), ("tabled", False, "basic"),
                                ("tabled", True, "primary")]))
def test_join_states_match_oracles(case, variant):
    mode, subsumption, dred = variant
    check(*case, mode=mode, subsumption=subsumption, dred=dred)


def _stats_after(source, goal, updates=""):
    generated = compile_source(source, "chain.pl", active_queries=AqOptions("tabled")).prolog
    text = (generated + "main :- aq_register(q, " + goal + ", As), length(As, N), " + updates
            + "aq_answers(q, Bs), length(Bs, M), aq_stats(S), "
              "memberchk(fact_records=F, S), format('~w ~w ~w~n', [N, M, F]).\n")
    return [int(x) for x in support._run(text)[-1].split()]


def test_left_recursion_keeps_no_record_per_answer():
    """path(0, _) on a left-recursive chain of 60 edges: 60 answers, and the states waiting on
    edge(Z, Y) after each path(0, Z) are joins, not 60 goal records; a point query likewise."""
    source = (":- dynamic edge/2.\n" + support_rules("left")
              + "".join(f"edge({i}, {i + 1}).\n" for i in range(60)))
    answers, after, records = _stats_after(source, "path(0, _)", "aq_retract(edge(30, 31)), ")
    assert (answers, after) == (60, 30)
    assert records <= 2, records
    answers, after, records = _stats_after(source, "path(0, 60)", "aq_assert(edge(0, 60)), ")
    assert (answers, after) == (1, 1)
    assert records <= 4, records


def support_rules(name):
    return RULES[name]


def test_many_consumers_of_one_join_step():
    """40 queries path(I, _) on a left-recursive graph: past 32 consumer states of the join
    step its states get goal records again (every fact would otherwise look at all of them);
    the answers stay those of SWI tabling through additions and deletions, before and after."""
    edges = [f"edge({i}, {i + 1})" for i in range(40)] + ["edge(7, 3)", "edge(20, 11)", "edge(39, 0)"]
    source = ":- dynamic edge/2.\n" + RULES["left"] + "".join(e + ".\n" for e in edges)
    goals = [f"path({i}, X)" for i in range(0, 40, 3)] + [f"path({i}, X)" for i in range(1, 40, 3)] \
        + [f"path({i}, X)" for i in range(2, 40, 9)] + ["path(X, 5)", "path(3, 30)"]
    steps = [("-", "edge(39, 0)"), ("-", "edge(15, 16)"), ("+", "edge(39, 0)"), ("+", "edge(15, 16)"),
             ("-", "edge(7, 3)"), ("-", "edge(2, 3)"), ("+", "edge(41, 42)"), ("+", "edge(40, 41)"),
             ("+", "edge(2, 3)"), ("-", "edge(40, 41)")]
    check(source, goals, steps)
    before_switch = [f"path({i}, X)" for i in range(0, 40, 3)]
    check(source, before_switch, steps)


START = st.integers(0, 39).map(lambda i: f"start({i})")
BIG_EDGE = st.tuples(st.integers(0, 41), st.integers(0, 41)).map(lambda t: f"edge({t[0]}, {t[1]})")


@st.composite
def switch_case(draw):
    """Batches that start many tables of one join step at once (start(I) makes path(I, _) a
    table), with edges in the same batch: the step switches to goal records in the middle of
    the batch's propagation, or at a later update."""
    edges = [f"edge({i}, {i + 1})" for i in range(40)] + draw(st.lists(BIG_EDGE, max_size=6, unique=True))
    starts = draw(st.lists(START, max_size=5, unique=True))
    steps = []
    for _ in range(draw(st.integers(1, 4))):
        batch = draw(st.lists(st.one_of(START, START, START, BIG_EDGE), min_size=1, max_size=40))
        steps.append((draw(st.sampled_from("++-")), batch))
    source = (":- dynamic edge/2, start/1.\n" + RULES["left"] + "reach(X, Y) :- start(X), path(X, Y).\n"
              + "".join(f + ".\n" for f in edges + starts))
    return source, ["reach(X, Y)", "path(0, 20)"], steps


@settings(max_examples=max(5, int(os.environ.get("AQ_EXAMPLES", "25")) // 3), deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(switch_case())
def test_join_step_switching_to_records_in_a_batch(case):
    source, goals, steps = case
    inc, orc, scr, stats = run_updates(source, goals, steps, "tabled", False, "primary")
    for key in orc:
        assert inc[key] == orc[key], f"step {key}: incremental {inc[key]} != SWI tabling {orc[key]}"
        assert scr[key] == orc[key], f"step {key}: scratch {scr[key]} != SWI tabling {orc[key]}"
    assert "fact_records=0" in stats, stats


def test_switch_during_a_fact_propagation_keeps_the_fact_for_join_states():
    """edge(0, K) makes path(K, _) a new table (through hop/1) and is also the fact that the
    join state after path(50, 0) waits on: the step switches to goal records while the 33rd
    such edge propagates, and path(50, K) must still be derived from that edge."""
    source = (":- dynamic edge/2.\n" + RULES["left"] + "hop(Y) :- edge(0, X), path(X, Y).\n"
              + "edge(50, 0).\nedge(60, 61).\n")
    batch = [f"edge(0, {k})" for k in range(1, 41)] + [f"edge({k}, {k + 100})" for k in range(1, 41, 5)]
    steps = [("+", batch), ("-", ["edge(0, 7)", "edge(0, 35)"]), ("+", ["edge(0, 35)"])]
    inc, orc, scr, stats = run_updates(source, ["path(50, Y)", "hop(Y)"], steps, "tabled", False, "primary")
    for key in orc:
        assert inc[key] == orc[key], f"step {key}: incremental {inc[key]} != SWI tabling {orc[key]}"
        assert scr[key] == orc[key], f"step {key}: scratch {scr[key]} != SWI tabling {orc[key]}"


def test_registering_and_unregistering_keeps_the_join_step():
    """Beside a query path(0, _), a query path(1, _) registered and unregistered 40 times on a
    left-recursive chain: the join step never has more than two consumer states at a time, so
    it stays a join step (no goal record per answer), and the answers stay right."""
    source = (":- dynamic edge/2.\n" + RULES["left"]
              + "".join(f"edge({i}, {i + 1}).\n" for i in range(50)))
    churn = "forall(between(1, 40, _), ( aq_register(p, path(1, _), _), aq_unregister(p) )), "
    answers, after, records = _stats_after(source, "path(0, _)", churn + "aq_retract(edge(30, 31)), ")
    assert (answers, after) == (50, 30)
    assert records <= 2, records


def test_join_state_index_follows_the_live_steps():
    """The states of the live join steps are also kept by their functor (aq_join_state/1, the
    test every state waiting on facts makes): the two agree when a step goes live, after it
    switched to goal records, after aq_reset/0 and after a rule added and removed at run time."""
    source = (":- dynamic edge/2.\n" + RULES["left"]
              + "".join(f"edge({i}, {i + 1}).\n" for i in range(40)))
    generated = compile_source(source, "chain.pl", active_queries=AqOptions("tabled")).prolog
    text = generated + """
same(Tag) :- findall(S, rtl_aq:aq_join_step(_, _, _, S), Steps),
    findall(S, rtl_aq:aq_join_state(S), States), length(Steps, N),
    ( Steps =@= States -> format('~w ~w~n', [Tag, N]) ; format('~w differ~n', [Tag]) ).
main :- aq_register(q, path(0, _), _), same(live),
    forall(between(1, 34, I), aq_register(I, path(I, _), _)), same(switched),
    aq_reset, aq_register(q, path(0, _), _), same(reset),
    aq_add_rule((path(X, Y) :- path(X, Z), edge(Y, Z))), aq_register(r, path(2, _), _), same(added),
    aq_remove_rule((path(X, Y) :- path(X, Z), edge(Y, Z))), same(removed).
"""
    lines = support._run(text)
    assert lines[-5:] == ["live 1", "switched 0", "reset 1", "added 2", "removed 1"], lines
