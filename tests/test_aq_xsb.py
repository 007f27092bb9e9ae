"""XSB compatibility of `retalisc aq` beyond the golden cases (tests/golden_aq/xsb_*): the notes
for ignored XSB directives, multi-line quoted atoms in update scripts, the checks on rules
added at run time, and the normalisation of disjunction and if-then-else."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from retalisc.cli import main
from retalisc.compiler import AqOptions, compile_source
from retalisc.frontend.definite import read_definite_program
from retalisc.passes.aq_normalise import normalise
from retalisc.frontend.terms import to_prolog


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
    ("+(e(X) :- p(X)).", "e/1 has stored facts only"),
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
    source = f"e(1).\np(X) :- {body}.\n"
    with pytest.raises(Exception) as info:
        compile_source(source, "p.pl", active_queries=AqOptions("tabled"))
    text = info.value.render(source)
    assert text.startswith("p.pl:2:") and message in text, text
