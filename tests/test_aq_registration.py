"""What registering a query costs per table and per registration, kept exact.

The activation of a rule with a body order per adornment (aq_join_order): the written rule becomes one rule per order; their activation is one clause that computes the
call's adornment mask once and picks the order in an if-then-else.  Checked here: the generated
text (one mask per written rule, each order's states after it), that the runtime's reading of
the generated clauses (which clause creates a state, for DRed's re-derivation and the
derivations from facts) sees through the if-then-else, and, against SWI-Prolog's `:- table` and
recomputation, the answers of calls of every adornment of a rule with four orders under
additions and deletions, with both DRed variants.  AQ_EXAMPLES sets the number of examples
(default 12).

aq_reset/0 keeps what is known of the stored facts (whether all are ground), which stay: the
registration after it does not scan them again, and a non-ground fact stored before the reset
is still known after it; a fact asserted directly after the reset is seen."""
from __future__ import annotations

import os

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import aq_support as support
from retalisc.compiler import AqOptions, compile_source

RIGHT = "path(X, Y) :- edge(X, Z), path(Z, Y).\npath(X, Y) :- edge(X, Y).\n"
ACC = ":- dynamic seller/2, has/2, offers/3.\nacc(O, S) :- seller(S, T), has(T, O), offers(S, O, P).\n"
# four body orders (masks [0, 1, 3, 5], [2], [4, 6], [7]), the last two starting alike
CHAIN3 = ":- dynamic a/2, b/2, c/2.\np(X, Y, W) :- a(X, Z), b(Z, Y), c(Y, W).\n"


def generated(source: str) -> str:
    return compile_source(source, "program.pl", active_queries=AqOptions("tabled")).prolog


def test_one_activation_computes_the_mask_once():
    text = generated(RIGHT + "edge(0, 1).\n")
    assert text.count("aq_adornment(") == 1
    assert text.count("'$aq_act'(path(X, Y), T) :-") == 2       # the written rules
    assert ("'$aq_act'(path(X, Y), T) :-\n"
            "    aq_adornment([X, Y], M),\n"
            "    (   memberchk(M, [0, 1, 3])\n"
            "    ->  aq_wait_fact(edge(X, Z), s1_1(T, X, Y))\n"
            "    ;   aq_wait_call(path(Z, Y), s2_1(T, X, Y))\n"
            "    ).\n") in text
    assert "%   rules 1-2, a body order each by what the call binds" in text
    assert "%   rule 3 (" in text


def test_four_orders_one_if_then_else():
    text = generated(CHAIN3)
    assert text.count("aq_adornment(") == 1
    assert text.count("memberchk(M, ") == 3                      # the last order is the else
    for k in (1, 2, 3, 4):
        assert f"'$aq_go'(s{k}_1(T, X, Y, W)" in text


def run_prolog(source: str, goal: str) -> list:
    main = f"main :- {goal}.\n"
    return support._run(generated(source) + main)


def test_runtime_reads_the_creators_in_the_branches():
    """Which clause creates a state: the branch of the activation it is in, with the mask test
    (or the negation of the tests before it) as its check."""
    goal = (
        "aq_register(q, acc(o, s), _), rtl_aq:aq_q(q, _, call, T), "
        # mask 3 (both bound): the else branch, offers first
        "( rtl_aq:state_derivable(s3_1(T, o, s)) -> writeln(else_derivable) ; true ), "
        "( rtl_aq:state_derivable(s1_1(T, o, s)) -> writeln(first_derivable) ; true ), "
        "( rtl_aq:state_creator(s2_1(_, _, _), act) -> writeln(creator_found) ; true ), "
        "( rtl_aq:waits_on_facts(s1_1(_, _, _)) -> writeln(waits_on_facts) ; true ), "
        "( rtl_aq:fact_only_state(s1_2(_, _, _, _)) -> writeln(fact_only) ; true )")
    out = run_prolog(ACC + "seller(s, t).\nhas(t, o).\noffers(s, o, 1).\n", goal)
    assert out == ["else_derivable", "creator_found", "waits_on_facts", "fact_only"]


D = st.sampled_from(["0", "1", "2"])
FACT = st.one_of(*(st.tuples(D, D).map(lambda t, p=p: f"{p}({t[0]}, {t[1]})") for p in "abc"))
GOALS = ["p(X, Y, W)", "p(0, Y, W)", "p(X, 1, W)", "p(0, 1, W)", "p(X, Y, 2)", "p(0, Y, 2)",
         "p(X, 1, 2)", "p(0, 1, 2)"]


@st.composite
def case(draw):
    facts = draw(st.lists(FACT, min_size=3, max_size=14))          # repeats: stored twice
    pool = facts + draw(st.lists(FACT, max_size=6))
    steps = draw(st.lists(st.tuples(st.sampled_from("+--"), st.sampled_from(pool)), min_size=1, max_size=8))
    goals = draw(st.lists(st.sampled_from(GOALS), min_size=1, max_size=4, unique=True))
    return CHAIN3 + "".join(f + ".\n" for f in facts), goals, steps


SETTINGS = settings(max_examples=int(os.environ.get("AQ_EXAMPLES", "12")), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(case(), st.sampled_from(["primary", "basic"]))
def test_every_adornment_matches_oracles(case, dred):
    source, goals, steps = case
    inc, orc, scr, stats = support.run_all(source, goals, steps, "tabled", dred=dred)
    for key in orc:
        assert inc[key] == orc[key], f"step {key}: incremental {inc[key]} != SWI tabling {orc[key]}\n{source}"
        assert scr[key] == orc[key], f"step {key}: scratch {scr[key]} != SWI tabling {orc[key]}\n{source}"
    for key in ("tables", "consumers", "fact_records", "cstates"):
        assert f"{key}=0" in stats, stats


def test_reset_keeps_what_is_known_of_the_facts():
    goal = (
        "aq_register(q, path(0, _), _), aq_reset, nb_getval(aq_ground, kept(G1, _)), writeln(G1), "
        "aq_register(q, path(0, _), _), aq_reset, "
        "aq_assert(edge(2, _)), aq_reset, nb_getval(aq_ground, kept(G2, _)), writeln(G2), "
        "aq_register(q, path(0, _), A1), numbervars(A1, 0, _), print(A1), nl, "
        "aq_retract_all([edge(1, 2), edge(2, 9)]), aq_answers(q, A2), print(A2), nl, "
        "( user:clause(edge(2, X), true), var(X) -> writeln(kept) ; writeln(lost) ), "
        "aq_retract(edge(2, _)), aq_assert(edge(1, 2)), aq_answers(q, A3), print(A3), nl")
    out = run_prolog(RIGHT + ":- dynamic edge/2.\nedge(0, 1).\nedge(1, 2).\n", goal)
    assert out == ["true", "false", "[path(0,A),path(0,1),path(0,2)]", "[path(0,1)]", "kept",
                   "[path(0,1),path(0,2)]"]


def test_facts_changed_directly_after_a_reset_are_scanned_again():
    """What aq_reset/0 keeps of the facts holds only while no stored predicate changes: a fact
    asserted directly after it (as a test or a loader may) is seen by the next registration.  A
    non-ground edge(2, _) asserted so must not be erased by retracting the ground edge(2, 7),
    which is not stored, nor make path(0, _) lose support."""
    goal = (
        "aq_register(q, path(0, _), _), aq_reset, assertz(user:edge(2, _)), "
        "aq_register(q, path(0, _), A1), numbervars(A1, 0, _), print(A1), nl, "
        "aq_retract(edge(2, 7)), aq_answers(q, A2), numbervars(A2, 0, _), print(A2), nl, "
        "( user:clause(edge(2, X), true), var(X) -> writeln(kept) ; writeln(lost) )")
    out = run_prolog(RIGHT + ":- dynamic edge/2.\nedge(0, 1).\nedge(1, 2).\n", goal)
    assert out == ["[path(0,A),path(0,1),path(0,2)]", "[path(0,A),path(0,1),path(0,2)]", "kept"], out
