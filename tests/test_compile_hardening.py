"""Everything `check` accepts compiles, loads and runs, and the command line
fails cleanly (item 5).

Each program `check` used to accept although SWI-Prolog could not load what `compile` made of it,
or that silently meant something else than it says, is here: either rejected by both `check` and
`compile` with `file:line:col: message`, the offending line and exit status 2, or compiled,
loaded by `swipl` and run on events.
"""
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from retalisc.backends.prolog.swi_predicates import LIBRARY_PREDICATES, SYSTEM_PREDICATES
from retalisc.cli import main
from retalisc.compiler import compile_source
from retalisc.frontend.depth import MAX_TERM_DEPTH
from retalisc.frontend.errors import RetalisError

ROOT = Path(__file__).resolve().parent.parent
FIRE = ROOT / "examples" / "fire_alarm"


def cli(*args, input=None):
    """Run `retalisc ARGS` in this process: (exit status, stdout, stderr)."""
    result = CliRunner().invoke(main, [str(a) for a in args], input=input)
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result.exit_code, result.stdout, result.stderr


# ---- rejected with a located error ----------------------------------------------------------

# (id, program, line, column, words of the message)
REJECTED = [
    ("nested_clause_in_pattern", "x <- a seq (b :- c).\n", 1, 13, "cannot stand inside a pattern"),
    ("nested_rule_in_where", "x <- a seq (b where (c <- d)).\n", 1, 22, "cannot stand inside a goal"),
    ("nested_clause_in_body", "p :- (q :- r).\n", 1, 7, "cannot stand inside a goal"),
    ("clause_body_not_callable", "foo :- 1.\n", 1, 8, "not callable"),
    ("rule_head_number", "1 <- a.\n", 1, 1, "head of an event rule"),
    ("clause_for_iso_builtin", "atom_length(a, 1).\n", 1, 1, "cannot define atom_length/2: it is a builtin"),
    ("clause_for_other_builtin", "forall(a, b).\n", 1, 1, "cannot define forall/2: it is a builtin"),
    ("clause_for_runtime_predicate", "rtl_input(a, b, c, d).\n", 1, 1, "Retalis runtime (module rtl_raise)"),
    ("clause_for_runtime_internal", "x <- a.\nrtl_derived(a, 1, 2).\n", 2, 1, "cannot define rtl_derived/3"),
    ("dot_as_clause_end", "located(t, garage)'.'\nnear(A) :- located(A, _).\n", 1, 1, "dict access"),
    ("dot_in_declaration", "c_mem(m1, a(_)'.'[], 5, 10).\n", 1, 11, "dict access"),
    ("memory_created_twice", "c_mem(m, a(_)-[], 2, 5).\nc_mem(m, b(_)-[], 2, 5).\n", 2, 7,
     "a memory instance m is already created at line 1"),
    ("memory_size", "c_mem(m, a(_)-[], 0, 5).\n", 1, 19, "c_mem/4: argument 3 must be a positive integer"),
    ("memory_limit", "c_mem(m, a(_)-[], 1, -5).\n", 1, 22, "c_mem/4: argument 4 must be a number of seconds"),
    ("subscription_consumer", "sub(1, X, a(_)-[], t, 0).\n", 1, 8, "sub/5: argument 2 must be an atom"),
    ("subscription_made_twice", "sub(1, cons, a(X)-[X > 1], got(X), 0).\nsub(1, cons, b(_), b, 0).\n", 2, 5,
     "subscription 1 of cons is already made at line 1"),
    ("unsub_without_subscription", "unsub(3, now).\n", 1, 7, "no declaration above makes a subscription 3"),
    ("aggregate_variable_not_in_pattern", "m(M) <- s seq aggregate(min(P), price(1), M).\n", 1, 29,
     "the variable P of min(P) does not occur"),
    ("aggregate_of_a_constant", "m(M) <- s seq aggregate(max(3), price(_), M).\n", 1, 29,
     "max(X) aggregates a variable"),
    ("bar_disjunction_with_number", "p :- a | 8.\n", 1, 10, "calls 8, which is not a goal"),
    ("module_not_an_atom", "p :- 9:q.\n", 1, 6, "module that is not an atom"),
    ("grammar_head_control", "(a ; b) --> [x].\n", 1, 2, "head of a grammar rule must be a non-terminal"),
    ("grammar_module_not_an_atom", "g --> 3:h.\n", 1, 7, "module that is not an atom"),
    ("grammar_head_dot", "'.' --> [x].\n", 1, 1, "cannot define ./2"),
    ("dynamic_not_an_indicator", ":- dynamic foo/x.\n", 1, 12, "dynamic takes predicate indicators"),
    ("initialization_undefined", ":- initialization(nosuch).\n", 1, 19, "calls nosuch/0"),
    ("clause_for_generated_predicate", "x <- a seq b.\ne_r1_1(s, e).\n", 2, 1,
     "code generated for the event rules"),
    ("clause_for_template_predicate", "ele_trigger(a, 1, 2).\n", 1, 1, "cannot define ele_trigger/3"),
    ("directive_of_directive", ":- :- true.\n", 1, 4, "a directive is written ':- Goal.'"),
    ("conjunction_as_clause", "(a, b, c).\n", 1, 2, "cannot define ,/2"),
    ("module_directive", ":- module(foo, []).\n", 1, 4, "cannot declare a module"),
    ("op_bad_priority", ":- op(1300, xfx, foo).\n", 1, 7, "op/3: the priority"),
    ("op_bad_type", ":- op(700, xfz, ===>).\n", 1, 12, "op/3: the type"),
    ("op_bad_name", ":- op(700, xfx, 12).\n", 1, 17, "op/3: the operator must be an atom"),
    ("op_comma", ":- op(700, xfx, ',').\n", 1, 17, "cannot be changed"),
    ("dynamic_builtin", ":- dynamic atom_length/2.\n", 1, 12, "cannot declare dynamic atom_length/2"),
    ("directive_undefined", ":- setup.\nsetup.\n", 1, 4, "calls setup/0, which does not exist when it runs"),
    ("directive_variable", ":- X.\n", 1, 4, "not a variable"),
    ("unknown_aggregate", "x(S) <- a seq aggregate(median(Y), b(Y), S).\n", 1, 25,
     "unknown aggregate function median(Y)"),
    ("aggregate_arity", "x <- aggregate(count, b).\n", 1, 6, "aggregate(Function, Pattern, Value)"),
    ("not_without_interval", "x <- a seq not(b(X)).\n", 1, 12, "not(N).[P1, P2]"),
    ("not_atom", "x <- a seq not.\n", 1, 12, "not(N).[P1, P2]"),
    ("duplicate_label", "l1 'rule:' x <- a.\nl1 'rule:' y <- b.\n", 2, 1, "two rules are labelled l1"),
    ("duplicate_label_colon", "l1 : x <- a.\nl1 : y <- b.\n", 2, 1, "two rules are labelled l1"),
    ("numeric_label", "7 'rule:' x <- a.\n", 1, 1, "rule label must be a name"),
    ("numeric_label_colon", "7 : x <- a.\n", 1, 1, "cannot be Module:Event"),
    ("label_not_a_name", "'My rule' 'rule:' x <- a.\n", 1, 1, "must be a name matching"),
    ("unknown_escape_atom", "x('a\\qb') <- a.\n", 1, 5, "unknown escape sequence '\\q'"),
    ("unknown_escape_string", "x(S) <- a where S = \"\\z\".\n", 1, 22, "unknown escape sequence '\\z'"),
    ("short_unicode_escape", "x('\\u12') <- a.\n", 1, 4, "\\u must be followed by 4 hexadecimal digits"),
    ("escape_out_of_range", "x('\\x110000\\') <- a.\n", 1, 4, "illegal character code"),
    ("where_number", "x <- a where 1.\n", 1, 14, "a condition calls 1"),
    ("action_number", "x do 1 <- a.\n", 1, 6, "an action calls 1"),
    ("grammar_number", "greeting --> 1.\n", 1, 14, "grammar rule body"),
    ("window_nan", "x <- (a).nan.\n", 1, 7, "needs a number Q"),
    ("module_qualified_clause", "lists:append(a, b, c).\n", 1, 1, "another module"),
    ("too_deep", "x(Y) <- a where Y = " + "(" * (MAX_TERM_DEPTH + 5) + "1" + ")" * (MAX_TERM_DEPTH + 5) + ".\n",
     1, None, "clause too deep"),
]


@pytest.mark.parametrize("program, line, column, words", [r[1:] for r in REJECTED], ids=[r[0] for r in REJECTED])
def test_check_and_compile_reject_with_a_location(tmp_path, program, line, column, words):
    path = tmp_path / "p.rtl"
    path.write_text(program)
    status, out, err = cli("check", path)
    assert status == 2 and out == ""
    first, offending = err.splitlines()[:2]
    where = f"{path}:{line}:{column}: " if column else f"{path}:{line}:"
    assert first.startswith(where), err
    assert words in first, err
    assert offending.strip() == program.splitlines()[line - 1].strip()[:len(offending.strip())]
    assert "Traceback" not in err
    # compile goes the same way, and writes nothing
    output = tmp_path / "p.pl"
    assert cli("compile", path, "-o", output) == (2, "", err)
    assert not output.exists()


# ---- accepted: compiled, loaded by swipl and run ---------------------------------------------

def _events(*items):
    return "".join(json.dumps({"event": e, "t": t}) + "\n" for e, t in items)


DEEP = 400
CHAIN = 1500

# (id, program, events, derived events in output order (event, start, end))
ACCEPTED = [
    ("events_named_like_operators",
     "meets(R, P) <- a(R) seq b(P).\nand(X, Y) <- a(X) and b(Y).\nseq(X, Y) <- a(X) seq b(Y).\n"
     "where(X) <- a(X).\nx(Y) <- a(X) where Y = (X seq X).\n",
     _events(("a(1)", 1), ("b(2)", 2)),
     [("where(1)", 1, 1), ("x(seq(1,1))", 1, 1), ("meets(1,2)", 1, 2), ("and(1,2)", 1, 2), ("seq(1,2)", 1, 2)]),
    ("new_event_directive", ":- new_event(foo(1)).\nx <- foo(1) seq a.\n", _events(("a", 3)), [("x", 0, 3)]),
    ("new_event_directive_with_time", ":- new_event(foo(1), 2).\nx <- foo(1) seq a.\n", _events(("a", 3)),
     [("x", 2, 3)]),
    ("label_that_is_an_automatic_id", "x <- a.\nr1 : y <- a.\n", _events(("a", 1)), [("x", 1, 1), ("y", 1, 1)]),
    ("known_escapes", "x('a\\x41\\b\\101\\c  d', 'p\\c   q', \"\\u00e9\", 0'\\101\\) <- a.\n", _events(("a", 1)),
     [("x('aAbAc  d',pq,\"é\",65)", 1, 1)]),
    ("control_characters_in_atoms", "x('a\\0\\b\\x7f\\') <- a.\n", _events(("a", 1)), [("x('a\\x0\\b\\x7F\\')", 1, 1)]),
    ("deep_brackets", "x(Y) <- a(X) where Y is " + "(" * DEEP + "X + 1" + ")" * DEEP + ".\n"
     "y <- " + "(" * DEEP + "a(_)" + ")" * DEEP + ".\n", _events(("a(3)", 1)), [("x(4)", 1, 1), ("y", 1, 1)]),
    ("deep_term", "x(" + "f(" * DEEP + "a" + ")" * DEEP + ") <- a.\n", _events(("a", 1)),
     [("x(" + "f(" * DEEP + "a" + ")" * DEEP + ")", 1, 1)]),
    ("seq_chain", "x <- " + " seq ".join(f"e{i}" for i in range(CHAIN)) + ".\n",
     _events(*[(f"e{i}", i + 1) for i in range(CHAIN)]), [("x", 1, CHAIN)]),
    ("non_finite_numbers", "x(1.0Inf, -1.0Inf, 1.5NaN) <- a.\ny(Z) <- a where Z is -(1.0Inf).\n",
     _events(("a", 1)), [("x(1.0Inf,-1.0Inf,1.5NaN)", 1, 1), ("y(-1.0Inf)", 1, 1)]),
    ("own_library_predicates", "min(A, _, A).\n:- dynamic max/3.\nnew_event(_).\n"
     "x(M) <- a(X) where min(X, 2, M).\n", _events(("a(1)", 1), ("a(5)", 2)), [("x(1)", 1, 1), ("x(5)", 2, 2)]),
    ("initialization_calls_clause_below", ":- initialization(setup).\nsetup :- assertz(seen(1)).\n"
     ":- dynamic seen/1.\nx(N) <- a where seen(N).\n", _events(("a", 1)), [("x(1)", 1, 1)]),
    ("memory_recreated_after_d_mem", "c_mem(m, a(_)-[], 2, 5).\nd_mem(m).\nc_mem(m, a(_)-[], 2, 5).\n"
     "x(Y) <- b where prev(m, a(Y)^_, 9).\n", _events(("a(1)", 1), ("b", 2)), [("x(1)", 2, 2)]),
    ("operator_atoms_as_operands", "* .\nwhere :- _.\nx(Y, Z) <- a where (Y = (\\ ;), Z = (- - -)).\n",
     _events(("a", 1)), [("x(\\ (;),- - (-))", 1, 1)]),
    ("directive_calling_clause_above", "setup :- assertz(seen(0)).\n:- dynamic seen/1.\n:- setup.\n"
     "x(N) <- a where seen(N).\n", _events(("a", 1)), [("x(0)", 1, 1)]),
]


def _derived(stdout: str):
    return [(d["event"], d["start"], d["end"]) for d in map(json.loads, stdout.splitlines())]


@pytest.mark.parametrize("program, events, expected", [a[1:] for a in ACCEPTED], ids=[a[0] for a in ACCEPTED])
def test_accepted_programs_load_and_run(tmp_path, swipl, program, events, expected):
    path = tmp_path / "p.rtl"
    path.write_text(program)
    status, _, err = cli("check", path)
    assert status == 0 and ": ok (" in err, err
    compiled = tmp_path / "p.pl"
    compiled.write_text(compile_source(program, str(path), output_name="p.pl").prolog)
    (tmp_path / "e.jsonl").write_text(events)
    run = subprocess.run([swipl, str(compiled), str(tmp_path / "e.jsonl")], capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 0, run.stderr
    assert "ERROR" not in run.stderr and "Warning" not in run.stderr, run.stderr
    assert sorted(_derived(run.stdout)) == sorted(expected)


def test_new_event_directive_through_the_engine():
    from retalisc.driver.engine import Engine

    earlier = Engine.from_compiled(compile_source("y <- b.\n", "earlier.rtl", module="rtl_prog_hardening_earlier"))
    earlier.feed("b", 50)           # another program's clock does not date the directive's event
    engine = Engine.from_compiled(compile_source(":- new_event(foo(1)).\nx <- foo(1) seq a.\n", "ne.rtl",
                                                 module="rtl_prog_hardening_ne"))
    assert [(o.event, o.start, o.end) for o in engine.feed("a", 3)] == [("x", 0, 3)]


def test_unlabelled_rule_keeps_clear_of_labels():
    unit = compile_source("x <- a.\nr1 : y <- a.\nz <- a.\n", "ids.rtl").unit
    assert [rule.rule_id for rule in unit.rules] == ["r1_2", "r1", "r3"]


def test_long_chains_of_variables_hit_the_arity_limit_with_a_location():
    variables = ", ".join(f"X{i}" for i in range(1100))
    program = f"x({variables}) <- e({variables}) seq f.\n"
    with pytest.raises(RetalisError) as info:
        compile_source(program, "wide.rtl")
    assert "SWI-Prolog allows at most 1024" in info.value.message
    assert (info.value.span.line, info.value.span.column) == (1, 1)


def test_generated_code_writes_event_operators_as_functors():
    prolog = compile_source("meets(R, P) <- a(R) seq b(P).\n", "m.rtl").prolog
    assert "rtl_derived(meets(R, P)" in prolog
    assert " meets " not in prolog.split("% ---- r1")[1].split("\n", 3)[3]


# ---- SWI-Prolog's predicate lists ---------------------------------------------------------------

_LISTS = r"""
listed(s, N, A) :- predicate_property(system:H, defined), functor(H, N, A), \+ sub_atom(N, 0, _, _, '$').
listed(l, N, A) :- '$autoload':library_index(H, _, _), functor(H, N, A), \+ sub_atom(N, 0, _, _, '$').
main :- aggregate_all(count, true, _),
        forall(listed(K, N, A), format("~w ~a ~w~n", [K, N, A])).
"""


def swipl_predicate_lists(swipl, tmp_path):
    """The builtins and autoloaded library predicates of the installed SWI-Prolog."""
    script = tmp_path / "lists.pl"
    script.write_text(_LISTS)
    out = subprocess.run([swipl, "-q", "-g", "main", "-t", "halt", str(script)], capture_output=True,
                         text=True, timeout=60, check=True).stdout
    lists = {"s": set(), "l": set()}
    for line in out.splitlines():
        kind, rest = line.split(" ", 1)
        name, _, arity = rest.rpartition(" ")
        lists[kind].add((name, int(arity)))
    return lists["s"], lists["l"]


def test_predicate_lists_match_the_installed_swipl(swipl, tmp_path):
    system, library = swipl_predicate_lists(swipl, tmp_path)
    assert set(SYSTEM_PREDICATES) == system
    assert set(LIBRARY_PREDICATES) == library


# ---- the command line fails cleanly (item 5) ---------------------------------------------------

FA, EV = FIRE / "fire_alarm.rtl", FIRE / "events.jsonl"

BAD_COMMAND_LINES = [
    ("run_missing_events", ["run", FA, "--events", "/nonexistent/e.jsonl"], "'--events'", "does not exist"),
    ("query_missing_events", ["query", FA, "--events", "/nonexistent/e.jsonl", "x"], "'--events'",
     "does not exist"),
    ("run_events_directory", ["run", FA, "--events", FIRE], "'--events'", "is a directory"),
    ("compile_unwritable_output", ["compile", FA, "-o", "/nonexistent/dir/x.pl"], "-o", "cannot write"),
    ("run_unwritable_output", ["run", FA, "--events", EV, "--out", "/nonexistent/dir/x"], "--out", "cannot write"),
    ("run_unmakeable_consumer_dir", ["run", FA, "--events", EV, "--consumer-dir", "/proc/x/y"], "--consumer-dir",
     "cannot make the directory"),
    ("max_delay_nan", ["run", FA, "--events", EV, "--max-delay", "nan"], "'--max-delay'", "NaN"),
    ("max_delay_minus_inf", ["run", FA, "--events", EV, "--max-delay", "-inf"], "'--max-delay'", "negative"),
    ("max_delay_negative", ["run", FA, "--events", EV, "--max-delay", "-1"], "'--max-delay'", "negative"),
    ("max_delay_text", ["run", FA, "--events", EV, "--max-delay", "soon"], "'--max-delay'", "not a number"),
    ("query_max_delay_nan", ["query", FA, "--max-delay", "nan", "x"], "'--max-delay'", "NaN"),
    ("query_timeout_nan", ["run", FA, "--events", EV, "--query-timeout", "nan"], "'--query-timeout'", "NaN"),
    ("query_time_inf", ["run", FA, "--events", EV, "--query", "inf", "x"], "--query", "finite"),
    ("aq_unknown_mode", ["aq", FA, "--script", EV, "--mode", "fast"], "'--mode'", "'fast' is not one of"),
    ("compile_unknown_pass", ["compile", FA, "--dump-after", "nothing"], "'--dump-after'", "is not one of"),
    ("check_unknown_option", ["check", FA, "--strict-mode"], "No such option", "--strict-mode"),
    ("check_missing_program", ["check", "/nonexistent.rtl"], "'PROGRAM'", "does not exist"),
    ("rules_without_module", ["compile-rules"], "Missing option", "--module"),
    ("unknown_command", ["chek", FA], "No such command", "chek"),
]


@pytest.mark.parametrize("args, option, words", [b[1:] for b in BAD_COMMAND_LINES],
                         ids=[b[0] for b in BAD_COMMAND_LINES])
def test_bad_command_lines_are_one_line_and_exit_2(args, option, words):
    status, out, err = cli(*args)
    assert status == 2 and out == ""
    assert len(err.splitlines()) == 1, err
    assert ": error: " in err and option in err and words in err
    assert "Traceback" not in err


def test_bad_command_line_from_a_subprocess_has_no_traceback():
    run = subprocess.run([sys.executable, "-m", "retalisc", "run", str(FA), "--events", "/nonexistent.jsonl"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and run.stdout == ""
    assert re.fullmatch(r".*retalisc run: error: Invalid value for '--events': .*does not exist.*\n", run.stderr)


def test_max_delay_inf_is_accepted(tmp_path):
    program = tmp_path / "fire_alarm_inf.rtl"        # a module name no other test loads
    program.write_text(FA.read_text())
    status, out, _ = cli("run", program, "--events", EV, "--max-delay", "inf")
    assert status == 0 and out == (FIRE / "expected.jsonl").read_text()


def test_swipl_reads_events_from_standard_input(tmp_path, swipl):
    compiled = tmp_path / "fire.pl"
    assert cli("compile", FA, "-o", compiled)[0] == 0
    run = subprocess.run([swipl, str(compiled), "-"], input=EV.read_text(), capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 0
    assert run.stdout == (FIRE / "expected.jsonl").read_text()
    assert "8 events" in run.stderr


COMMANDS = ["check", "compile", "run", "query", "aq", "compile-rules"]


@pytest.mark.parametrize("command", COMMANDS)
def test_help_gives_an_example(command):
    status, out, _ = cli(command, "--help")
    assert status == 0
    example = out.split("Example", 1)[1]
    assert f"retalisc {command} " in example


def test_readme_use_section_shows_every_command():
    readme = (ROOT / "README.md").read_text()
    use = readme.split("## Use", 1)[1].split("\n## ", 1)[0]
    for command in COMMANDS:
        assert f"retalisc {command} " in use, command
    assert "swipl OUT.pl -" in use
    # the two set-up commands stay as they are
    assert ("    bash setup.sh && .venv/bin/python examples/nao/make_bag.py /tmp/nao.bag --seconds 10 --force "
            "&& .venv/bin/retalisc run examples/nao/nao.rtl --bag /tmp/nao.bag\n") in readme
    assert "    bash setup.sh && .venv/bin/python -m pytest -q\n" in readme
