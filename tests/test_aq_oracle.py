"""Oracle tests: random definite programs and random add/delete sequences.  After every update
the maintained answers equal (a) recomputation from scratch with the same transformation and
(b) SWI-Prolog's own `:- table` answers, for all three transformations."""
from __future__ import annotations

import os

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from test_aq_support import run_all

VARS = ["X", "Y", "Z", "W"]
CONSTS = ["0", "1", "2"]
# predicate -> arity; facts e/2, f/1; rules q/1, p/2, r/2 (r also has facts)
FACT_PREDS = {"e": 2, "f": 1}
RULE_PREDS = [("q", 1), ("p", 2), ("r", 2)]
LEVEL = {"e": 0, "f": 0, "q": 1, "p": 2, "r": 3}


@st.composite
def literal(draw, allowed):
    name = draw(st.sampled_from(allowed))
    arity = {**FACT_PREDS, "q": 1, "p": 2, "r": 2}[name]
    args = [draw(st.sampled_from(VARS + CONSTS[:1] + VARS)) for _ in range(arity)]
    return name, args


@st.composite
def rule(draw, head_name, head_arity, recursive):
    allowed = [n for n in LEVEL if recursive or LEVEL[n] < LEVEL[head_name]]
    body = draw(st.lists(literal(allowed), min_size=1, max_size=3))
    body_vars = [a for _, args in body for a in args if a in VARS]
    head_args = [draw(st.sampled_from(body_vars + CONSTS[:2])) if body_vars else draw(st.sampled_from(CONSTS))
                 for _ in range(head_arity)]
    goals = [f"{n}({', '.join(a)})" for n, a in body]
    distinct = list(dict.fromkeys(body_vars))
    if len(distinct) >= 2 and draw(st.booleans()):
        goals.append(f"{distinct[0]} =< {distinct[1]}")
    return f"{head_name}({', '.join(head_args)}) :- {', '.join(goals)}."


@st.composite
def program(draw, recursive):
    rules = []
    for name, arity in RULE_PREDS:
        rules += draw(st.lists(rule(name, arity, recursive), min_size=1, max_size=2))
    fact = st.one_of(
        st.tuples(st.just("e"), st.sampled_from(CONSTS), st.sampled_from(CONSTS)).map(lambda t: f"e({t[1]}, {t[2]})"),
        st.sampled_from(CONSTS).map(lambda c: f"f({c})"),
        st.tuples(st.sampled_from(CONSTS), st.sampled_from(CONSTS)).map(lambda t: f"r({t[0]}, {t[1]})"),
    )
    facts = draw(st.lists(fact, max_size=6, unique=True))
    steps = draw(st.lists(st.tuples(st.sampled_from("+-"), fact), min_size=1, max_size=6))
    goals = draw(st.lists(st.sampled_from(["p(X, Y)", "p(0, X)", "q(X)", "r(X, Y)", "r(1, X)", "p(X, X)"]),
                          min_size=1, max_size=3, unique=True))
    source = ":- dynamic e/2, f/1, r/2.\n" + "\n".join(rules + [f + "." for f in facts]) + "\n"
    return source, goals, steps


def check(source, goals, steps, mode, subsumption=False, dred="primary"):
    inc, orc, scr, stats = run_all(source, goals, steps, mode, subsumption, dred=dred)
    for key in orc:
        assert inc[key] == orc[key], f"step {key}: incremental {inc[key]} != SWI tabling {orc[key]}\n{source}"
        assert scr[key] == orc[key], f"step {key}: scratch {scr[key]} != SWI tabling {orc[key]}\n{source}"
    assert "tables=0" in stats and "consumers=0" in stats and "fact_records=0" in stats, stats


SETTINGS = settings(max_examples=int(os.environ.get("AQ_EXAMPLES", "25")), deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(program(recursive=True))
def test_tabled_matches_oracles(case):
    check(*case, mode="tabled")


@SETTINGS
@given(program(recursive=True))
def test_tabled_subsumption_matches_oracles(case):
    check(*case, mode="tabled", subsumption=True)


@SETTINGS
@given(program(recursive=True))
def test_naive_matches_oracles(case):
    check(*case, mode="naive")


@SETTINGS
@given(program(recursive=False))
def test_optimized_matches_oracles(case):
    check(*case, mode="optimized")


@SETTINGS
@given(program(recursive=True))
def test_tabled_basic_dred_matches_oracles(case):
    check(*case, mode="tabled", dred="basic")


# Graphs with cycles and many redundant derivations, where the two DRed variants differ most:
# an answer keeps the derivation that created it unless a deletion reaches that one.
PATH_RULES = {
    "right": "path(X, Y) :- edge(X, Z), path(Z, Y).\npath(X, Y) :- edge(X, Y).\n",
    "left": "path(X, Y) :- path(X, Z), edge(Z, Y).\npath(X, Y) :- edge(X, Y).\n",
    "double": "path(X, Y) :- path(X, Z), path(Z, Y).\npath(X, Y) :- edge(X, Y).\n",
}
NODES = [str(n) for n in range(6)]
EDGE = st.tuples(st.sampled_from(NODES), st.sampled_from(NODES)).map(lambda t: f"edge({t[0]}, {t[1]})")


@st.composite
def graph_case(draw):
    rules = PATH_RULES[draw(st.sampled_from(sorted(PATH_RULES)))]
    edges = draw(st.lists(EDGE, min_size=3, max_size=14, unique=True))
    # deletions mostly of edges that are there, so that they change something
    delete = st.sampled_from(edges).map(lambda e: ("-", e))
    steps = draw(st.lists(st.one_of(delete, delete, EDGE.map(lambda e: ("+", e))), min_size=1, max_size=8))
    goals = draw(st.lists(st.sampled_from(["path(X, Y)", "path(0, X)", "path(X, 0)", "path(X, X)"]),
                          min_size=1, max_size=2, unique=True))
    source = ":- dynamic edge/2.\n" + rules + "\n".join(e + "." for e in edges) + "\n"
    return source, goals, steps


@SETTINGS
@given(graph_case(), st.sampled_from([("tabled", "primary"), ("tabled", "basic"), ("naive", "primary")]))
def test_graph_deletions_match_oracles(case, variant):
    mode, dred = variant
    check(*case, mode=mode, dred=dred)
