"""Oracle tests: random definite programs and random add/delete sequences.  After every update
the maintained answers equal (a) recomputation from scratch with the same transformation and
(b) SWI-Prolog's own `:- table` answers, for all three transformations.

Facts have set semantics: programs list some facts twice, a batch (aq_assert_all/1,
aq_retract_all/1) may name a fact twice, and updates retract and re-assert the same fact.
AQ_EXAMPLES sets the number of examples per test (default 25)."""
from __future__ import annotations

import os
from typing import List, Tuple

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import aq_support as support
from retalisc.compiler import AqOptions, compile_source

# An update step: ("+" | "-", [fact, ...]); one fact is aq_assert/aq_retract, more are one batch
Update = Tuple[str, List[str]]

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
def listed_facts(draw, fact, max_size, min_size=0):
    """Facts as a program lists them: distinct ones, some listed twice (or three times)."""
    facts = draw(st.lists(fact, min_size=min_size, max_size=max_size, unique=True))
    again = draw(st.lists(st.sampled_from(facts), max_size=3)) if facts else []
    return draw(st.permutations(facts + again))


@st.composite
def updates(draw, fact, present):
    """Update steps: single asserts and retracts, batches that may name a fact twice, and
    retract/re-assert cycles; retractions mostly of facts the program lists (`present`)."""
    known = st.sampled_from(present) if present else fact
    some = st.one_of(fact, known)
    single = st.tuples(st.sampled_from("+-"), some.map(lambda f: [f]))
    named = st.tuples(st.lists(some, min_size=1, max_size=3), st.booleans())
    batch = st.tuples(st.sampled_from("+-"),
                      named.flatmap(lambda t: st.permutations(t[0] + t[0][:1] if t[1] else t[0])))
    cycle = st.tuples(known, st.sampled_from("+-")).map(
        lambda t: [("-", [t[0]]), ("+", [t[0]]), ("-", [t[0]])] if t[1] == "-"
        else [("+", [t[0]]), ("-", [t[0]]), ("+", [t[0]])])
    parts = draw(st.lists(st.one_of(single.map(lambda u: [u]), batch.map(lambda u: [u]), cycle),
                          min_size=1, max_size=4))
    return [u for part in parts for u in part]


FACT = st.one_of(
    st.tuples(st.sampled_from(CONSTS), st.sampled_from(CONSTS)).map(lambda t: f"e({t[0]}, {t[1]})"),
    st.sampled_from(CONSTS).map(lambda c: f"f({c})"),
    st.tuples(st.sampled_from(CONSTS), st.sampled_from(CONSTS)).map(lambda t: f"r({t[0]}, {t[1]})"),
)


@st.composite
def program(draw, recursive):
    rules = []
    for name, arity in RULE_PREDS:
        rules += draw(st.lists(rule(name, arity, recursive), min_size=1, max_size=2))
    facts = draw(listed_facts(FACT, 6))
    steps = draw(updates(FACT, facts))
    goals = draw(st.lists(st.sampled_from(["p(X, Y)", "p(0, X)", "q(X)", "r(X, Y)", "r(1, X)", "p(X, X)"]),
                          min_size=1, max_size=3, unique=True))
    source = ":- dynamic e/2, f/1, r/2.\n" + "\n".join(rules + [f + "." for f in facts]) + "\n"
    return source, goals, steps


def run_updates(source: str, goals: List[str], steps: List[Update], mode: str, subsumption: bool,
                dred: str):
    """aq_support.run_all with batches: the answer sets after registration (step 0) and after
    every update step, incremental, SWI `:- table` oracle and scratch, and the stats at the end."""
    generated = compile_source(source, "program.pl", active_queries=AqOptions(mode, subsumption)).prolog
    generated += f":- aq_configure([dred({dred})]).\n"
    qlist = "[" + ", ".join(goals) + "]"
    olist = "[" + ", ".join(f"({support.oracle_goal(g, source)})-({g})" for g in goals) + "]"

    def update(op: str, facts: List[str]) -> str:
        if len(facts) == 1:
            return f"{'aq_assert' if op == '+' else 'aq_retract'}({facts[0]})"
        return f"{'aq_assert_all' if op == '+' else 'aq_retract_all'}([{', '.join(facts)}])"

    body = [f"    Qs = {qlist}, Os = {olist},",
            "    forall(nth1(I, Qs, G), aq_register(I, G, _)),",
            "    print_state(0, Qs), print_oracle(0, Os),"]
    sbody = [f"    Qs = {qlist},", "    scratch(0, Qs),"]
    for k, (op, facts) in enumerate(steps, start=1):
        body.append(f"    {update(op, facts)}, print_state({k}, Qs), print_oracle({k}, Os),")
        sbody.append(f"    {update(op, facts)}, scratch({k}, Qs),")
    body.append("    aq_events(_), forall(nth1(I, Qs, _), aq_unregister(I)), aq_stats(St), "
                "format('0 0 stats ~q~n', [St]).")
    sbody.append("    true.")
    lines = support._run(generated + support.oracle_rules(source) + support._PRINT
                         + "main :-\n" + "\n".join(body) + "\n")
    stext = (generated + support._PRINT + "scratch(K, Qs) :- forall(nth1(I, Qs, G), aq_register(I, G, _)), "
             "print_state(K, Qs), aq_reset.\n" + "main :-\n" + "\n".join(sbody) + "\n")
    scr = support._parse(support._run(stext), "inc")
    return (support._parse(lines, "inc"), support._parse(lines, "oracle"), scr,
            support._parse(lines, "stats")[(0, 0)])


def check(source, goals, steps, mode, subsumption=False, dred="primary"):
    inc, orc, scr, stats = run_updates(source, goals, steps, mode, subsumption, dred)
    for key in orc:
        assert inc[key] == orc[key], f"step {key}: incremental {inc[key]} != SWI tabling {orc[key]}\n{source}"
        assert scr[key] == orc[key], f"step {key}: scratch {scr[key]} != SWI tabling {orc[key]}\n{source}"
    for key in ("tables", "consumers", "fact_records", "cstates", "negations"):
        assert f"{key}=0" in stats, stats


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
    edges = draw(listed_facts(EDGE, 14, min_size=3))
    # deletions mostly of edges that are there, so that they change something
    delete = st.sampled_from(edges).map(lambda e: ("-", [e]))
    steps = draw(st.lists(st.one_of(delete, delete, EDGE.map(lambda e: ("+", [e]))), min_size=1, max_size=8))
    steps += draw(updates(EDGE, edges))
    goals = draw(st.lists(st.sampled_from(["path(X, Y)", "path(0, X)", "path(X, 0)", "path(X, X)"]),
                          min_size=1, max_size=2, unique=True))
    source = ":- dynamic edge/2.\n" + rules + "\n".join(e + "." for e in edges) + "\n"
    return source, goals, steps


@SETTINGS
@given(graph_case(), st.sampled_from([("tabled", "primary"), ("tabled", "basic"), ("naive", "primary")]))
def test_graph_deletions_match_oracles(case, variant):
    mode, dred = variant
    check(*case, mode=mode, dred=dred)
