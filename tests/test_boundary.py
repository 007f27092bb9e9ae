"""The boundary of untrusted goals (issue 35: repros 1-4, 6, 12, 13 and the printer of 16):
every road that takes a goal (queries, subscription and memory conditions, added rules and
control lines, from Python, the command line and `swipl OUT.pl`) refuses what could run code,
block, catch the runtime's limits or stop a run, and reports errors of untrusted code with a
printer that never interprets them. Each exploit tries to create a canary file; the file must
not exist afterwards and the engine must go on working."""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.bridge import PrologError
from retalisc.driver.engine import Engine, QueryError

ROOT = Path(__file__).resolve().parent.parent
FIRE = ROOT / "examples" / "fire_alarm"

PROGRAM = """
located(s1, kitchen).
located(s2, kitchen).
nearby(A, B) :- located(A, R), located(B, R).
swallow(G) :- catch(G, _, true).
r1 : fire(S) <- smoke(S) seq heat(S).
"""

# Goals that ran a shell command (or would have) before the boundary: {c} is the canary.
CODE_EXECUTION = [
    'print_message(error, format("~@", [shell("touch {c}")]))',                      # repro 1
    'message_to_codes(format("~@", [shell("touch {c}")]), [], _)',
    'format(atom(_), "~@", [shell("touch {c}")])',
    'format(atom(_), "~W", ["touch {c}", [portray_goal(shell)]])',                    # repro 3
    'F = "~W", format(atom(_), F, ["touch {c}", [portray_goal(shell)]])',              # known when it runs
    'atom_codes(F, "~~@"), format(F, [shell("touch {c}")])',
    'write_term("touch {c}", [portray_goal(shell)])',
    'with_output_to(string(_), print_message(error, format("~@", [shell("touch {c}")])))',
    'put_attr(Y, freeze, shell("touch {c}")), Y = 1',                                # repro 4
    'freeze(Y, shell("touch {c}")), Y = 1',
    'dif(Y, a), when(nonvar(Y), shell("touch {c}")), Y = 1',
    'maplist([X]>>shell(X), ["touch {c}"])',
    'setup_call_cleanup(true, true, shell("touch {c}"))',
]


def canary_goals(tmp_path):
    canary = tmp_path / "pwned"
    return canary, [g.format(c=canary) for g in CODE_EXECUTION]


@pytest.fixture
def engine():
    e = Engine.from_source(PROGRAM, "boundary.rtl")
    e.set_flag("max_delay", "inf")
    e.set_flag("echo_input", "false")
    return e


def still_works(engine: Engine, t: float) -> None:
    assert engine.query("nearby(s1, X)") == {"X": "s1"}
    assert [o.event for o in engine.feed_batch([("smoke(s1)", t), ("heat(s1)", t + 1)])] == ["fire(s1)"]


# ---- the query road, in process -----------------------------------------------------------

@pytest.mark.parametrize("goal", CODE_EXECUTION)
def test_a_query_cannot_run_code(engine, tmp_path, goal):
    canary = tmp_path / "pwned"
    with pytest.raises(QueryError) as refused:
        engine.query(goal.format(c=canary))
    assert refused.value.kind in ("unsafe", "failed"), refused.value
    assert not canary.exists()
    still_works(engine, 1)


def test_an_error_thrown_by_a_query_is_printed_not_interpreted(engine, tmp_path):
    """Repro 2: the error text of a thrown term never runs its `~@` goal."""
    canary = tmp_path / "pwned"
    for goal in (f'throw(error(format("~@", [shell("touch {canary}")]), _))',
                 f'throw(format("~@", [shell("touch {canary}")]))',
                 f'atom_length(abc, format("~@", [shell("touch {canary}")]))'):
        with pytest.raises(QueryError) as failed:
            engine.query(goal)
        assert failed.value.kind == "failed"
        assert "shell" in failed.value.message                     # shown as data, with ~q
    assert not canary.exists()
    still_works(engine, 1)


def test_aborted_from_a_query_keeps_the_engine(engine):
    """Repro 6: '$aborted' neither ends the Engine's Prolog thread nor passes the guard."""
    for goal in ("throw('$aborted')", "X = '$aborted', throw(X)", "atom_concat('$abort', ed, X), throw(X)",
                 "X = time_limit_exceeded, throw(X)", "throw(unwind(abort))"):
        with pytest.raises(QueryError, match="No permission to throw reserved_ball") as refused:
            engine.query(goal)
        assert refused.value.kind == "failed"
    still_works(engine, 1)
    assert engine.query_all("located(S, kitchen)") == [{"S": "s1"}, {"S": "s2"}]


@pytest.mark.parametrize("goal", [
    "catch(sleep(100), _, true), sleep(100)",                      # repro 12 (sleep is refused)
    "catch(repeat, _, true), fail",                                # a busy loop that catches
    "catch((repeat, fail), E, true), E == x",
    "catch(catch((between(1, inf, _), fail), time_limit_exceeded, true), _, true)",
    "catch((repeat, fail), error(_, _), true)",
])
def test_a_query_cannot_catch_its_time_limit(engine, goal):
    engine.set_flag("query_time_limit", "0.5")
    started = time.monotonic()
    with pytest.raises(QueryError) as stopped:
        engine.query(goal)
    assert time.monotonic() - started < 5
    assert stopped.value.kind in ("unsafe", "failed")
    if stopped.value.kind == "failed":
        assert "time limit" in stopped.value.message
    still_works(engine, 1)


def test_a_program_predicate_that_catches_everything_is_refused(engine):
    """A program predicate reached from a query is walked as the query is: its catch/3 of
    anything cannot be guarded there, so it is refused (it would catch the time limit)."""
    with pytest.raises(QueryError, match=r"catch/3 .*runtime's limits.*\(reached from swallow/1\)"):
        engine.query("swallow((repeat, fail))")
    assert engine.query("catch(atom_length(1, _), error(type_error(_, _), _), true)") == {}
    assert engine.query("catch(throw(mine), mine, true)") == {}
    assert engine.query("catch(throw(mine), B, true)") == {"B": "mine"}


@pytest.mark.parametrize("goal, message", [
    ("sleep(1)", "sleep/1"),
    ("read(_)", "read/1"),
    ("thread_create(true, _, [])", "thread_create/3"),
    ("thread_get_message(_)", "thread_get_message/1"),
    ("nb_setval(rtl_clock, 0)", "nb_setval/2"),
    ("b_setval(x, 0)", "b_setval/2"),
    ("format(user_error, \"x\", [])", "format/3 writing to user_error"),
    ("with_output_to(user_error, true)", "with_output_to/2 writing to user_error"),
    ("call_cleanup(true, true)", "call_cleanup/2"),
    ("format(\"~p\", [x])", "format/2 with the directive ~p"),
    ("tab(user_error, 1)", "tab/2"),
])
def test_blocking_and_outside_builtins_are_refused(engine, goal, message):
    with pytest.raises(QueryError, match="unsafe goal: " + message.replace("(", r"\(")) as refused:
        engine.query(goal)
    assert refused.value.kind == "unsafe"


def test_what_queries_do_still_runs(engine):
    assert engine.query("format(atom(A), \"~w-~a ~d~n\", [x, y, 3])") == {"A": "'x-y 3\\n'"}
    assert engine.query("F = \"~w\", format(atom(A), F, [x])")["A"] == "x"       # guarded, allowed
    assert engine.query("catch(X is 1/0, error(evaluation_error(E), _), true)")["E"] == "zero_divisor"
    assert engine.query("catch(throw(f(1)), f(N), true)") == {"N": "1"}
    assert engine.query("findall(X-Y, (member(X, [1, 2]), succ(X, Y)), L)")["L"] == "[1-2,2-3]"
    assert engine.query("maplist([X, Y]>>(Y is X * 2), [1, 2], L)")["L"] == "[2,4]"
    assert engine.query("aggregate_all(count, nearby(_, _), N)") == {"N": "4"}
    assert engine.query("with_output_to(string(S), (write(a), print(b)))") == {"S": '"ab"'}


# ---- subscriptions, memories, added rules, in process --------------------------------------

def test_subscription_and_memory_conditions_cannot_run_code(engine, tmp_path):
    """Each exploit is refused when it is given, or (a format string only known when it
    runs) refused by its guard when the event comes."""
    canary, goals = canary_goals(tmp_path)
    accepted = 0
    for i, goal in enumerate(goals):
        for give, text in ((engine.subscribe, f"[{goal}]"), (engine.subscribe_query, f"smoke(X)-[{goal}]"),
                           (engine.memory, f"c_mem(m{i}, smoke(_)-[{goal}], 5, inf)"),
                           (engine.add_rules, f"alarm(X) <- smoke(X) where ({goal})."),
                           (engine.add_rules, f"null do ({goal}) <- smoke(_).")):
            try:
                if give == engine.subscribe:
                    give("ops", "smoke(X)", conditions_text=text)
                elif give == engine.subscribe_query:
                    give("ops", text)
                else:
                    give(text)
                accepted += 1
            except (PrologError, QueryError) as refused:
                assert "unsafe goal" in str(refused), refused
    assert accepted <= 10                                  # the two goals known when they run
    _, rejected = engine.feed_lines('{"event": "smoke(s1)", "t": 1}\n{"event": "smoke(s2)", "t": 2}\n')
    assert rejected and all("No permission to use format_directive `'~W''" in r.reason for r in rejected), rejected
    assert not canary.exists()
    assert engine.query("nearby(s1, X)") == {"X": "s1"}
    assert [o.event for o in engine.feed_batch([("other(s2)", 3)])] == []


def test_an_error_raised_in_an_added_rule_is_printed_not_interpreted(engine, tmp_path):
    """Repro 2 on the event road: an added rule's condition and action throw a term whose
    message would run a goal; the event fails (or the action warns) and nothing runs."""
    canary = tmp_path / "pwned"
    ball = f'error(format("~@", [shell("touch {canary}")]), _)'
    engine.add_rules(f"alarm(X) <- smoke(X) where throw({ball}).\n"
                     f"null do throw({ball}) <- heat(_).")
    engine.subscribe("ops", "smoke(X)", conditions_text=f"[throw({ball})]")
    engine.memory(f"c_mem(m, smoke(_)-[throw({ball})], 5, inf)")
    _, rejected = engine.feed_lines('{"event": "smoke(s1)", "t": 1}\n{"event": "heat(s2)", "t": 2}\n')
    assert [r.line for r in rejected] == [1]
    assert "Unknown error term: format(" in rejected[0].reason
    assert not canary.exists()


def test_an_added_rule_cannot_catch_the_step_limit(engine):
    """The step limit is not caught by the condition's own catch/3: the event fails with the
    limit's message and the next one is processed."""
    engine.set_flag("max_steps", "100000")
    engine.add_rules("loop(X) <- trig(X) where catch((repeat, fail), _, true).")
    _, rejected = engine.feed_lines('{"event": "trig(1)", "t": 1}\n{"event": "smoke(s1)", "t": 2}\n'
                                    '{"event": "heat(s1)", "t": 3}\n')
    assert [r.line for r in rejected] == [1]
    assert "more than 100,000 steps (--max-steps)" in rejected[0].reason


def test_sleep_in_a_condition_is_refused(engine):
    """Repro 13: `where sleep(20)` held each event 20 s; the step limit counts inferences."""
    with pytest.raises(PrologError, match="unsafe goal: sleep/1"):
        engine.add_rules("slow(X) <- smoke(X) where sleep(20).")
    with pytest.raises(PrologError, match="unsafe goal: sleep/1"):
        engine.subscribe("ops", "smoke(X)", conditions_text="[sleep(20)]")


def test_error_text_is_bounded_and_the_step_limit_reads_well(engine):
    """Repro 16 (the printer): a 300,000-element list in an error gives a short line; the step
    limit from the Python API is `more than N steps`, not `Unknown error term`."""
    engine.add_rules("big(X) <- smoke(X) where (numlist(1, 300000, L), throw(L)).")
    _, rejected = engine.feed_lines('{"event": "smoke(s1)", "t": 1}\n')
    assert len(rejected) == 1 and len(rejected[0].reason) < 2500
    assert "Unhandled exception: [1,2,3" in rejected[0].reason
    with pytest.raises(QueryError) as failed:
        engine.query("numlist(1, 300000, L), atom_length(f(L), _)")
    assert len(failed.value.message) < 2500
    engine.set_flag("max_steps", "1000")
    engine.add_rules("deep(X) <- heat(X) where (between(1, inf, _), fail).")
    _, rejected = engine.feed_lines('{"event": "heat(s2)", "t": 3}\n')
    assert "more than 1,000 steps (--max-steps)" in rejected[0].reason
    with pytest.raises(PrologError, match=r"more than 1,000 steps \(--max-steps\)"):
        engine.feed("heat(s3)", 4)


# ---- the command line and swipl OUT.pl ------------------------------------------------------

def cli(*args, cwd=None, timeout=120):
    return subprocess.run([sys.executable, "-m", "retalisc", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=cwd, env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})


def test_cli_query_and_run_query_refuse_and_go_on(tmp_path):
    canary = tmp_path / "pwned"
    program, events = FIRE / "fire_alarm.rtl", FIRE / "events.jsonl"
    q = cli("query", program, "--events", events, f'print_message(error, format("~@", [shell("touch {canary}")]))')
    assert q.returncode != 0 and "unsafe goal: print_message/2" in q.stderr
    run = cli("run", program, "--events", events, "--query", "5", "throw('$aborted')")
    assert not canary.exists()
    assert "fire" in run.stdout, run.stderr                 # the run's output is written
    assert "No permission to throw reserved_ball" in run.stdout       # the query's answer line
    bad = cli("run", program, "--events", events, "--query", "6", f'put_attr(Y, freeze, shell("touch {canary}")), Y = 1')
    assert bad.returncode == 2 and "unsafe goal: put_attr/3" in bad.stderr
    sub = cli("run", program, "--events", events,
              "--subscribe", f'ops=smoke(S)-[format(atom(_), "~W", ["touch {canary}", [portray_goal(shell)]])]')
    assert sub.returncode == 2 and "unsafe goal: format/2 with the directive ~W" in sub.stderr
    assert not canary.exists()


def test_cli_memory_and_swipl_control_lines(tmp_path, swipl):
    canary = tmp_path / "pwned"
    program, events = FIRE / "fire_alarm.rtl", FIRE / "events.jsonl"
    run = cli("run", program, "--events", events,
              "--memory", f'c_mem(m, smoke(_)-[freeze(Y, shell("touch {canary}")), Y = 1], 5, inf)')
    assert run.returncode != 0 and "unsafe goal: freeze/2" in run.stderr
    compiled = tmp_path / "p.pl"
    compiled.write_text(compile_source(program.read_text(encoding="utf-8"), str(program)).prolog, encoding="utf-8")
    ball = f'error(format("~@", [shell("touch {canary}")]), _)'
    lines = [json.dumps({"op": "add_rule", "rule": f"alarm(X) <- smoke(X) where throw({ball})."}),
             json.dumps({"op": "add_rule", "rule": f'null do print_message(error, format("~@", [shell("touch {canary}")])) <- smoke(_).'}),
             json.dumps({"op": "add_rule", "rule": "null do throw('$aborted') <- high_temperature(_)."}),
             json.dumps({"op": "add_rule", "rule": "slow(X) <- smoke(X) where sleep(20)."}),
             *events.read_text(encoding="utf-8").splitlines()]
    feed = tmp_path / "in.jsonl"
    feed.write_text("\n".join(lines) + "\n", encoding="utf-8")
    started = time.monotonic()
    out = subprocess.run([swipl, str(compiled), "--allow-control", str(feed)], capture_output=True, text=True,
                         timeout=120)
    assert time.monotonic() - started < 60
    assert not canary.exists()
    assert "fire" in out.stdout, out.stderr
    assert "unsafe goal: print_message/2" in out.stderr
    assert "No permission to throw reserved_ball" in out.stderr
    assert "unsafe goal: sleep/1" in out.stderr


def test_error_printer_and_guards_plunit(swipl):
    """rtl_error_text.pl (the one printer: never interprets, bounded, SWI-Prolog's words for
    the known forms) and rtl_guard.pl (catch/throw/format guards)."""
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_error_text.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0 and "ERROR" not in proc.stdout and "Warning" not in proc.stdout, proc.stdout
