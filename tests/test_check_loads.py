"""What `retalisc check` accepts compiles and loads (issue 35, repros 11 and 16).

- No Python traceback escapes `check` for odd numbers in directives (`:- op(1e309, xfx, <-).`,
  huge integers, NaN): a located error, exit status 2 (hypothesis over directive arguments).
- A program `check` accepts loads in SWI-Prolog without an error: the oracle loads every
  accepted program of a generated set (directives that load files, windows, numbers) in one
  `swipl` process; `check` itself loads only the programs that load files (load_check.py).
"""
from __future__ import annotations

import json
import re
import subprocess

import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st

from retalisc.cli import main
from retalisc.compiler import compile_source
from retalisc.frontend.errors import RetalisError
from retalisc.load_check import load_error

LOCATED = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+): (syntax )?error: ")

NUMBERS = ["0", "1", "700", "1200", "1201", "-1", "1e309", "-1e309", "1.0e308", "1.0Inf", "-1.0Inf", "1.5NaN",
           "nan", "inf", "99999999999999999999999999999999999999", "-99999999999999999999999999999",
           "0x7fffffffffffffffffff", "2.5", "0.0", "-0.0", "1.0e-320", "0'a", "1_000"]
OP_TYPES = ["xfx", "xfy", "yfx", "fx", "fy", "xf", "yf", "abc", "1e309", "X"]
OP_NAMES = ["<-", "===>", "seq", "[a, b]", "[]", "'|'", "1e309", "X", "foo"]
FILES = ["missing_file", "library(lists)", "library(no_such_library_xyz)", "helper", "'helper.pl'",
         "[missing_file]", "library(1e309)"]


def check(path):
    """`retalisc check PATH` as a user runs it: (exit status, standard error)."""
    result = CliRunner().invoke(main, ["check", str(path)])
    return result.exit_code, result.stderr


def assert_located(path, code, stderr):
    assert code == 2, stderr
    assert "Traceback" not in stderr
    first = stderr.splitlines()[0]
    match = LOCATED.match(first)
    assert match and match["file"] == str(path), stderr


def test_an_op_directive_with_a_priority_beyond_a_float_is_a_located_error(tmp_path):
    path = tmp_path / "op.rtl"
    path.write_text(":- op(1e309, xfx, <-).\n")
    code, stderr = check(path)
    assert_located(path, code, stderr)
    assert stderr.startswith(f"{path}:1:7: error: op/3: the priority must be an integer")


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(NUMBERS), st.sampled_from(OP_TYPES), st.sampled_from(OP_NAMES),
       st.sampled_from(["a(N).", "r <- (a seq b).N.", "c_mem(m, a(_)-[], N, N).", "max_delay(a/1, N).",
                        "n <- not(c).[a, N].", ":- set_etalis_flag(window, N).", "p(X) :- X > N.",
                        ":- X is N.", "s(X) <- a(X) where X < N."]))
def test_no_traceback_escapes_the_compiler_for_odd_directive_arguments(priority, kind, name, clause):
    text = f":- op({priority}, {kind}, {name}).\n{clause.replace('N', priority)}\nq <- a seq b.\n"
    try:
        compile_source(text, "fuzz.rtl")
    except RetalisError as error:
        assert error.span is not None and error.span.file == "fuzz.rtl" and error.span.line >= 1, error.message


TOKENS = NUMBERS + ["a", "b(", "X", ")", ",", ".", " ", "\n", "<-", ":-", "seq", "where", "(", "[", "]", "op(",
                   "xfx", "is", "1e309", "- ", "'q'", "\"s\"", "c_mem(", "not(", ").", "^", "T", "sub(", "|"]


@settings(max_examples=120, deadline=None)
@given(st.lists(st.sampled_from(TOKENS), min_size=1, max_size=30))
def test_no_traceback_escapes_the_compiler_for_token_soups_with_odd_numbers(tokens):
    text = "".join(tokens) + "\n"
    try:
        compile_source(text, "soup.rtl")
    except RetalisError as error:
        assert error.span is not None and error.span.file == "soup.rtl" and error.span.line >= 1, error.message


def test_check_on_a_program_that_loads_a_missing_file_is_a_located_error(tmp_path):
    path = tmp_path / "p.rtl"
    path.write_text("p(1).\n:- ensure_loaded(missing_file).\nr <- a seq b.\n")
    code, stderr = check(path)
    assert_located(path, code, stderr)
    assert stderr.startswith(f"{path}:2:1: error: the compiled program does not load: "), stderr
    assert "missing_file" in stderr.splitlines()[0]


def test_check_finds_a_loaded_file_next_to_the_program(tmp_path):
    (tmp_path / "helper.pl").write_text("helper_fact(1).\n")
    path = tmp_path / "p.rtl"
    path.write_text(":- ensure_loaded(helper).\nr(X) <- a(X) where helper_fact(X).\n")
    assert check(path) == (0, f"{path}: ok (1 event rule)\n")


def test_check_on_an_infinite_window_is_a_located_error(tmp_path):
    path = tmp_path / "w.rtl"
    path.write_text("r <- (a seq b).1e309.\n")
    code, stderr = check(path)
    assert_located(path, code, stderr)
    assert "at most 1e+15" in stderr


def _programs():
    """Programs that load files, set windows and op/3 priorities from odd numbers."""
    for number in NUMBERS:
        yield f"r <- (a seq b).{number}.\n"
        yield f":- op({number}, xfx, ===>).\nx <- a ===> b.\n"
        yield f"c_mem(m, a(_)-[], 2, {number}).\nl(X) <- b(_)^T where prev(m, a(X)^_, T).\n"
        yield f"n <- not(c).[a, {number}].\n"
        yield f"f({number}).\ng(X) :- X is {number} + 1.\n"
    for spec in FILES:
        yield f":- ensure_loaded({spec}).\nr <- a seq b.\n"
        yield f":- use_module({spec}).\nr <- a seq b.\n"
        yield f"p(1).\n:- consult({spec}).\nr <- a.\n"


def test_every_program_check_accepts_loads_in_swipl(tmp_path, swipl):
    # a module file: the programs load it into modules of their own, in one process
    (tmp_path / "helper.pl").write_text(":- module(helper, [helper_fact/1]).\nhelper_fact(1).\n")
    accepted = []
    for n, text in enumerate(_programs()):
        path = tmp_path / f"p{n}.rtl"
        path.write_text(text)
        try:
            result = compile_source(text, str(path), output_name=f"p{n}.pl", module=f"rtl_prog_p{n}")
        except RetalisError as error:
            assert error.span is not None and error.span.file == str(path), error.message
            continue
        if load_error(result, str(path)) is not None:       # what check adds to the compilation
            continue
        out = tmp_path / f"p{n}.pl"
        out.write_text(result.prolog, encoding="utf-8")
        accepted.append(str(out))
    assert len(accepted) > 20
    goal = ("create_prolog_flag(retalis_embedded, true, []), "
            f"forall(member(F, {json.dumps(accepted)}), load_files(F, [])), halt(0)")
    load = subprocess.run([swipl, "--no-tty", "-q", "-g", goal, "-t", "halt(1)"], capture_output=True, text=True,
                          timeout=300, cwd=tmp_path)
    assert load.returncode == 0, load.stderr
    problems = [line for line in load.stderr.splitlines() if line.startswith(("ERROR", "Warning"))]
    assert not problems, load.stderr


@pytest.fixture
def swipl():
    from shutil import which

    found = which("swipl")
    if found is None:
        pytest.skip("no swipl")
    return found
