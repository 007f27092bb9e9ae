"""The `lint` pass: warnings for programs that compile but cannot mean what they say, their
place and hint, `--werror`, and no warnings on the shipped examples."""
from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from retalisc.cli import main
from retalisc.compiler import compile_file, compile_source

ROOT = Path(__file__).resolve().parent.parent


def lint(text: str):
    return compile_source(text, "robot.rtl").unit.lint


def codes(text: str):
    return [w.code for w in lint(text)]


def test_window_after_the_last_operand_is_reported_at_the_operand():
    [warning] = lint("alarm(X) <- smoke(X) seq heat(X).10.\n")
    assert warning.code == "window-on-last-operand"
    assert (warning.span.line, warning.span.column) == (1, 26)
    assert "heat(X) only" in warning.message
    assert "(smoke(X) seq heat(X)).10" in warning.hint


@pytest.mark.parametrize("text", [
    "alarm(X) <- (smoke(X) seq heat(X)).10.\n",       # the whole sequence
    "alarm(X) <- smoke(X) seq (heat(X)).10.\n",       # explicitly this event alone
    "alarm(X) <- smoke(X) seq\n    (heat(X)).10.\n",
])
def test_window_written_with_brackets_is_not_reported(text):
    assert codes(text) == []


@pytest.mark.parametrize("operator, advice", [(",", "'and'"), (";", "'or'"), ("->", "where")])
def test_prolog_control_inside_a_pattern(operator, advice):
    [warning] = lint(f"both(X) <- (a(X) {operator} b(X)) seq c(X).\n")
    assert warning.code == "prolog-control-in-pattern"
    assert f"event named '{operator}'" in warning.message
    assert advice in warning.hint


def test_event_operator_under_prolog_arrow():
    [warning] = lint("alarm(X) :- smoke(X) seq heat(X).\n")
    assert warning.code == "event-operator-in-clause"
    assert warning.hint.endswith("alarm(X) <- smoke(X) seq heat(X).")


def test_program_without_event_rules_that_uses_operators():
    [warning] = lint("pattern(alarm(X), (smoke(X) seq heat(X))).\n")
    assert warning.code == "no-event-rules"
    assert "0 event rules" in warning.message


def test_a_program_defining_the_operator_name_is_not_reported():
    assert codes("seq(A, B) :- A, B.\nok :- seq(true, true).\nr(X) <- a(X) seq b(X).\n") == []


@pytest.mark.parametrize("text, reason", [
    ("r(X) <- a(X) or b(Y).\n", "one branch of 'or'"),
    ("r(Y, N) <- (a(X) seq aggregate(count, b(X, Y), N)).5.\n", "inside an aggregate"),
    ("r(X, N) <- not(n(N)).[a(X), b(X)].\n", "negated pattern"),
    ("r(X, N) <- a(X) fnot n(N).\n", "negated pattern"),
])
def test_head_variable_bound_in_part_of_the_pattern(text, reason):
    [warning] = lint(text)
    assert warning.code == "head-variable-unbound"
    assert reason in warning.message


def test_head_variable_bound_in_both_branches_is_fine():
    assert codes("r(X) <- a(X) or b(X).\ns(X, N) <- (a(X) seq aggregate(count, b(X), N)).5.\n") == []


def test_undefined_predicate_in_a_condition_and_an_action():
    found = lint("w(X) <- a(X) where (X > 1, undefined_thing(X)).\nnull do nothing_here(X) <- b(X).\n")
    assert [w.code for w in found] == ["undefined-predicate", "undefined-predicate"]
    assert "undefined_thing/1" in found[0].message and "condition" in found[0].message
    assert "nothing_here/1" in found[1].message and "action" in found[1].message


def test_defined_builtin_library_and_dynamic_predicates_are_known():
    text = (":- dynamic seen/1.\nnear(a, b).\n"
            "w(X, Y) <- (a(X) seq b(Y) where (near(X, Y), seen(X), atom_length(X, _), min(1, 2, _),"
            " findall(Z, near(Z, _), _))).3.\n"
            "c(X) <- a(X) check (t1(T), T > 0).\n")
    assert codes(text) == []


def test_undefined_predicate_is_not_reported_when_the_program_loads_code():
    assert codes(":- use_module(library(lists)).\nw(X) <- a(X) where mine(X).\n") == []


def test_keyless_join_without_a_window():
    [warning] = lint("j(X, Y) <- a(X) and b(Y).\n")
    assert warning.code == "keyless-join"
    assert "share no variable" in warning.message


@pytest.mark.parametrize("text", [
    "j(X, Y) <- (a(X) and b(Y)).10.\n",                       # bounded by a window
    "j(X, Y) <- a(X) and b(Y) where X < Y.\n",                 # related by a condition
    "j(X) <- a(X) and b(X).\n",                                # a key
    "j <- a and b.\n",                                         # nothing to key on
    ":- set_etalis_flag(event_consumption_policy, recent).\nj(X, Y) <- a(X) and b(Y).\n",
    "r1([property(event_rule_window, 4)]) 'rule:' j(X, Y) <- a(X) seq b(Y).\n",
])
def test_keyless_join_not_reported(text):
    assert codes(text) == []


def test_shipped_examples_give_no_warnings():
    for program in sorted((ROOT / "examples").glob("*/*.rtl")):
        assert compile_file(str(program)).warnings == [], program


# The golden programs test operators on purpose with all-pairs joins and no window; those
# findings are true (their cost grows with the run) and are the only ones.
GOLDEN_KEYLESS = {"aggregates": 4, "and_or_hierarchy": 2, "etalis_housekeeping": 1, "figure_3_1": 7, "listing_3_1": 1}


# Two golden programs test ETALIS's new_event/1 in actions on purpose (stamped with the clock).
GOLDEN_AT_THE_CLOCK = {"etalis_actions_after_pattern", "subscriptions_and_new_event"}


def test_golden_programs_give_only_their_true_warnings():
    for program in sorted((ROOT / "tests" / "golden").glob("*/program.rtl")):
        found = compile_file(str(program)).unit.lint
        name = program.parent.name
        expected = ["keyless-join"] * GOLDEN_KEYLESS.get(name, 0) + \
            (["new-event-at-the-clock"] if name in GOLDEN_AT_THE_CLOCK else [])
        assert sorted(w.code for w in found) == sorted(expected), program


def test_new_event_1_in_an_action_is_reported_also_through_a_predicate():
    text = ("null do new_event(raised(R)) <- odom(R).\n"
            "null do relay(R) <- odom2(R).\n"
            "relay(R) :- new_event(r(R)).\n"
            "null do new_event(ok(R), T) <- odom3(R)^T.\n"
            "null do new_event(ok(R), S, NS) <- odom4(R, [S, NS]).\n")
    found = lint(text)
    assert [(w.code, w.span.line) for w in found] == [("new-event-at-the-clock", 1), ("new-event-at-the-clock", 3)]
    assert "raised(R)" in found[0].message and "new_event(Event, T)" in found[0].hint


@pytest.mark.parametrize("condition, warned", [
    ("(V > 0.1 ; W > 0.1)", True),                     # both can hold: two moving(R) per message
    ("(V > 0.1 -> true ; W > 0.1)", False),            # if-then-else: at most once
    ("member(K, [a, b])", True),                       # K is not in the head
    ("member(V, [1, 2])", False),                      # V is bound by the pattern: a test
    ("once(member(K, [a, b]))", False),
    ("speed(V, K)", True),                             # two clauses for this call
    ("kind(fast, K)", False),                          # one clause for this call
])
def test_a_condition_with_several_solutions_that_give_the_same_head(condition, warned):
    text = (f"moving(R) <- odom(R, V, W) where {condition}.\n"
            "speed(V, fast) :- V > 1.\nspeed(V, slow) :- V =< 1.\nkind(fast, 1).\nkind(slow, 2).\n")
    assert ("one-event-per-solution" in codes(text)) == warned


def test_a_condition_binding_a_head_variable_is_not_reported():
    assert codes("pair(R, K) <- odom(R, _) where member(K, [a, b]).\n") == []


def test_check_prints_warning_with_place_line_and_hint(tmp_path):
    program = tmp_path / "robot.rtl"
    program.write_text("alarm(X) <- smoke(X) seq heat(X).10.\n")
    result = CliRunner().invoke(main, ["check", str(program)])
    assert result.exit_code == 0
    lines = result.stderr.splitlines() if hasattr(result, "stderr") else result.output.splitlines()
    assert lines[0].startswith(f"{program}:1:26: warning: the window .10 applies to heat(X) only")
    assert lines[1] == "    alarm(X) <- smoke(X) seq heat(X).10."
    assert lines[2] == "    " + " " * 25 + "^"
    assert lines[3].startswith("    hint: write (smoke(X) seq heat(X)).10")
    assert lines[-1] == f"{program}: ok (1 event rule, 1 warning)"


@pytest.mark.parametrize("command", ["check", "compile"])
def test_werror_makes_warnings_errors(tmp_path, command):
    program = tmp_path / "robot.rtl"
    program.write_text("r(X) <- a(X) or b(Y).\n")
    out = tmp_path / "out.pl"
    args = [command, str(program), "--werror"] + (["-o", str(out)] if command == "compile" else [])
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2
    assert f"{program}:1:3: error: variable X of the rule head" in result.output
    assert "1 warning treated as error (--werror)" in result.output
    if command == "compile":
        assert not out.exists() or out.read_text() == ""
    clean = tmp_path / "clean.rtl"
    clean.write_text("r(X) <- a(X) or b(X).\n")
    assert CliRunner().invoke(main, [command, str(clean), "--werror"]).exit_code == 0


def test_variable_met_first_inside_a_negation_and_used_after_it():
    [warning] = lint("p(0, 0) :- \\+ f(Y), e(Y, Y).\n")
    assert warning.code == "variable-bound-after-negation"
    assert (warning.span.line, warning.span.column) == (1, 17)
    assert "variable Y is met first inside \\+ f(Y)" in warning.message
    assert "before the negation" in warning.hint


@pytest.mark.parametrize("text", [
    "p(X) :- e(X, Y), \\+ f(Y).\n",                # bound before the negation
    "p(Y) :- \\+ f(Y), e(Y, Y).\n",                # a head variable: the caller may bind it
    "p :- \\+ f(Y), e(1, 2).\n",                   # not used after it
    "p :- \\+ f(_Y), e(_Y, 1).\n",                 # marked as don't-care
    "p :- \\+ f(Y), \\+ g(Y).\n",                  # used after it only in another negation
])
def test_negations_that_bind_nothing_later_used_are_not_reported(text):
    assert "variable-bound-after-negation" not in codes(text)


def test_variable_met_first_inside_a_negation_in_a_condition():
    [warning] = lint(":- dynamic f/1, g/1.\nalarm(X) <- smoke(X) where (\\+ f(Z), g(Z)).\n")
    assert warning.code == "variable-bound-after-negation"
    assert warning.span.line == 2


# ---- string-mode -------------------------------------------------------------------------------

@pytest.mark.parametrize("text, found", [
    ("b(X) <- a('\"odom\"', X).", ["string-mode"]),                      # the release's atom, plain program
    ("memorize(tf('\"/odom\"', C, V, Q), [], tf(V, Q), m, 10).", ["string-mode"]),
    ("b(X) <- a(odom, X).", []),
    (":- ros_strings(quoted).\nb(X) <- a('\"odom\"', X).", []),
    (":- ros_strings(quoted).\nb(X) <- p(std_msgs__0__Header(_, _, odom), X).", ["string-mode"]),
    (":- ros_strings(quoted).\nb(X) <- p(std_msgs__0__Header(_, '\"odom\"'), X).", []),
    (":- ros_strings(quoted).\nb(X) <- t(geometry_msgs__0__TransformStamped(_, base, X)).", ["string-mode"]),
    (":- ros_strings(quoted).\nb(X) <- a(odom, X).", []),       # not a frame id: cannot tell
])
def test_a_string_of_the_other_mode_is_reported(text, found):
    assert [c for c in codes(text) if c == "string-mode"] == found


def test_the_string_mode_warning_says_what_to_write():
    (warning,) = lint("b(X) <- a('\"odom\"', X).")
    assert "is ever" in warning.message and "write odom" in warning.hint and "ros_strings(quoted)" in warning.hint
    assert (warning.span.line, warning.span.column) == (1, 11)


def test_ros_strings_takes_plain_or_quoted():
    from retalisc.frontend.errors import RetalisSemanticError
    with pytest.raises(RetalisSemanticError, match="ros_strings takes one of plain, quoted"):
        compile_source(":- ros_strings(yes).\nb <- a.\n", "p.rtl")
