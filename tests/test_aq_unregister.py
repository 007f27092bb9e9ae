"""Unregistering one of several active queries frees exactly the tables no other query needs.
The dependencies between tables are read from the states (a table's consumer states and its
states at a negated literal), not recorded per table.  Random graphs and update sequences, one
query unregistered in the middle: after every update the remaining queries' answers equal
SWI-Prolog's `:- table` evaluation (a table freed while a remaining state still needs it
would lose answers or updates), and unregistering the rest leaves no table, state or record."""
from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.compiler import AqOptions, compile_source
from aq_support import _PRINT, _parse, _run, oracle_goal, oracle_rules

PROGRAMS = {
    "right": "path(X, Y) :- edge(X, Y).\npath(X, Y) :- edge(X, Z), path(Z, Y).\n",
    "left": "path(X, Y) :- edge(X, Y).\npath(X, Y) :- path(X, Z), edge(Z, Y).\n",
    "negation": ("path(X, Y) :- edge(X, Y).\npath(X, Y) :- edge(X, Z), path(Z, Y).\n"
                 "apart(X, Y) :- node(X), node(Y), \\+ path(X, Y).\n"
                 "lonely(X) :- node(X), \\+ apart(X, 0).\n"),
}
GOALS = {
    "right": ["path(0, Y)", "path(X, 2)", "path(1, 3)", "path(X, Y)"],
    "left": ["path(0, Y)", "path(X, 2)", "path(1, 3)", "path(X, Y)"],
    "negation": ["apart(0, Y)", "lonely(X)", "path(1, Y)", "apart(X, 2)"],
}
NODES = range(4)
EDGES = [f"edge({a}, {b})" for a in NODES for b in NODES]


def scenario(program, goals, facts, steps, gone, mode):
    """Register `goals`, apply `steps` (("+"|"-", fact) or ("!", "") to unregister query
    `gone`), print the remaining queries' answers and the oracle's after every step, the
    goals of the tables left, and aq_stats/1 once the remaining queries are unregistered."""
    source = PROGRAMS[program]
    node_facts = "".join(f"node({n}).\n" for n in NODES) if program == "negation" else ""
    full = source + node_facts + "".join(f"{f}.\n" for f in facts)
    if not facts:
        full += ":- dynamic edge/2.\n"
    generated = compile_source(full, "program.pl", active_queries=AqOptions(mode)).prolog
    oracle = oracle_rules(full)
    qlist = "[" + ", ".join(goals) + "]"
    olist = "[" + ", ".join(f"({oracle_goal(g, full)})-({g})" for g in goals) + "]"
    body = [f"    Qs = {qlist}, Os = {olist},",
            "    forall(nth1(I, Qs, G), aq_register(I, G, _)),",
            "    live(0, Qs, Os),"]
    for k, (op, fact) in enumerate(steps, start=1):
        if op == "!":
            body.append(f"    aq_unregister({gone}), nb_setval(gone, {gone}),")
        else:
            body.append(f"    aq_{'assert' if op == '+' else 'retract'}({fact}),")   # the oracle reads them too
        body.append(f"    live({k}, Qs, Os),")
    body += ["    table_goals(Left), format('0 0 left ~q~n', [Left]),",
             "    forall(( nth1(I, Qs, _), \\+ nb_getval(gone, I) ), aq_unregister(I)),",
             "    aq_stats(Stats), format('0 0 stats ~q~n', [Stats])."]
    helpers = r"""
:- nb_setval(gone, none).
live(K, Qs, Os) :-
    nb_getval(gone, Gone),
    forall(( nth1(I, Qs, _), I \== Gone ), ( aq_answers(I, L), format("~w ~w inc ~q~n", [K, I, L]) )),
    abolish_all_tables,
    forall(( nth1(I, Os, O-G), I \== Gone ),
           ( findall(G, O, L0), sort(L0, L), format("~w ~w oracle ~q~n", [K, I, L]) )).
table_goals(Goals) :-
    findall(G, ( rtl_aq:aq_tab(_, G0, _, _, _), copy_term(G0, G), numbervars(G, 0, _) ), Goals0),
    msort(Goals0, Goals).
"""
    lines = _run(generated + oracle + _PRINT + helpers + "main :-\n" + "\n".join(body) + "\n")
    return _parse(lines, "inc"), _parse(lines, "oracle"), _parse(lines, "left")[(0, 0)], \
        _parse(lines, "stats")[(0, 0)]


@st.composite
def cases(draw):
    program = draw(st.sampled_from(sorted(PROGRAMS)))
    facts = draw(st.lists(st.sampled_from(EDGES), unique=True, max_size=8))
    stored = set(facts)
    steps = []
    for _ in range(draw(st.integers(2, 8))):
        fact = draw(st.sampled_from(EDGES))
        if fact in stored:
            stored.discard(fact)
            steps.append(("-", fact))
        else:
            stored.add(fact)
            steps.append(("+", fact))
    steps.insert(draw(st.integers(0, len(steps))), ("!", ""))
    gone = draw(st.integers(1, len(GOALS[program])))
    return program, facts, steps, gone


SETTINGS = settings(max_examples=int(os.environ.get("AQ_EXAMPLES", "25")), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def check(case, mode):
    program, facts, steps, gone = case
    inc, orc, _, stats = scenario(program, GOALS[program], facts, steps, gone, mode)
    assert inc == orc
    assert_nothing_left(stats)


def assert_nothing_left(stats):
    counts = dict(item.split("=") for item in stats.strip("[]").split(","))
    assert {k: v for k, v in counts.items() if v != "0"} == {}


@pytest.mark.parametrize("mode", ["tabled", "naive"])   # the optimized mode loops on cycles
@SETTINGS
@given(case=cases())
def test_unregistering_one_query_keeps_what_the_others_need(case, mode):
    check(case, mode)


def test_a_table_needed_only_through_a_negation_survives():
    """`apart(X, 2)` checks `\\+ path(X, 2)` for each X: path(0, 2) is a table only that
    negation reaches once `path(X, Y)` is gone; it must stay and follow the updates."""
    steps = [("!", ""), ("+", "edge(0, 2)"), ("-", "edge(0, 1)"), ("-", "edge(0, 2)")]
    inc, orc, left, stats = scenario("negation", ["path(1, Y)", "apart(X, 2)"],
                                     ["edge(0, 1)", "edge(1, 2)"], steps, 1, "tabled")
    assert inc == orc
    assert "path(0,2)" in left
    assert_nothing_left(stats)
