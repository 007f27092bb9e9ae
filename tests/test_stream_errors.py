"""One failing event is reported and the stream goes on:
errors raised while processing an event, `--strict`, `halt` from program code, and
derivations that never end (the step limit). Both paths: `retalisc run` and `swipl OUT.pl`."""
import json
import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine

from stream_paths import PATHS, jsonl, run_path

PROGRAM = """
first(X, Y) <- a(X, Y).
big(X, Y) <- a(X, Y) where Y > 1.
odd(X) <- d(X) where nosuch(X).
"""

EVENTS = jsonl(
    ("a(1, 5)", 1),
    ("a(2, foo)", 2),       # first(2, foo) is derived, then `Y > 1` raises
    ("d(1)", 3),            # nosuch/1 does not exist
    ("a(3, 7)", 4),
)

SUMMARY = re.compile(r"^retalis: (\d+) events in, (\d+) derived, (\d+) rejected(, \d+ \w+)*, \d+\.\d\d s$")


def summary(stderr: str) -> re.Match:
    last = stderr.rstrip("\n").splitlines()[-1]
    match = SUMMARY.match(last)
    assert match, f"no summary line at the end of stderr: {last!r}"
    return match


@pytest.mark.parametrize("path", PATHS)
def test_a_failing_event_is_reported_and_the_stream_goes_on(path, tmp_path, capfd):
    result = run_path(path, tmp_path, PROGRAM, EVENTS, "--batch-size", "3", capfd=capfd)
    assert result.returncode == 0, result.stderr
    assert result.events == ["first(1,5)", "big(1,5)", "first(2,foo)", "first(3,7)", "big(3,7)"]
    assert re.search(re.escape(result.location(2)) + r" error: .*foo.* while processing a\(2,foo\)\n",
                     result.stderr), result.stderr
    assert re.search(re.escape(result.location(3)) + r" error: .*nosuch/1.* while processing d\(1\)\n",
                     result.stderr), result.stderr
    assert "Traceback" not in result.stderr
    assert summary(result.stderr).groups()[:3] == ("4", "5", "0")
    assert ", 2 failed" in result.stderr.splitlines()[-1]


@pytest.mark.parametrize("path", PATHS)
def test_strict_stops_at_the_first_bad_line_after_printing_its_output(path, tmp_path, capfd):
    result = run_path(path, tmp_path, PROGRAM, EVENTS, "--strict", capfd=capfd)
    assert result.returncode == 1
    assert result.events == ["first(1,5)", "big(1,5)", "first(2,foo)"]
    assert f"{result.location(2)} error: " in result.stderr and "d(1)" not in result.stderr


@pytest.mark.parametrize("path", PATHS)
def test_strict_is_fatal_for_a_rejected_line_too(path, tmp_path, capfd):
    events = jsonl(("a(1, 5)", 1), "not json", ("a(3, 7)", 4))
    result = run_path(path, tmp_path, PROGRAM, events, "--strict", capfd=capfd)
    assert result.returncode == 1
    assert result.events == ["first(1,5)", "big(1,5)"]
    assert f"{result.location(2)} rejected: invalid JSON" in result.stderr


HALTS = {
    "action": ("null do halt <- stop.\n", "(in the action halt) while processing stop"),
    "condition": ("never <- stop where halt.\n", "while processing stop"),
    "static rule": ("quit :- X = 1, X > 0, halt(0).\nnever <- stop where quit.\n", "while processing stop"),
}


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("where", sorted(HALTS))
def test_halt_in_program_code_flushes_output_and_exits_non_zero(path, where, tmp_path, capfd):
    rules, message = HALTS[where]
    program = "out(X) <- a(X).\n" + rules
    events = jsonl(("a(1)", 1), ("stop", 2), ("a(3)", 3))
    result = run_path(path, tmp_path, program, events, capfd=capfd)
    assert result.returncode == 1, result.stderr
    assert result.events == ["out(1)"]
    assert f"{result.location(2)} error: the program called halt {message}" in result.stderr


POSTPONED_HALT = """
memorize(tf(V), [], tf(V), odom, 100).
place(T, X) :- prev(odom, tf(X)^_, T), halt.
syncronized(pose(Name, X), place(T, X), [[odom, T]]) <- marker(Name)^T.
"""


@pytest.mark.parametrize("path", PATHS)
def test_halt_in_a_match_postponed_to_the_end_of_the_input_exits_non_zero(path, tmp_path, capfd):
    events = jsonl(("tf(1)", 1), ("marker(m1)", 2))
    result = run_path(path, tmp_path, POSTPONED_HALT, events, capfd=capfd)
    assert result.returncode == 1, result.stderr
    assert "the program called halt while processing the matches postponed to the end of the input" \
        in result.stderr


@pytest.mark.parametrize("path", PATHS)
def test_halt_in_a_directive_says_where_and_exits_non_zero(path, tmp_path, capfd):
    result = run_path(path, tmp_path, "out(X) <- a(X).\n:- halt.\n", jsonl(("a(1)", 1)), capfd=capfd)
    assert result.returncode == 1, result.stderr
    assert result.stdout == ""
    assert "the program called halt in the directive" in result.stderr


CYCLIC = """
a(X) <- a(X).
b(X) <- c(X).
loop(X) :- loop(X).
spin(X) <- s(X) where loop(X).
deep(X) :- deep(X), true.
dive(X) <- v(X) where deep(X).
work(N) <- w(N) where numlist(1, N, L), sum_list(L, _).
"""


@pytest.mark.parametrize("path", PATHS)
def test_derivations_that_never_end_are_stopped_per_event(path, tmp_path, capfd):
    events = jsonl(("a(1)", 1), ("s(1)", 2), ("v(1)", 3), ("c(2)", 4), ("w(2000)", 5))
    result = run_path(path, tmp_path, CYCLIC, events, "--max-steps", "200000", timeout=60, capfd=capfd)
    assert result.returncode == 0, result.stderr
    for line, event in ((1, "a(1)"), (2, "s(1)"), (3, "v(1)")):
        assert re.search(re.escape(result.location(line)) + r" error: more than 200,?000 steps \(--max-steps\) "
                         r"while processing " + re.escape(event), result.stderr), result.stderr
    assert result.events[-2:] == ["b(2)", "work(2000)"]
    assert "a(1)" in result.events                    # the first derivations came out before the limit
    second = tmp_path / "second"
    second.mkdir()
    result = run_path(path, second, CYCLIC, jsonl(("w(2000)", 1)), "--max-steps", "1000", capfd=capfd)
    assert result.events == [] and "more than 1,000 steps" in result.stderr


@pytest.mark.parametrize("path", PATHS)
def test_the_default_step_limit_stops_a_cyclic_rule(path, tmp_path, capfd):
    events = jsonl(("a(1)", 1), ("c(2)", 2))
    program = "print_trigger(b/1).\na(X) <- a(X).\nb(X) <- c(X).\n"     # only b/1 is written out
    result = run_path(path, tmp_path, program, events, timeout=60, capfd=capfd)
    assert result.returncode == 0, result.stderr
    assert "error: more than 1,000,000 steps (--max-steps) while processing a(1)" in result.stderr
    assert result.events == ["b(2)"]


# ---- property: bad lines change nothing for the good ones -------------------------------------

ORACLE_PROGRAM = """
big(I, Y) <- b(I, Y) where Y > 50.
pair(I, X, Y) <- (a(I, X) seq b(I, Y)).10.
both(I) <- (a(I, _) and c(I)).5.
"""

good_event = st.tuples(st.sampled_from(["a", "b", "c"]), st.integers(1, 3), st.integers(1, 100))
BAD_LINES = [
    "not json",
    '{"event": "a(1, _)", "t": 1}',
    '{"event": "b(1, 2). halt", "t": 1}',
    '{"event": "b(2, 3)", "t": 1.0Inf}',
    '{"event": "b(2, 3)", "t": "7"}',
    '{"event": "b(2, 3)", "start": 9, "end": 3}',
    '{"event": "b(2, 3)", "t": [1, 1000000000]}',
    '{"event": "b(2, foo)", "t": 1}',                       # raises in `Y > 50`
    '{"event": "b(3, 400)", "t": 2, "op": "retract"}',      # never added
    '{"op": "delete_rule", "rule": "r1"}',
    '{"op": "add_rule", "rule": "x(X) <- a(X, _)."}',
]


def _lines(events):
    out = []
    for t, (kind, key, value) in enumerate(events, start=1):
        text = f"c({key})" if kind == "c" else f"{kind}({key}, {value})"
        out.append(json.dumps({"event": text, "t": t}))
    return out


@pytest.fixture(scope="module")
def oracle_engine():
    return Engine.from_source(ORACLE_PROGRAM, "oracle.rtl")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(events=st.lists(good_event, max_size=12), data=st.data())
def test_bad_lines_interleaved_with_good_ones_change_nothing(oracle_engine, events, data):
    good = _lines(events)
    mixed = list(good)
    for _ in range(data.draw(st.integers(0, 8))):
        mixed.insert(data.draw(st.integers(0, len(mixed))), data.draw(st.sampled_from(BAD_LINES)))
    oracle_engine.clear()
    expected, rejected = oracle_engine.feed_lines("\n".join(good))
    assert rejected == []
    oracle_engine.clear()
    got = []
    for start in range(0, len(mixed), 3):                 # batches of 3, as `--batch-size 3`
        produced, rejected = oracle_engine.feed_lines("\n".join(mixed[start:start + 3]), start + 1)
        got += produced
        for rejection in rejected:
            assert mixed[rejection.line - 1] in BAD_LINES
    assert [e.line for e in got] == [e.line for e in expected]
