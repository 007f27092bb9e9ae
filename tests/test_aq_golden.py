"""Golden active-query cases in the XSB style (`tests/golden/<case>/` with a `program.pl`; the
layout and the one switch, `pytest --update-golden`, are described in tests/golden_cases.py).

The expectations (`expected.txt`) come from SWI-Prolog's own `:- table` (never from our code).
The test drives the `retalisc aq` command and rebuilds the answer sets from its add/delete
notifications.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from retalisc.cli import main
from aq_support import run_all
from golden_cases import GOLDEN, aq_cases, check_expected, modes

CASES = [case.name for case in aq_cases()]


def _lines(path: Path):
    return [line.strip() for line in path.read_text().splitlines() if line.strip()]


def _goal(line: str) -> str:
    return line[:-1] if line.endswith(".") else line


def render(goals, snapshots) -> str:
    out = []
    for label, answers in snapshots:
        out.append(f"% checkpoint: {label}")
        for n, goal in enumerate(goals, start=1):
            out.append(f"% query q{n}: {goal}")
            out.extend(answers[n])
    return "\n".join(out) + "\n"


def _labels(updates):
    labels, checkpoints = ["initial"], [0]
    for k, line in enumerate(updates, start=1):
        if line.startswith("?"):
            labels.append(f"after update line {k}")
            checkpoints.append(k)
    labels.append("end")
    checkpoints.append(len(updates))
    return labels, checkpoints


def _split_list(text: str):
    """`[a(1),b([x,y])]` (writeq of a sorted list) -> its element texts."""
    inner = text[1:-1]
    items, depth, start, quote = [], 0, 0, None
    for i, ch in enumerate(inner):
        if quote:
            if ch == quote and inner[i - 1] != "\\":
                quote = None
            continue
        if ch in "'\"":
            quote = ch
        elif ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            items.append(inner[start:i])
            start = i + 1
    if inner:
        items.append(inner[start:])
    return items


def oracle_expected(case: Path) -> str:
    source = (case / "program.pl").read_text()
    goals = [_goal(g) for g in _lines(case / "queries.txt")]
    updates = _lines(case / "updates.txt")
    steps = [(u[0], _goal(u[1:].strip())) for u in updates]
    _, oracle, _, _ = run_all(source, goals, steps, "tabled", scratch=False)
    labels, checkpoints = _labels(updates)
    snaps = [(label, {n: _split_list(oracle[(k, n)]) for n in range(1, len(goals) + 1)})
             for label, k in zip(labels, checkpoints)]
    return render(goals, snaps)


@pytest.mark.parametrize("case", CASES)
def test_expected_is_swi_tabling(case, update_golden):
    path = GOLDEN / case
    check_expected(path / "expected.txt", oracle_expected(path), update_golden)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("mode,subsumption", [("tabled", False), ("tabled", True), ("optimized", False),
                                              ("naive", False)])
def test_golden(case, mode, subsumption, tmp_path, monkeypatch):
    path = GOLDEN / case
    if mode not in modes(path):
        pytest.skip(f"{mode} does not terminate on {case} (left recursion or cycles)")
    goals = [_goal(g) for g in _lines(path / "queries.txt")]
    updates = _lines(path / "updates.txt")
    labels, checkpoints = _labels(updates)
    # One script per checkpoint prefix would re-register; instead replay the notifications.
    script_lines = [f"?q{n} {g}." for n, g in enumerate(goals, start=1)]
    boundaries = {0: len(script_lines)}
    for k, line in enumerate(updates, start=1):
        if not line.startswith("?"):
            script_lines.append(line)
        boundaries[k] = len(script_lines)
    # run the prefix up to each checkpoint: events are printed in script order, so we tag them
    # by running the prefixes incrementally through the same command
    snaps = []
    for label, k in zip(labels, checkpoints):
        script = tmp_path / f"script_{k}.txt"
        script.write_text("\n".join(script_lines[:boundaries[k]]) + "\n")
        args = ["aq", str(path / "program.pl"), "--script", str(script), "--mode", mode]
        if subsumption:
            args.append("--subsumption")
        result = CliRunner().invoke(main, args, catch_exceptions=False)
        assert result.exit_code == 0, f"exit {result.exit_code} at {label}: {result.stderr}"
        answers = {n: set() for n in range(1, len(goals) + 1)}
        for line in result.stdout.splitlines():
            event = json.loads(line)
            n = int(event["query"][1:])
            if event["op"] in ("answer", "add"):
                assert event["answer"] not in answers[n] or event["op"] == "answer", line
                answers[n].add(event["answer"])
            else:
                assert event["answer"] in answers[n], f"delete of an absent answer: {line}"
                answers[n].remove(event["answer"])
        snaps.append((label, {n: sorted(a, key=_std_order_key(a)) for n, a in answers.items()}))
    expected = (path / "expected.txt").read_text()
    got = render(goals, snaps)
    assert _normalise(got) == _normalise(expected)


def _std_order_key(_answers):
    return lambda text: text


def _normalise(text: str):
    """Compare answer sets per checkpoint and query, independent of Python vs Prolog sorting."""
    blocks, current, key = {}, None, None
    for line in text.splitlines():
        if line.startswith("% checkpoint"):
            current = line
        elif line.startswith("% query"):
            key = (current, line)
            blocks[key] = set()
        else:
            blocks[key].add(line)
    return blocks


def _run_aq(tmp_path, program: str, script: str, mode: str):
    (tmp_path / "program.pl").write_text(program)
    (tmp_path / "updates.txt").write_text(script)
    args = ["aq", str(tmp_path / "program.pl"), "--script", str(tmp_path / "updates.txt"), "--mode", mode]
    return CliRunner().invoke(main, args, catch_exceptions=False)


@pytest.mark.parametrize("mode", ["naive", "optimized", "tabled"])
def test_runtime_failure_exits_1_with_one_line(tmp_path, mode):
    """A well-formed script line that fails while it runs (here `is` on an atom) is a runtime
    failure: exit status 1 and one line naming the script line, after the events printed so far."""
    program = ":- dynamic e/1.\nt(Y) :- e(X), Y is X + 1.\ne(1).\n"
    result = _run_aq(tmp_path, program, "?q t(A).\n+e(a).\n+e(2).\n", mode)
    assert result.exit_code == 1, result.stderr
    assert result.stdout == '{"query": "q", "op": "answer", "answer": "t(2)"}\n'
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"{tmp_path / 'updates.txt'}:2: runtime error: ")
    assert "evaluable" in lines[0] or "Arithmetic" in lines[0], lines[0]


@pytest.mark.parametrize("script,message", [
    ("?q nosuch(A).\n", "nosuch/1"),
    ("?q t(A).\n?q t(B).\n", "register"),
    ("+t(1).\n", "t/1"),
    ("!r.\n", "r"),
    ("*e(1).\n", "unknown command"),
])
def test_bad_script_line_exits_2(tmp_path, script, message):
    program = ":- dynamic e/1.\nt(Y) :- e(Y).\ne(1).\n"
    result = _run_aq(tmp_path, program, script, "tabled")
    assert result.exit_code == 2, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and ": error: " in lines[0] and message in lines[0], result.stderr
