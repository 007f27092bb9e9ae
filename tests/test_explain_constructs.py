"""`retalisc explain` on one small program per construct of docs/language.md ("Patterns",
"Absence and timers", "Sliding aggregates by group", "Actions and raising events", and the
synchronized rules of slr.md): each
derived `h` is explained by its rule, and `--why-not` walks every part, so a construct the
explainer has no form for fails here rather than with a traceback for a user."""
from __future__ import annotations

import pytest
from click.testing import CliRunner

from retalisc.cli import main

EVENTS = "".join(f'{{"event": "{e}", "t": {t}}}\n' for e, t in
                 [("a(1)", 1), ("b(1)", 2), ("c(1)", 3), ("d(1)", 4), ("z", 20)])

INTERVALS = """\
ab(X) <- a(X) seq b(X).
ab2(X) <- a(X) seq b(X).
ac(X) <- a(X) seq c(X).
bc(X) <- b(X) seq c(X).
bd(X) <- b(X) seq d(X).
"""

CONSTRUCTS = {
    "event atom": ("h(X) <- a(X).", "h(_)"),
    "seq": ("h(X) <- a(X) seq b(X).", "h(_)"),
    "and": ("h(X) <- b(X) and a(X).", "h(_)"),
    "par": (INTERVALS + "h(X) <- ac(X) par bd(X).", "h(_)"),
    "or": ("h(X) <- q(X) or a(X).", "h(_)"),
    "equals": (INTERVALS + "h(X) <- ab(X) equals ab2(X).", "h(_)"),
    "meets": (INTERVALS + "h(X) <- ab(X) meets bc(X).", "h(_)"),
    "during": (INTERVALS + "h(X) <- b(X) during ac(X).", "h(_)"),
    "starts": (INTERVALS + "h(X) <- ab(X) starts ac(X).", "h(_)"),
    "finishes": (INTERVALS + "h(X) <- bc(X) finishes ac(X).", "h(_)"),
    "negation between": ("h(X) <- not(q(X)).[a(X), b(X)].", "h(_)"),
    "cnot": ("h(X) <- (a(X) seq b(X)) cnot q(X).", "h(_)"),
    "absence": ("h(X) <- not(q(X)).[a(X), 5].", "h(_)"),
    "fnot": ("h(X) <- b(X) fnot q(X).", "h(_)"),
    "where": ("h(X) <- a(X) where X > 0.", "h(_)"),
    "check": ("h(X) <- a(X) check (t1(T), T > 0).", "h(_)"),
    "timestamp": ("h(X) <- a(X) timestamp (t2(T), T > 0).", "h(_)"),
    "event_multiply": ("h(X, Y) <- a(X) event_multiply member(Y, [1, 2]).", "h(_, _)"),
    "star_times": ("h(X) <- a(X) seq b(X) star_times.", "h(_)"),
    "subpattern": ("h(X) <- a(X) seq (k(X) <- b(X)).", "h(_)"),
    "window": ("h(X) <- (a(X) seq b(X)).5.", "h(_)"),
    "time of an atom": ("h(X, T) <- a(X)^T.", "h(_, _)"),
    "interval of an atom": ("h(X, T1, T2) <- ab(X)^[T1, T2].\nab(X) <- a(X) seq b(X).", "h(_, _, _)"),
    "aggregate": ("h(V) <- a(X) seq aggregate(count, b(X), V).", "h(_)"),
    "sliding": ("h(X, N) <- sliding(count, b(X), X, 5, N).", "h(_, _)"),
    "sliding sum": ("h(X, N) <- sliding(sum(X), b(X), X, 5, N).", "h(_, _)"),
    "alarm": ("alarm(h(X), 2) <- a(X).", "h(_)"),
    "exceptionAlarm": ("exceptionAlarm(h(X), 2) <- a(X).", "h(_)"),
    "action": ("h(X) do true <- a(X).", "h(_)"),
    "action after": ("h(X) <- a(X) do true.", "h(_)"),
    "prolog seq": ("h(X) <- a(X) seq prolog(X > 0).", "h(_)"),
    "synchronized rule": ("c_mem(m, a(_)-[], 10, inf).\nsyncronized(h(X), prev(m, a(X)^_, T), [[m, T]]) <- b(_)^T.",
                          "h(_)"),
    "raised event": ("null do new_event(r(X)) <- a(X).\nh(X) <- r(X).", "h(_)"),
}


@pytest.mark.parametrize("construct", sorted(CONSTRUCTS))
def test_explain_and_why_not_handle_every_construct(construct, tmp_path):
    program, target = CONSTRUCTS[construct]
    (tmp_path / "p.rtl").write_text(program + "\n")
    (tmp_path / "ev.jsonl").write_text(EVENTS)
    base = ["explain", str(tmp_path / "p.rtl"), "--events", str(tmp_path / "ev.jsonl")]
    result = CliRunner().invoke(main, base + [target])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("h(") and "derived by rule" in result.stdout, result.stdout
    result = CliRunner().invoke(main, base + ["--why-not", target])
    assert result.exit_code == 0, result.output
    assert "derived event" in result.stdout and "every part matches" in result.stdout, result.stdout
