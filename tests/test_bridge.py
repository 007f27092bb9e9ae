"""Behavioural tests of retalisc.driver.bridge against the real SWI-Prolog."""

from __future__ import annotations

import importlib
import importlib.util
import threading
from pathlib import Path

import pytest

from retalisc.driver import bridge as bridge_mod
from retalisc.driver.bridge import Bridge, GoalFailed, PrologError


@pytest.fixture(scope="module")
def pl() -> Bridge:
    return Bridge()


def test_backend_is_known(pl: Bridge) -> None:
    assert pl.backend in ("janus", "pyswip")


def test_singleton_and_reimport(pl: Bridge) -> None:
    assert Bridge() is pl
    assert Bridge.instance() is pl
    again = importlib.import_module("retalisc.driver.bridge")
    assert again.Bridge() is pl


def test_second_copy_of_module_reuses_engine(pl: Bridge) -> None:
    # A second module object for the same file (as after an import under
    # another name) must not try to initialise Prolog again.
    spec = importlib.util.spec_from_file_location("bridge_copy", bridge_mod.__file__)
    assert spec is not None and spec.loader is not None
    copy = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(copy)
    pl.once("retractall(copy_marker(_)), assertz(copy_marker(42))")
    other = copy.Bridge()
    assert other is not pl
    assert other.backend == pl.backend
    assert other.once("copy_marker(X)", "X") == "42"
    assert pl.once("X is 2*21", "X") == "42"


def test_once_truth(pl: Bridge) -> None:
    assert pl.once("true") is True
    assert pl.once("fail") is False
    assert pl.once("member(x, [a, b])") is False
    assert pl.once("member(b, [a, b])") is True


def test_once_template(pl: Bridge) -> None:
    assert pl.once("X is 1+2", "X") == "3"
    assert pl.once("X = 'Hello World', Y = [1, 2.5, \"s\"]", "f(X, Y)") == \
        "f('Hello World',[1,2.5,\"s\"])"
    assert pl.once("member(X, [])", "X") is None


def test_template_shares_variables_by_name(pl: Bridge) -> None:
    assert pl.once("X = a, Y = b", "pair(Y, X)") == "pair(b,a)"
    # Template variables absent from the goal stay unbound.
    assert pl.once("X = a", "t(X, Z)").startswith("t(a,_")


def test_trailing_full_stop_and_comment(pl: Bridge) -> None:
    assert pl.once("X is 6*7.", "X") == "42"
    assert pl.once("X = ok % trailing comment", "X") == "ok"


def test_all(pl: Bridge) -> None:
    assert pl.all("member(X, [a, 'B', \"s\", 1.5])", "X") == ["a", "'B'", '"s"', "1.5"]
    assert pl.all("between(1, 3, X), Y is X*X", "X-Y") == ["1-1", "2-4", "3-9"]
    assert pl.all("fail", "x") == []


def test_call_text_returns_unquoted_text(pl: Bridge) -> None:
    assert pl.call_text("Out = 'It''s'") == "It's"
    assert pl.call_text('Out = "line1\\nline2"') == "line1\nline2"
    assert pl.call_text("atom_codes(R, \"abc\")", result_var="R") == "abc"
    assert pl.call_text("Out = \"abc\"") == "abc"
    assert pl.call_text("Out is 40+2") == "42"
    assert pl.call_text("Out = f(x)") == "f(x)"


def test_call_text_failure_and_missing_variable(pl: Bridge) -> None:
    with pytest.raises(GoalFailed):
        pl.call_text("fail, Out = x")
    with pytest.raises(PrologError, match="Result"):
        pl.call_text("Out = x", result_var="Result")
    with pytest.raises(PrologError):
        pl.call_text("true, Out = _")


def test_unicode_round_trip(pl: Bridge) -> None:
    text = "héllo wörld – 日本語 ✓ 𝄞"
    assert pl.call_text(f'Out = "{text}"') == text
    assert pl.once(f"X = '{text}'", "X") == f"'{text}'"
    assert pl.call_text("atom_length('日本語', N), format(string(Out), '~w|~a', [N, 'ü'])") \
        == "3|ü"
    assert pl.all("sub_atom('äöü', _, 1, _, C)", "C") == ["ä", "ö", "ü"]


def test_unknown_procedure_raises(pl: Bridge) -> None:
    with pytest.raises(PrologError, match="Unknown procedure: no_such_pred_xyz/1") as info:
        pl.once("no_such_pred_xyz(1)")
    assert info.value.term is not None
    assert info.value.term.startswith("error(existence_error(procedure,no_such_pred_xyz/1)")


def test_errors_carry_prolog_message(pl: Bridge) -> None:
    with pytest.raises(PrologError, match="zero_divisor"):
        pl.once("X is 1/0", "X")
    with pytest.raises(PrologError, match="not sufficiently instantiated"):
        pl.once("atom_length(_, _)")
    with pytest.raises(PrologError, match="my_ball") as info:
        pl.once("throw(my_ball(1))")
    assert info.value.term == "my_ball(1)"
    with pytest.raises(PrologError, match="Type error"):
        pl.all("member(X, [a]), atom_length(f(X), _)", "X")


def test_syntax_errors_raise(pl: Bridge) -> None:
    with pytest.raises(PrologError, match="[Ss]yntax error"):
        pl.once("foo(")
    with pytest.raises(PrologError, match="[Ss]yntax error"):
        pl.once("X = 1", "f(X")


def test_engine_usable_after_repeated_errors(pl: Bridge) -> None:
    bad = ["undefined_1", "X is foo+1", "throw(x)", "a b c", "atom_length(1, a)"]
    for goal in bad:
        with pytest.raises(PrologError):
            pl.once(goal)
    assert pl.once("X is 2+2", "X") == "4"
    assert pl.all("member(X, [1, 2])", "X") == ["1", "2"]


def test_prolog_flags(pl: Bridge) -> None:
    assert pl.once("current_prolog_flag(debug_on_error, F)", "F") == "false"
    assert pl.once("current_prolog_flag(unknown, F)", "F") == "error"


def test_consult_defines_predicates(pl: Bridge, tmp_path: Path) -> None:
    src = tmp_path / "facts.pl"
    src.write_text(
        "bridge_test_color(rouge).\n"
        "bridge_test_color('grün').\n"
        "bridge_test_join(Out) :-\n"
        "    findall(C, bridge_test_color(C), Cs),\n"
        "    atomic_list_concat(Cs, ',', Out).\n",
        encoding="utf-8",
    )
    pl.consult(str(src))
    assert pl.all("bridge_test_color(C)", "C") == ["rouge", "grün"]
    assert pl.call_text("bridge_test_join(Out)") == "rouge,grün"


def test_consult_reports_errors(pl: Bridge, tmp_path: Path) -> None:
    with pytest.raises(PrologError, match="does not exist"):
        pl.consult(str(tmp_path / "missing.pl"))
    bad = tmp_path / "bad.pl"
    bad.write_text("bridge_test_ok(1).\nbridge_test_broken(( :- .\n", encoding="utf-8")
    with pytest.raises(PrologError, match="bad.pl:2"):
        pl.consult(bad)
    # The well-formed clause was still loaded and the engine still works.
    assert pl.once("bridge_test_ok(X)", "X") == "1"


def test_batch_call_returns_long_string_intact(pl: Bridge) -> None:
    chunk = "événement;𝄞;\\n;"  # the \n is a Prolog escape -> real newline
    payload = chunk * (1_000_000 // len(chunk) + 1)
    out = pl.call_text(f'string_concat("{payload}", "<end>", Out)')
    expected = payload.replace("\\n", "\n") + "<end>"
    assert len(out.encode("utf-8")) > 1_000_000
    assert out == expected


def test_batch_of_terms(pl: Bridge, tmp_path: Path) -> None:
    src = tmp_path / "batch.pl"
    src.write_text(
        "bridge_test_feed(Batch, Out) :-\n"
        "    maplist([ev(I, S), L]>>format(string(L), '~w:~w', [I, S]), Batch, Ls),\n"
        "    atomic_list_concat(Ls, '\\n', Out).\n",
        encoding="utf-8",
    )
    pl.consult(src)
    batch = ",".join(f'ev({i}, "é{i}")' for i in range(1000))
    out = pl.call_text(f"bridge_test_feed([{batch}], Out)")
    assert out.split("\n") == [f"{i}:é{i}" for i in range(1000)]


def test_many_text_results_do_not_exhaust_string_buffers(pl: Bridge) -> None:
    # Regression: each text result used to leave a buffer on SWI's string
    # buffer stack; after 2**20 of them the process aborted.
    for _ in range(1000):
        out = pl.all("between(1, 1100, X)", "X")
    assert len(out) == 1100 and out[-1] == "1100"


def test_resource_error_is_recoverable(pl: Bridge) -> None:
    old_limit = pl.once("current_prolog_flag(stack_limit, L)", "L")
    pl.once("set_prolog_flag(stack_limit, 32_000_000)")
    try:
        with pytest.raises(PrologError, match="[Ss]tack limit"):
            pl.once("numlist(1, 100_000_000, L), sum_list(L, S)", "S")
    finally:
        pl.once(f"set_prolog_flag(stack_limit, {old_limit})")
    assert pl.once("X is 1+1", "X") == "2"


def test_calls_from_other_threads(pl: Bridge) -> None:
    pl.once("retractall(bridge_test_shared(_)), assertz(bridge_test_shared(7))")
    results: list[object] = []
    errors: list[BaseException] = []

    def worker(n: int) -> None:
        try:
            for _ in range(50):
                results.append(pl.once(f"bridge_test_shared(X), Y is X*{n}", "Y"))
        except BaseException as e:  # surfaced by the assertion below
            errors.append(e)

    threads = [threading.Thread(target=worker, args=(n,)) for n in range(1, 5)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert sorted(set(results)) == ["14", "21", "28", "7"]
    assert len(results) == 200


def test_prolog_half_plunit(swipl):
    """prolog_runtime/tests/test_bridge.pl: the Prolog half of the bridge (rtl_bridge.pl) on its own."""
    import subprocess
    from pathlib import Path

    suite = Path(__file__).resolve().parent.parent / "prolog_runtime" / "tests" / "test_bridge.pl"
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt", str(suite)],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout
