"""XSB compatibility of `retalisc aq` beyond the golden cases (tests/golden/xsb_*): the notes
for ignored XSB directives and the directives refused, multi-line quoted atoms in update
scripts, the checks on rules added at run time, rules added for a predicate with stored facts
only (checked against SWI-Prolog's tabling with hypothesis), builtin tests placed where their
arguments are bound, and the normalisation of disjunction and if-then-else."""
from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st
from click.testing import CliRunner

from retalisc.cli import main
from retalisc.compiler import AqOptions, compile_source
from retalisc.frontend.definite import read_definite_program
from retalisc.passes.aq_normalise import normalise
from retalisc.frontend.terms import to_prolog
from test_aq_join import check as check_against_swi
from test_aq_negation import SETTINGS


def run_aq(tmp_path, program: str, script: str, mode: str = "tabled"):
    (tmp_path / "program.pl").write_text(program)
    (tmp_path / "updates.txt").write_text(script)
    args = ["aq", str(tmp_path / "program.pl"), "--script", str(tmp_path / "updates.txt"), "--mode", mode]
    return CliRunner().invoke(main, args, catch_exceptions=False)


def events(result):
    return [(e["query"], e["op"], e["answer"]) for e in map(json.loads, result.stdout.splitlines())]


def test_xsb_directives_are_accepted_with_a_note(tmp_path):
    program = (":- import member/2, append/3 from basics.\n"
               ":- table p/1 as incremental.\n"
               ":- dynamic e/1 as incremental.\n"
               ":- export p/1.\n"
               "e(1).\np(X) :- e(X).\n")
    result = run_aq(tmp_path, program, "?q p(X).\n+e(2).\n")
    assert result.exit_code == 0, result.stderr
    assert events(result) == [("q", "answer", "p(1)"), ("q", "add", "p(2)")]
    notes = result.stderr.splitlines()
    where = str(tmp_path / "program.pl")
    assert [n.split(": note: ")[0] for n in notes] == [f"{where}:{line}:1" for line in (1, 2, 3, 4)]
    assert "import" in notes[0] and "as incremental" in notes[1] and "as incremental" in notes[2]


@pytest.mark.parametrize("mode", ["tabled", "naive"])
def test_multiline_quoted_atoms_in_scripts(tmp_path, mode):
    program = ":- dynamic note/2.\nnote(1, 'a\nb').\nshown(N, T) :- note(N, T).\n"
    script = "?q shown(N, T).\n+note(2, 'two\n  lines  kept').\n-note(1, 'a\nb').\n+note(3, 'x').\n"
    result = run_aq(tmp_path, program, script, mode)
    assert result.exit_code == 0, result.stderr
    assert events(result) == [("q", "answer", "shown(1,'a\\nb')"), ("q", "add", "shown(2,'two\\n  lines  kept')"),
                              ("q", "delete", "shown(1,'a\\nb')"), ("q", "add", "shown(3,x)")]


def test_unclosed_quoted_atom_names_the_line_it_starts_on(tmp_path):
    result = run_aq(tmp_path, ":- dynamic e/1.\ne(1).\np(X) :- e(X).\n", "?q p(X).\n+e('open\nstill open\n")
    assert result.exit_code == 2
    assert result.stderr.startswith(f"{tmp_path / 'updates.txt'}:2: error: ")


@pytest.mark.parametrize("line,message", [
    ("+(p(X) :- e(X), shell(ls)).", "unknown predicate shell/1"),
    ("+(p(X) :- e(X), call(X)).", "unknown predicate call/1"),
    ("+(p(X) :- e(X), assertz(e(9))).", "unknown predicate assertz/1"),
    ("+(p(X) :- G).", "meta-call"),
    ("+(atom_length(X, Y) :- e(X)).", "cannot define atom_length/2"),
    ("+(p(X) :- e(X), \\+ p(X)).", "negate builtins only"),
    ("-(p(X) :- e(X), X > 1).", "no such rule was added"),
])
def test_rules_from_scripts_are_checked(tmp_path, line, message):
    result = run_aq(tmp_path, ":- dynamic e/1.\ne(1).\np(X) :- e(X).\n", f"?q p(X).\n{line}\n+e(2).\n")
    assert result.exit_code == 2, result.stdout
    assert result.stderr.startswith(f"{tmp_path / 'updates.txt'}:2: error: ") and message in result.stderr, \
        result.stderr
    assert events(result) == [("q", "answer", "p(1)")]      # nothing of the rule ran


def test_rule_added_twice_is_one_rule_and_removal_uses_dred(tmp_path):
    program = ":- dynamic e/2.\ne(1, 2). e(2, 3).\nr(X, Y) :- e(X, Y).\n"
    script = ("?q r(1, Y).\n+(r(X, Y) :- e(X, Z), r(Z, Y)).\n+(r(X, Y) :- e(X, Z), r(Z, Y)).\n"
              "+(r(X, Y) :- r(X, Z), r(Z, Y)).\n-(r(X, Y) :- e(X, Z), r(Z, Y)).\n"
              "-(r(X, Y) :- r(X, Z), r(Z, Y)).\n")
    result = run_aq(tmp_path, program, script)
    assert result.exit_code == 0, result.stderr
    # the second rule derives r(1, 3) too: removing the first keeps it, removing both loses it
    assert events(result) == [("q", "answer", "r(1,2)"), ("q", "add", "r(1,3)"), ("q", "delete", "r(1,3)")]


def test_rule_for_a_new_predicate_can_be_queried(tmp_path):
    program = ":- dynamic e/1.\ne(1). e(5).\np(X) :- e(X).\n"
    result = run_aq(tmp_path, program, "+(big(X) :- p(X), X > 2).\n?b big(X).\n+e(7).\n-(big(X) :- p(X), X > 2).\n")
    assert result.exit_code == 0, result.stderr
    assert events(result) == [("b", "answer", "big(5)"), ("b", "add", "big(7)"),
                              ("b", "delete", "big(5)"), ("b", "delete", "big(7)")]


def normalised(source: str):
    program = normalise(read_definite_program(source, "p.pl"))
    return [f"{to_prolog(r.head)} :- {', '.join(to_prolog(literal.term) for literal in r.body)}" for r in program.rules]


def test_disjunction_and_if_then_else_become_clauses():
    assert normalised("p(X) :- a(X), ( b(X) ; c(X) ), d(X).\n") == [
        "p(X) :- a(X), b(X), d(X)", "p(X) :- a(X), c(X), d(X)"]
    assert normalised("p(X, K) :- a(X), ( X > 1 -> K = big ; K = small ).\n") == [
        "p(X, K) :- a(X), >(X, 1), =(K, big)", "p(X, K) :- a(X), \\+(>(X, 1)), =(K, small)"]
    assert normalised("p(X) :- a(X), not(b(X)), tnot(c(X)).\n") == ["p(X) :- a(X), \\+(b(X)), \\+(c(X))"]
    # a negated conjunction gets a predicate of its own, over the variables it shares
    assert normalised("p(X) :- a(X), \\+ (b(X, Y), c(Y)).\n") == [
        "p(X) :- a(X), \\+('$not_p_1'(X))", "'$not_p_1'(X) :- b(X, Y), c(Y)"]


def test_too_many_alternatives_is_a_located_error():
    body = ", ".join("(a(X) ; b(X))" for _ in range(9))
    source = f"a(1). b(1).\np(X) :- {body}.\n"
    with pytest.raises(Exception) as info:
        compile_source(source, "p.pl", active_queries=AqOptions("tabled"))
    assert "more than 256 alternatives" in str(info.value)


@pytest.mark.parametrize("body,message", [
    ("e(X), !", "cut (!)"),
    ("findall(Y, e(Y), X)", "findall/3"),
    ("e(X), assertz(e(2))", "side effects (assertz)"),
])
def test_non_definite_bodies_are_refused_with_a_location(body, message):
    assert_refused(f"e(1).\np(X) :- {body}.\n", "p.pl:2:", message)


def assert_refused(source: str, where: str, message: str) -> None:
    """The compiler refuses program `p.pl` with an error at `where` (`p.pl:L:C: error: `, as
    `retalisc aq` prints it) that says `message`."""
    with pytest.raises(Exception) as info:
        compile_source(source, "p.pl", active_queries=AqOptions("tabled"))
    text = info.value.render(source)
    assert text.startswith(where) and message in text, text


# ---- directives -----------------------------------------------------------------------------

@pytest.mark.parametrize("directive,message", [
    (":- set_prolog_flag(unknown, fail).", "not a flag for reading the program text"),
    (":- set_prolog_flag(double_quotes, foo).", "read with double_quotes codes or chars or atom or string"),
    (":- ensure_loaded(other_file).", "loads a file of clauses"),
    (":- use_module(mine).", "loads a file of clauses"),
    (":- encoding(iso_latin_1).", "read as UTF-8"),
    (":- initialization(main).", "other directives run code"),
])
def test_directives_that_change_the_program_are_refused_with_the_reason(directive, message):
    assert_refused(f"e(1).\n{directive}\np(X) :- e(X).\n", "p.pl:2:4: error: ", message)


def test_double_quotes_apply_to_the_clauses_after_the_flag():
    source = ('w(1, "ab").\n:- set_prolog_flag(double_quotes, chars).\nw(2, "ab").\n'
              ':- set_prolog_flag(double_quotes, atom).\nw(3, "ab").\n')
    program = read_definite_program(source, "p.pl")
    assert [to_prolog(f.term) for f in program.facts] == ['w(1, "ab")', "w(2, [a, b])", "w(3, ab)"]


# ---- builtins where their arguments are bound -----------------------------------------------

@pytest.mark.parametrize("mode", ["naive", "optimized", "tabled"])
def test_builtins_wait_for_the_literals_that_bind_them(tmp_path, mode):
    program = (":- dynamic e/2.\ne(1, 2). e(2, 2). e(3, 1).\n"
               "ne(X, Y) :- X \\= Y, e(X, Y).\nup(X, Y) :- X < Y, e(X, Y).\n"
               "d(X, D) :- D is Y - X, e(X, Y).\n")
    result = run_aq(tmp_path, program, "?a ne(X, Y).\n?b up(X, Y).\n?c d(X, D).\n+e(0, 5).\n-e(1, 2).\n", mode)
    assert result.exit_code == 0, result.stderr
    assert sorted(events(result)) == sorted([
        ("a", "answer", "ne(1,2)"), ("a", "answer", "ne(3,1)"), ("b", "answer", "up(1,2)"),
        ("c", "answer", "d(1,1)"), ("c", "answer", "d(2,0)"), ("c", "answer", "d(3,-2)"),
        ("a", "add", "ne(0,5)"), ("b", "add", "up(0,5)"), ("c", "add", "d(0,5)"),
        ("a", "delete", "ne(1,2)"), ("b", "delete", "up(1,2)"), ("c", "delete", "d(1,1)")])


@pytest.mark.parametrize("body,column,unbound", [
    ("e(X), X < Y", 15, "Y"),
    ("e(X), ( Z > 1 -> true ; X = 1 )", 17, "Z"),
    ("e(X), W is V + 1, W > X", 15, "V"),
])
def test_a_test_no_order_binds_is_a_located_error(body, column, unbound):
    assert_refused(f"e(1).\np(X) :- {body}.\n", f"p.pl:2:{column}: error: ", f"binds {unbound} before this goal")


def test_a_test_of_head_variables_stays_for_the_call_to_bind():
    """`p(X) :- X > 1, e(Y).`: the call binds X (p(5) holds); no body literal does."""
    source = ":- dynamic e/1.\ne(1).\np(X) :- X > 1, e(Y).\n"
    prolog = compile_source(source, "p.pl", active_queries=AqOptions("tabled")).prolog
    assert "X > 1,\n    aq_wait_fact(e(Y)" in prolog


# ---- rules for a predicate with stored facts only (a mixed predicate) --------------------------

def test_a_rule_for_a_predicate_with_stored_facts_only_makes_it_mixed(tmp_path):
    """The issue's case: XSB's incremental tabling makes the dynamic predicate a mixed one."""
    program = ":- dynamic p/1, f/2.\np(1).\nf(1, 5). f(2, 7).\nbig(X) :- p(X), X > 2.\n"
    script = "?a big(X).\n?b p(X).\n+(p(X) :- f(1, X)).\n+p(5).\n+f(1, 9).\n-(p(X) :- f(1, X)).\n"
    for mode in ("tabled", "optimized", "naive"):
        result = run_aq(tmp_path, program, script, mode)
        assert result.exit_code == 0, result.stderr
        # p(5) is stored as a fact too: it stays when the rule goes
        assert events(result) == [("b", "answer", "p(1)"), ("a", "add", "big(5)"), ("b", "add", "p(5)"),
                                  ("a", "add", "big(9)"), ("b", "add", "p(9)"),
                                  ("a", "delete", "big(9)"), ("b", "delete", "p(9)")], mode


CONSTS = ["0", "1", "2"]
FACTS = st.one_of(st.tuples(st.sampled_from(CONSTS), st.sampled_from(CONSTS)).map(lambda t: f"e({t[0]}, {t[1]})"),
                  st.sampled_from(CONSTS).map(lambda c: f"f({c})"))
#: Rules a script adds for the stored predicates; the recursive ones (also through each other)
#: not in the optimized mode, which does not terminate on recursion.
MIXED_RULES = ["(f(X) :- e(0, X))", "(f(Y) :- e(X, Y), X < Y)"]
RECURSIVE_RULES = ["(e(X, Y) :- f(X), f(Y), X \\= Y)", "(f(Y) :- e(X, Y), f(X))", "(e(X, Z) :- e(X, Y), e(Y, Z))"]
PROGRAM_RULES = ["q(X) :- f(X), e(X, Y), Y > 0.", "r(X, Y) :- e(X, Y), f(Y).", "s(X) :- X \\== 1, f(X).",
                 "t(X) :- e(X, _), \\+ f(X)."]


@st.composite
def mixed_case(draw, recursive):
    facts = draw(st.lists(FACTS, max_size=6, unique=True))
    pool = MIXED_RULES + (RECURSIVE_RULES if recursive else [])
    added, steps = [], []
    for _ in range(draw(st.integers(2, 8))):
        kind = draw(st.sampled_from(["add_rule", "remove_rule", "fact", "fact"]))
        if kind == "remove_rule" and added:
            rule = draw(st.sampled_from(added))
            added.remove(rule)
            steps.append(("-", rule))
        elif kind == "add_rule" and len(added) < len(pool):
            # a rule added again is the same rule (nothing happens): the oracle would have two
            rule = draw(st.sampled_from([r for r in pool if r not in added]))
            added.append(rule)
            steps.append(("+", rule))
        else:
            steps.append((draw(st.sampled_from("+-")), draw(FACTS)))
    goals = draw(st.lists(st.sampled_from(["q(X)", "r(X, Y)", "s(X)", "t(X)", "f(X)", "e(X, Y)", "e(0, X)"]),
                          min_size=1, max_size=3, unique=True))
    source = ":- dynamic e/2, f/1.\n" + "\n".join(PROGRAM_RULES + [f + "." for f in facts]) + "\n"
    return source, goals, steps


@SETTINGS
@given(mixed_case(recursive=True), st.sampled_from([("tabled", False), ("tabled", True), ("naive", False)]))
def test_rules_for_stored_predicates_match_swi_tabling(case, variant):
    check_against_swi(*case, *variant)


@SETTINGS
@given(mixed_case(recursive=False))
def test_rules_for_stored_predicates_match_swi_tabling_optimized(case):
    check_against_swi(*case, "optimized")
