"""Programs written for ETALIS and for Retalis 2015 (docs/compatibility.md): the
forms that are not covered by a golden case (tests/golden/etalis_*, retalis_2015_*)."""
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retalisc.compiler import compile_file, compile_source
from retalisc.driver.engine import Engine
from retalisc.frontend.errors import RetalisError, RetalisSyntaxError
from retalisc.frontend.parser import read_program
from retalisc.frontend.program import complete_paragraphs, parse_program, read_goal_lines
from retalisc.frontend.terms import to_prolog

ROOT = Path(__file__).resolve().parent.parent


def retalisc(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "retalisc", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=120)


# ---- Retalis 2015: goal lines without a final period -------------------------------------

def test_goal_lines_without_period_one_per_paragraph():
    text = ("memorize(seen(O), [], seen(O), m1, 5)\n\n"
            "subscribe(\n  seen(_), [],\n  _, % template\n  topic, s1)   % a comment 'with' quotes\n\n"
            "% a comment paragraph\n\n"
            "a(1). b(2).\n")
    program = parse_program(text, "goalPredicates.txt")
    goals = [c.goal.name for c in program.declarations]
    assert goals == ["memorize", "subscribe"]
    assert [c.span.line for c in program.clauses] == [1, 3, 10, 10]


def test_completing_paragraphs_keeps_lines_and_columns():
    text = "a(1)\n\nb(2).\n\nc('%', \"x\")  % done\n"
    assert complete_paragraphs(text) == "a(1) .\n\nb(2).\n\nc('%', \"x\") .  % done\n"


def test_a_real_syntax_error_is_reported_where_it_is():
    """Adding periods is tried only when the text cannot be read; when that fails too, the
    error of the text as written stands."""
    text = "a(1).\n\nh(X) :- b(X\n\nc(2).\n"
    with pytest.raises(RetalisSyntaxError) as info:
        parse_program(text, "bad.rtl")
    assert (info.value.span.line, info.value.span.column) == (5, 5)


def test_compile_event_file_relative_to_the_program(tmp_path):
    (tmp_path / "rules").mkdir()
    (tmp_path / "rules" / "eventRules.txt").write_text("c(X) <- a(X) seq b(X).\n")
    (tmp_path / "goals.txt").write_text("compile_event_file('rules/eventRules.txt')\n\nprint_trigger(c/1)\n")
    result = compile_file(str(tmp_path / "goals.txt"))
    assert [r.span.file for r in result.unit.program.event_rules] == [str(tmp_path / "rules" / "eventRules.txt")]
    engine = Engine.from_compiled(result)
    assert [o.line for o in engine.feed_batch([("a(1)", 1), ("b(1)", 2)])] == \
        ['{"event": "c(1)", "start": 1, "end": 2}']


def test_compile_event_file_missing_is_a_located_error(tmp_path):
    program = tmp_path / "goals.txt"
    program.write_text("set_etalis_flag(event_consumption_policy, recent)\n\n:- compile_event_file(nowhere).\n")
    run = retalisc("compile", program)
    assert run.returncode == 2
    assert run.stderr.startswith(f"{program}:3:1: syntax error: compile_event_file: cannot read nowhere")
    assert ":- compile_event_file(nowhere)." in run.stderr and "Traceback" not in run.stderr


def test_compile_event_file_errors_point_into_the_included_file(tmp_path):
    (tmp_path / "eventRules.txt").write_text("ok(X) <- a(X).\nh(X) <- a(X) SEQ b(X).\n")
    program = tmp_path / "goals.txt"
    program.write_text("compile_event_file('eventRules.txt')\n")
    run = retalisc("compile", program)
    assert run.returncode == 2
    assert run.stderr.startswith(f"{tmp_path / 'eventRules.txt'}:2:14: syntax error:")
    assert "h(X) <- a(X) SEQ b(X)." in run.stderr


def test_compile_event_file_that_includes_itself(tmp_path):
    (tmp_path / "a.txt").write_text("compile_event_file('a.txt')\n")
    with pytest.raises(RetalisSyntaxError, match="includes itself"):
        compile_file(str(tmp_path / "a.txt"))


RELEASE_PATH = "/home/nao/catkin_ws/src/retalis/application_source/eventRules.txt"


def test_the_2015_absolute_path_falls_back_to_the_file_beside_the_goal_file(tmp_path):
    """The NAO goal file as the release published it: its rules by an absolute path on the
    author's machine. The eventRules.txt beside it is read, with a warning naming both."""
    nao = ROOT / "examples" / "nao"
    (tmp_path / "eventRules.txt").write_text((nao / "eventRules.txt").read_text())
    goals = (nao / "goalPredicates.txt").read_text()
    assert goals.startswith("compile_event_file('eventRules.txt')\n")
    program = tmp_path / "goalPredicates.txt"
    program.write_text(goals.replace("'eventRules.txt'", f"'{RELEASE_PATH}'", 1))
    published, edited = compile_file(str(program)), compile_file(str(nao / "goalPredicates.txt"))
    assert [r.source for r in published.unit.program.event_rules] == [r.source for r in edited.unit.program.event_rules]
    assert {r.span.file for r in published.unit.program.event_rules} == {str(tmp_path / "eventRules.txt")}
    assert published.warnings[0] == (f"{program}:1:1: warning: compile_event_file: {RELEASE_PATH} does not exist; "
                                     f"reading {tmp_path / 'eventRules.txt'}, the file of that name beside {program}")
    run = retalisc("check", program)
    assert run.returncode == 0 and f"{RELEASE_PATH} does not exist" in run.stderr


def test_an_absolute_path_that_exists_is_read_and_one_missing_everywhere_is_an_error(tmp_path):
    (tmp_path / "rules").mkdir()
    (tmp_path / "rules" / "eventRules.txt").write_text("c(X) <- a(X).\n")
    (tmp_path / "eventRules.txt").write_text("d(X) <- a(X).\n")
    program = tmp_path / "goals.txt"
    program.write_text(f"compile_event_file('{tmp_path / 'rules' / 'eventRules.txt'}')\n")
    result = compile_file(str(program))
    assert [r.head.name for r in result.unit.program.event_rules] == ["c"] and result.warnings == []
    program.write_text(f"compile_event_file('{RELEASE_PATH[:-4]}_other.txt')\n")
    with pytest.raises(RetalisSyntaxError, match="cannot read /home/nao/"):
        compile_file(str(program))


# ---- directives that call the runtime ------------------------------------------------------

DIRECTIVES = """c(X) <- a(X) seq b(X).
:- subscribe(c(X), [X > 1], _, big, s1), sub(s2, all, c(Y)-[], got(Y), now).
:- initialization(subscribe(c(_), [], _, late, s3)).
"""


def test_runtime_directives_run_after_the_load_in_program_order_with_the_driver():
    engine = Engine.from_source(DIRECTIVES, "d.rtl")
    lines = [o.line for o in engine.feed_batch([("a(1)", 1), ("b(1)", 2), ("a(2)", 3), ("b(2)", 4)])]
    assert lines == ['{"event": "c(1)", "start": 1, "end": 2}',
                     '{"event": "got(1)", "start": 1, "end": 2, "consumer": "all"}',
                     '{"event": "c(1)", "start": 1, "end": 2, "consumer": "late"}',
                     '{"event": "c(2)", "start": 3, "end": 4}',
                     '{"event": "c(2)", "start": 3, "end": 4, "consumer": "big"}',
                     '{"event": "got(2)", "start": 3, "end": 4, "consumer": "all"}',
                     '{"event": "c(2)", "start": 3, "end": 4, "consumer": "late"}']


def test_a_failing_runtime_directive_is_reported_with_its_line(tmp_path, swipl):
    source = "c(X) <- a(X).\n:- true,\n   sub(s1, out, c(_)-[], x, never).\n"
    program = tmp_path / "p.pl"
    program.write_text(compile_source(source, "p.rtl").prolog)
    run = subprocess.run([swipl, str(program), "-"], input='{"event": "a(1)", "t": 1}\n', capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 0
    assert "p.rtl:2: directive raised:" in run.stderr
    assert run.stdout == '{"event": "c(1)", "start": 1, "end": 1}\n'


# ---- ETALIS operators: timestamp, event_multiply, star_times, subpatterns ------------------

def _lines(source, events):
    engine = Engine.from_source(source, "ops.rtl")
    return [(o.event, o.start, o.end) for o in engine.feed_batch(events)]


def test_capitalised_timestamp_and_event_multiply():
    source = ("p(1, x). p(1, y).\n"
              "m(X, Y) <- a(X) 'EVENT_MULTIPLY' p(X, Y).\n"
              "t(X, S) <- (a(X) seq b(X)) 'TIMESTAMP' t1(S).\n")
    assert _lines(source, [("a(1)", 1), ("b(1)", 3)]) == [("m(1,x)", 1, 1), ("m(1,y)", 1, 1), ("t(1,1)", 1, 3)]


def test_star_times_under_recent_keeps_one_start():
    """Under `recent` a new start replaces the waiting one, as for any sequence."""
    source = ":- set_etalis_flag(event_consumption_policy, recent).\ntrail(X) <- start(X) seq b(X) star_times.\n"
    assert _lines(source, [("start(1)", 1), ("b(1)", 2), ("b(1)", 3)]) == [
        ("trail(1)", 1, 1), ("trail(1)", 1, 2), ("trail(1)", 1, 3)]


@pytest.mark.parametrize("source, words", [
    ("h(Y) <- start(X) seq b(X, Y) star_times.\n", "occurs only in the pattern repeated by star_times"),
    ("h(X) <- b(X) star_times.\n", "star_times repeats a pattern after a start event"),
])
def test_star_times_errors(source, words):
    with pytest.raises(RetalisError, match=words):
        compile_source(source, "bad.rtl")


def test_nested_subpatterns_become_rules_of_their_own():
    source = "f(Z) <- c(Z) seq (outer(X) <- (inner(X) <- b0(X) seq b1(X)) seq b2(X)).\n"
    program = parse_program(source, "sub.rtl")
    assert [(r.head.name, r.span.line) for r in program.event_rules] == [("inner", 1), ("outer", 1), ("f", 1)]
    assert _lines(source, [("c(1)", 1), ("b0(2)", 2), ("b1(2)", 3), ("b2(2)", 4)]) == [
        ("inner(2)", 2, 3), ("outer(2)", 2, 4), ("f(1)", 1, 4)]


# ---- runtime rule goals in actions ------------------------------------------------------

def test_a_rule_term_inserted_by_an_action_is_checked_like_added_rules(tmp_path, swipl):
    """`ins_event_rule(Head <- Pattern)` with a goal that came with an event: the rule goes
    through the sandbox of rules added at run time; a rule term without a label cannot be
    deleted (rules are found by label)."""
    marker = tmp_path / "hacked"
    program = tmp_path / "p.pl"
    program.write_text(compile_source("null do ins_event_rule(h <- a where G) <- install(G).\n"
                                      "null do del_event_rule(h <- a) <- stop.\n", "p.rtl").prolog)
    events = f'{{"event": "install(shell(\'touch {marker}\'))", "t": 1}}\n{{"event": "a", "t": 2}}\n' \
             '{"event": "stop", "t": 3}\n'
    run = subprocess.run([swipl, str(program), "-"], input=events, capture_output=True, text=True, timeout=60)
    assert "unsafe goal: shell/1" in run.stderr
    assert "rules are deleted by label" in run.stderr
    assert not marker.exists() and run.stdout == ""


def test_del_event_rule_takes_the_label_of_a_rule_term():
    source = ("r1 'rule:' e(X) <- c(X).\n"
              "null do del_event_rule(r1 'rule:' e(X) <- c(X)) <- stop.\n"
              "null do del_event_rule(f(X) <- c(X)) <- stop2.\n")
    engine = Engine.from_source(source, "p.rtl")
    assert [o.event for o in engine.feed_batch([("c(1)", 1), ("stop", 2), ("c(2)", 3)])] == ["e(1)"]
    assert engine.feed_batch([("stop2", 4)]) == []


# ---- ETALIS housekeeping: print_trigger, flags, facts ----------------------------------------

def test_etalis_flags_warn_only_where_meaningless():
    source = (":- set_etalis_flag(subPatterns, on).\n:- set_etalis_flag(revision_flag, on).\n"
              ":- set_etalis_flag(out_of_order, off).\nset_etalis_flag(store_fired_events, on).\nh <- a.\n")
    warnings = compile_source(source, "f.rtl").warnings
    assert len(warnings) == 2
    assert warnings[0].startswith("f.rtl:3:1: warning: ETALIS flag out_of_order is ignored: events out of order")
    assert warnings[1].startswith("f.rtl:4:1: warning: ETALIS flag store_fired_events has no meaning")


@pytest.mark.parametrize("declarations, printed", [
    ("print_trigger(_).\nprint_trigger(h/1).\n", ["h(1)", "g", "k(1,2)"]),
    ("print_trigger(all_defined_events).\n", ["h(1)", "g", "k(1,2)"]),
    ("print_trigger(_/_).\n", ["h(1)", "g", "k(1,2)"]),
    ("print_trigger(_/2).\n", ["k(1,2)"]),
    ("external_trigger(h/_).\n", ["h(1)"]),
    ("print_trigger(k(_, 2)).\nprint_trigger(g/0).\n", ["g", "k(1,2)"]),
])
def test_print_trigger_forms(declarations, printed):
    source = declarations + "h(X) <- a(X).\ng <- a(_).\nk(X, Y) <- a(X) seq b(Y).\n"
    engine = Engine.from_source(source, "p.rtl")
    assert [o.event for o in engine.feed_batch([("a(1)", 1), ("b(2)", 2)])] == printed


def test_print_trigger_with_a_bad_indicator_is_a_located_error():
    with pytest.raises(RetalisError, match="print_trigger takes Name/Arity") as info:
        compile_source("h <- a.\nprint_trigger(h/x).\n", "p.rtl")
    assert info.value.span.line == 2


def test_capitalised_operators_in_functional_notation():
    assert _lines("h(X) <- 'SEQ'(a(X), 'AND'(b(X), c(X))).\n", [("a(1)", 1), ("c(1)", 2), ("b(1)", 3)]) == [
        ("h(1)", 1, 3)]


def test_blank_lines_inside_quotes_and_block_comments_do_not_end_a_paragraph():
    text = "a(1)\n\n/* a comment\n\nover two paragraphs */\nb(2)\n\n\nc('%', \"x\n\ny\", 0'a)\n"
    assert complete_paragraphs(text) == \
        "a(1) .\n\n/* a comment\n\nover two paragraphs */\nb(2) .\n\n\nc('%', \"x\n\ny\", 0'a) .\n"


_ATOMS = st.sampled_from(["a", "b1", "'x y'", "'%'", "\"s\"", "[]", "0'a", "1.5", "X", "_"])


@st.composite
def _goal(draw, depth=2):
    name = draw(st.sampled_from(["memorize", "subscribe", "set_etalis_flag", "p", "q"]))
    args = [draw(_goal(depth - 1)) if depth and draw(st.booleans()) else draw(_ATOMS)
            for _ in range(draw(st.integers(1, 3)))]
    layout = draw(st.sampled_from([", ", ",\n  ", " ,"]))
    return f"{name}({layout.join(args)})"


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(_goal(), st.sampled_from(["", "  % note", " /* n */"])), min_size=1, max_size=5),
       st.sampled_from(["\n\n", "\n\n\n", "\n \n"]))
def test_goal_lines_read_as_the_same_goals_with_periods(goals, gap):
    """Oracle: the goal lines without periods read as the same clauses as with them."""
    with_periods = gap.join(f"{g}.{c}" for g, c in goals) + "\n"
    without = gap.join(f"{g}{c}" for g, c in goals) + "\n"
    expected = [to_prolog(c.term) for c in read_program(with_periods, "g.txt")]
    assert [to_prolog(c.term) for c in read_goal_lines(without, "g.txt")] == expected
    assert [to_prolog(c.term) for c in read_goal_lines(with_periods, "g.txt")] == expected


def test_directives_after_one_that_calls_the_runtime_keep_their_order(tmp_path, swipl):
    """A directive that reaches the runtime through the program's own predicates waits for
    it too; the directives after it wait as well (program order), except what the load
    needs (`dynamic`)."""
    source = ("c(X) <- a(X).\nsetup(T) :- subscribe(c(_), [], _, T, T).\n"
              ":- writeln(first).\n:- setup(out).\n:- dynamic seen/1.\n:- writeln(third).\n"
              ":- assertz(seen(1)), writeln(fourth).\n")
    program = tmp_path / "p.pl"
    program.write_text(compile_source(source, "p.rtl").prolog)
    assert ":- dynamic seen / 1." in program.read_text()
    run = subprocess.run([swipl, str(program), "-"], input='{"event": "a(1)", "t": 1}\n', capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ["first", "third", "fourth", '{"event": "c(1)", "start": 1, "end": 1}',
                                       '{"event": "c(1)", "start": 1, "end": 1, "consumer": "out"}']


# ---- ETALIS actions after the pattern -------------------------------------------------------

@pytest.mark.parametrize("after, on_head", [
    ("d(X) <- a(X) seq b(X) do new_event(e(X)).\n", "d(X) do new_event(e(X)) <- a(X) seq b(X).\n"),
    ("l 'rule:' d(X) <- a(X) where X > 1 'do' (f(X), g).\n", "l 'rule:' d(X) do (f(X), g) <- a(X) where X > 1.\n"),
    ("l : d(X) <- (a(X) seq b(X) timestamp t1(T)) 'DO' f(T).\n", "l : d(X) do f(T) <- (a(X) seq b(X) timestamp t1(T)).\n"),
])
def test_an_action_after_the_pattern_is_the_action_on_the_head(after, on_head):
    """ETALIS's parser gives `Head <- P do A` and `Head do A <- P` one meaning: so does retalisc."""
    statics = ":- dynamic f/1, g/0.\nf(_).\ng.\n"
    compiled = compile_source(statics + after, "x.rtl").prolog.replace(after.strip(), on_head.strip())
    assert compiled == compile_source(statics + on_head, "x.rtl").prolog


@pytest.mark.parametrize("source, column, words", [
    ("h(X) do f <- a(X) do g.\n", 14, "a rule has one action"),
    ("h(X) <- a(X) seq (b(X) do g).\n", 19, "'do' cannot stand inside a pattern"),
    ("h <- a and prolog(true).\n", 12, "prolog\\(Goal\\) is a step of a sequence"),
    ("h <- prolog(true) seq prolog(true).\n", 6, "prolog\\(Goal\\) needs an event pattern beside it"),
])
def test_misplaced_actions_and_prolog_steps_are_located_errors(source, column, words):
    with pytest.raises(RetalisSyntaxError, match=words) as info:
        compile_source(source, "bad.rtl")
    assert (info.value.span.line, info.value.span.column) == (1, column)


# ---- ETALIS's prolog(Goal) steps and library predicates -------------------------------------

def test_prolog_steps_of_a_sequence_are_conditions():
    """ETALIS's `P seq prolog(G)` and `prolog(G) seq P` call G when P is detected: `P where G`."""
    source = ("low(M) <- a(X) seq b(Y) 'seq' prolog(min(X, Y, M)).\n"
              "high(M) <- prolog(max(X, Y, M)) seq (a(X) seq b(Y)).\n")
    assert _lines(source, [("a(3)", 1), ("b(2)", 2)]) == [("low(2)", 1, 2), ("high(3)", 1, 2)]


def test_an_undefined_predicate_in_a_prolog_step_is_a_warning_and_a_reported_error(tmp_path):
    """It failed silently before: `prolog(...)` was read as an event that never occurs."""
    program = tmp_path / "p.event"
    program.write_text("g(Y) <- a(X) seq prolog(no_such(X, Y)).\nok(X) <- b(X).\n")
    assert any("this condition calls no_such/2" in w for w in compile_source(program.read_text(), str(program)).warnings)
    events = tmp_path / "events.jsonl"
    events.write_text('{"event": "a(1)", "t": 1}\n{"event": "a(2)", "t": 2}\n{"event": "b(3)", "t": 3}\n')
    run = retalisc("run", program, "--events", events)
    assert f"{events}:1: error: " in run.stderr and "no_such/2" in run.stderr
    assert f"{events}:2: error: " in run.stderr
    assert run.stdout.splitlines() == ['{"event": "ok(3)", "start": 3, "end": 3}'] and "2 failed" in run.stderr


def test_etalis_library_predicates_are_callable_from_rules_added_at_run_time():
    """Added rules are untrusted (the sandbox checks what they call): the library is allowed."""
    engine = Engine.from_source("start <- go.\n", "lib.rtl")
    engine.add_rules("late(D) <- seen(T) where (less_datime(T, datime(2020,1,2,0,0,0)), "
                     "datime_plus_sec(T, 60, D), is_datime(D), equal_datime(D, D), "
                     "between_datime(T, datime(2019,1,1,0,0,0), D), datime_minus_sec(D, 60, T)).\n")
    assert [o.event for o in engine.feed_batch([("seen(datime(2020,1,1,23,59,30))", 1),
                                                ("seen(datime(2020,1,3,0,0,0))", 2)])] == \
        ["late(datime(2020,1,2,0,0,30))"]
