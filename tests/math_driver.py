"""Evaluates batches of goals on prolog_runtime/rtl_math.pl in one swipl subprocess, for the
property tests of the math builtins (tests/test_math.py, tests/test_retalis2015_builtins.py).

A goal text binds the variable `Out`; each goal gives ("ok", value), ("error", text) or
("fail", "")."""
from __future__ import annotations

import ast
import math
import subprocess
from pathlib import Path

MODULE = Path(__file__).resolve().parent.parent / "prolog_runtime" / "rtl_math.pl"

# Reads `Goal-Out.` terms from standard input and prints one line per term:
# "ok <writeq of Out>", "error <writeq of the exception>" or "fail".
DRIVER = r"""
run_cases :-
    repeat,
    read_term(user_input, T, []),
    (   T == end_of_file
    ->  !
    ;   T = Goal-Out,
        (   catch(Goal, E, true)
        ->  (   var(E)
            ->  format("ok ~q~n", [Out])
            ;   format("error ~q~n", [E])
            )
        ;   format("fail~n")
        ),
        fail
    ).
"""


def write_driver(directory: Path) -> Path:
    """Writes the driver program (loading rtl_math.pl) into `directory`; returns its path."""
    path = directory / "driver.pl"
    path.write_text(f":- use_module({str(MODULE)!r}).\n" + DRIVER)
    return path


def pl(x) -> str:
    """Prolog text of a number or a (nested) list of numbers (numpy values included)."""
    if isinstance(x, str):
        return x
    if hasattr(x, "tolist"):
        x = x.tolist()
    if isinstance(x, (list, tuple)):
        return "[" + ",".join(pl(e) for e in x) + "]"
    if isinstance(x, float):
        assert math.isfinite(x)
        return repr(x)
    return str(x)


def run(driver, goals: list[str]) -> list[tuple[str, object]]:
    """Evaluates each goal text (whose answer is the variable Out) in one swipl process."""
    swipl, path = driver
    text = "".join(f"({g})-Out.\n" for g in goals)
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_cases", "-t", "halt", str(path)],
                          input=text, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert len(lines) == len(goals), (proc.stdout, proc.stderr)
    out = []
    for line in lines:
        kind, _, rest = line.partition(" ")
        out.append((kind, ast.literal_eval(rest) if kind == "ok" else rest))
    return out


def answers(driver, goals: list[str]) -> list:
    """The value of Out for each goal; every goal must succeed."""
    results = run(driver, goals)
    for goal, (kind, value) in zip(goals, results):
        assert kind == "ok", f"{goal}: {kind} {value}"
    return [value for _, value in results]
