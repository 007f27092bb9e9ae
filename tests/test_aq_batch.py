"""Batch updates (aq_assert_all/1, aq_retract_all/1) on a store that mixes ground and non-ground
facts: the stored facts after every step equal a model of the documented set semantics, and a
query over ground facts equals its answers computed in Python.

The batch path decides per fact without asking first whether it is stored (a fact no state waits
on is erased at once) and, while every stored fact of every predicate is ground, retracts a ground
fact with retract/1 (and retractall/1 for a copy left behind) on the strength of one global flag
(`aq_ground`); once a non-ground fact is stored, the flag per predicate decides.  A wrong flag
would let retracting `e(0, 1)` remove the more general `e(X, 1)`, or an assertion add a fact that
a stored one implies: the model catches both.  The model (docs/active_queries.md, "Programs"):
asserting a ground fact does nothing when a stored fact is it or is more general; asserting a
non-ground fact does nothing when a variant is stored; retracting a fact removes every stored
variant of it (for a ground fact: itself only).
"""
from __future__ import annotations

import os
from typing import Dict, List, Tuple

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import test_aq_kept as kept
import aq_support as support
from retalisc.compiler import AqOptions, compile_source

# e/2 gets non-ground facts; f/1 and h/1 stay ground.  t/1 waits on e (so that retracting an
# e fact it matches goes through DRed); p/1 is the query whose answers are checked.
E_FACTS = ["e(0, 1)", "e(1, 1)", "e(0, 0)", "e(X, 1)", "e(0, Y)", "e(X, X)", "e(X, Y)"]
G_FACTS = ["f(0)", "f(1)", "f(2)", "h(0)", "h(1)", "h(2)"]
RULES = "p(X) :- f(X), h(X).\nt(X) :- e(X, 1).\n"


def canon(fact: str) -> Tuple[str, Tuple[str, ...]]:
    """A fact as (name, args) with its variables renamed A, B, ... in order of appearance."""
    name, rest = fact.split("(", 1)
    args = [a.strip() for a in rest.rstrip(")").split(",")]
    names: Dict[str, str] = {}
    out = []
    for a in args:
        if a[0].isupper() or a[0] == "_":
            names.setdefault(a, "ABCDEFGH"[len(names)])
            out.append(names[a])
        else:
            out.append(a)
    return name, tuple(out)


def is_var(a: str) -> bool:
    return a[0].isupper()


def subsumes(general, specific) -> bool:
    """general subsumes the ground fact specific."""
    if general[0] != specific[0] or len(general[1]) != len(specific[1]):
        return False
    binding: Dict[str, str] = {}
    for g, s in zip(general[1], specific[1]):
        if is_var(g):
            if binding.setdefault(g, s) != s:
                return False
        elif g != s:
            return False
    return True


def apply(store: List, op: str, facts: List[str]) -> None:
    for fact in facts:
        c = canon(fact)
        ground = not any(is_var(a) for a in c[1])
        if op == "+":
            if (any(subsumes(s, c) for s in store) if ground else c in store):
                continue
            store.append(c)
        else:
            store[:] = [s for s in store if s != c]


def shown(c) -> str:
    return f"{c[0]}({','.join(c[1])})"


@st.composite
def case(draw):
    facts = draw(st.lists(st.sampled_from(E_FACTS + G_FACTS), max_size=6, unique=True))
    some = st.sampled_from(E_FACTS + G_FACTS)
    steps = draw(st.lists(st.tuples(st.sampled_from("+-"), st.lists(some, min_size=1, max_size=3)),
                          min_size=1, max_size=8))
    return facts, steps


PRINT = r"""
print_store(K) :-
    forall(member(P, [e(_, _), f(_), h(_)]),
           forall(clause(P, true), ( copy_term(P, C), numbervars(C, 0, _),
                                     format("~w store ~W~n", [K, C, [numbervars(true), quoted(true), spacing(standard)]]) ))),
    aq_answers(p, As), format("~w answers ~q~n", [K, As]).
"""


def run(facts: List[str], steps) -> Dict[int, Tuple[List[str], str]]:
    source = ":- dynamic e/2, f/1, h/1.\n" + RULES + "".join(f + ".\n" for f in facts)
    generated = compile_source(source, "program.pl", active_queries=AqOptions("tabled")).prolog
    body = ["    aq_register(p, p(_), _), aq_register(t, t(_), _), print_store(0),"]
    for k, (op, batch) in enumerate(steps, start=1):
        pred = "aq_assert_all" if op == "+" else "aq_retract_all"
        body.append(f"    {pred}([{', '.join(batch)}]), print_store({k}),")
    body.append("    true.")
    lines = support._run(generated + PRINT + "main :-\n" + "\n".join(body) + "\n")
    out: Dict[int, Tuple[List[str], str]] = {}
    for line in lines:
        k, what, rest = line.split(" ", 2)
        store, answers = out.setdefault(int(k), ([], ""))
        if what == "store":
            store.append(rest.replace(" ", ""))
        else:
            out[int(k)] = (store, rest)
    return out


def expected_answers(store) -> str:
    f = {s[1][0] for s in store if s[0] == "f"}
    h = {s[1][0] for s in store if s[0] == "h"}
    return "[" + ",".join(f"p({x})" for x in sorted(f & h)) + "]"


SETTINGS = settings(max_examples=int(os.environ.get("AQ_EXAMPLES", "10")), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def check_against_the_model(facts, steps):
    got = run(facts, steps)
    store: List = [canon(f) for f in facts]          # the program's facts, as listed
    for k in range(len(steps) + 1):
        if k:
            apply(store, *steps[k - 1])
        stored, answers = got[k]
        assert sorted(stored) == sorted(shown(s) for s in store), f"step {k}: {steps[:k]}"
        assert answers.replace(" ", "") == expected_answers(store), f"step {k}: {steps[:k]}"


@SETTINGS
@given(case())
def test_batches_keep_the_set_semantics(data):
    check_against_the_model(*data)


def test_a_ground_retraction_keeps_a_more_general_fact():
    """The case a wrong all-ground flag gets wrong: e(X, 1) asserted after the flag was set."""
    got = run(["e(0, 1)", "f(1)", "h(1)"], [("-", ["f(1)"]), ("+", ["e(X, 1)"]), ("-", ["e(0, 1)"]),
                                           ("+", ["e(1, 1)", "f(1)"]), ("-", ["e(1, 1)"])])
    assert sorted(got[3][0]) == ["e(A,1)", "h(1)"]
    assert sorted(got[4][0]) == ["e(A,1)", "f(1)", "h(1)"]     # e(1, 1) is implied by e(X, 1)
    assert sorted(got[5][0]) == ["e(A,1)", "f(1)", "h(1)"]
    assert got[5][1] == "[p(1)]"


@st.composite
def case_with_repeated_facts(draw):
    """As case(), but the program may list a fact more than once."""
    facts, steps = draw(case())
    repeated = draw(st.lists(st.sampled_from(facts), max_size=3)) if facts else []
    return facts + repeated, steps


@SETTINGS
@given(case_with_repeated_facts())
def test_batches_keep_the_set_semantics_of_repeated_program_facts(data):
    """A fact the program lists twice is one fact: retracting it removes both copies, also while
    every stored fact is ground (the batch path of a ground fact)."""
    check_against_the_model(*data)


def test_a_repeated_ground_fact_goes_at_once():
    """h(5) listed twice, every fact ground, no state waiting on h(5) (no f(5)): one retraction
    removes both copies, so p(5) does not appear when f(5) comes."""
    got = run(["f(1)", "h(1)", "h(5)", "h(5)"], [("-", ["h(5)"]), ("+", ["f(5)"]), ("+", ["h(5)"])])
    assert got[0][1] == "[p(1)]"
    assert sorted(got[1][0]) == ["f(1)", "h(1)"]
    assert sorted(got[2][0]) == ["f(1)", "f(5)", "h(1)"]
    assert got[2][1] == "[p(1)]"
    assert got[3][1] == "[p(1),p(5)]"


def test_a_fact_listed_three_times_goes_at_once():
    """h(5) and h(1) listed three times: retracting h(5) (no state waits on it: the generated
    retraction of a ground fact) and h(1) (a state waits on it: the DRed pass and its cleanup)
    removes every copy, so nothing of either is left and p(5) does not come with f(5)."""
    got = run(["f(1)", "h(1)", "h(1)", "h(5)", "h(5)", "h(1)", "h(5)"],
              [("-", ["h(5)"]), ("-", ["f(0)", "h(1)"]), ("+", ["f(5)"])])
    assert got[0][1] == "[p(1)]"
    assert sorted(got[1][0]) == ["f(1)", "h(1)", "h(1)", "h(1)"]
    assert got[1][1] == "[p(1)]"
    assert sorted(got[2][0]) == ["f(1)"]
    assert got[2][1] == "[]"
    assert sorted(got[3][0]) == ["f(1)", "f(5)"]
    assert got[3][1] == "[]"


def test_a_batch_with_a_bad_fact_changes_nothing():
    """A batch is checked before any fact is changed, the ground batch (one ground/1 for the list,
    the predicates by index) as any other: a fact of a predicate without stored facts, a number, a
    variable or a list that is not one raise the error of the first bad fact, and the store and
    the answers stay as they were."""
    source = ":- dynamic e/2, f/1, h/1, alarm/0.\n" + RULES + "f(1).\nh(1).\nf(2).\n"
    generated = compile_source(source, "program.pl", active_queries=AqOptions("tabled")).prolog
    # [X] alone: a variable must not be taken for the stored predicate of arity 0
    batches = ["[f(3), h(2), p(3)]", "[h(2), 42]", "[f(3), X]", "[h(2)|f(3)]", "[h(2), e(0, Y), nope]",
               "[f(1), h(1), g(1)]", "[X]"]
    body = ["    aq_register(p, p(_), _), print_store(0),"]
    for k, batch in enumerate(batches, start=1):
        for pred in ("aq_assert_all", "aq_retract_all"):
            body.append(f"    catch(({pred}({batch}), E{k}{pred[3]} = none), error(E{k}{pred[3]}, _), true),"
                        f" format('~w ~w error ~q~n', [{k}, {pred[3]}, E{k}{pred[3]}]), print_store({k}),")
    body.append("    true.")
    lines = support._run(generated + PRINT + "main :-\n" + "\n".join(body) + "\n")
    errors = [line.split(" ", 3)[3] for line in lines if " error " in line]
    errors = [e if not e.startswith("type_error(callable,_") else "type_error(callable,_)" for e in errors]
    assert errors == ["permission_error(modify,static_procedure,p/1)"] * 2 \
        + ["type_error(callable,42)"] * 2 + ["type_error(callable,_)"] * 2 \
        + ["type_error(list,[h(2)|f(3)])"] * 2 + ["permission_error(modify,static_procedure,nope/0)"] * 2 \
        + ["permission_error(modify,static_procedure,g/1)"] * 2 + ["type_error(callable,_)"] * 2, errors
    stores = {line for line in lines if " store " in line or " answers " in line}
    assert {line.split(" ", 1)[1] for line in stores} == {"store f(1)", "store f(2)", "store h(1)",
                                                          "answers [p(1)]"}, stores


def test_a_ground_batch_that_makes_a_join_step_live():
    """While the program has a join step that no query uses yet, a batch's first fact can make it
    live (trigger(1) starts the table of r(1, _), whose state after t(1, Z) joins with e/2); the
    next fact of the same batch must then reach the join state: answers against SWI-Prolog's
    tabling and recomputation, and the notifications, for a ground batch and a mixed one."""
    source = (":- dynamic trigger/1, g/2, e/2.\n"
              "q(X) :- trigger(X), r(X, Y).\nr(X, Y) :- t(X, Z), e(Z, Y).\nt(X, Z) :- g(X, Z).\n"
              "g(1, 5).\ne(9, 9).\n")
    for batch in (["trigger(1)", "e(5, 7)"], ["trigger(1)", "e(5, 7)", "e(8, X)"]):
        for mode in ("tabled", "optimized"):
            kept.check(source, ["q(X)"], [("+", batch)], mode)
