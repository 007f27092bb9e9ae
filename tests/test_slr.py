"""SLR semantics (thesis 4.2.2-4.2.4, Def. 16-24) through the Python API and `retalisc query`:
cases that do not fit the golden format (program, events, derived output). The golden
cases tests/golden/slr_prev_next_select and tests/golden/slr_memory_events cover
unification-based selection, end-time order and memory events; tests/test_slr_oracle.py
compares everything against a brute-force model on random streams. The plunit suite
prolog_runtime/tests/test_slr.pl (rtl_slr internals) is run from here too."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine, QueryError

ROOT = Path(__file__).resolve().parent.parent


def _engine(program: str) -> Engine:
    return Engine.from_source(program, "slr_test.rtl")


def _values(answers, *names):
    return [tuple(a[n] for n in names) for a in answers]


# ---- selection by unification, order, bounds ----------------------------------------------

def test_prev_and_next_skip_records_that_do_not_unify():
    e = _engine("c_mem(tf, tf(_, _, _)-[], inf, inf).\n")
    e.feed_batch([("tf(a, b, 1)", 1), ("tf(a, c, 2)", 2), ("tf(a, b, 3)", 3), ("tf(a, c, 4)", 4)])
    assert e.query("prev(tf, tf(a, b, V)^T, 4)") == {"V": "3", "T": "3"}      # not tf(a, c, 4)
    assert e.query("prev(tf, tf(a, c, V)^T, 3.5)") == {"V": "2", "T": "2"}
    assert e.query("next(tf, tf(a, c, V)^T, 2.5, inf)") == {"V": "4", "T": "4"}
    assert e.query("next(tf, tf(a, b, V)^T, 1.5, inf)") == {"V": "3", "T": "3"}  # not tf(a, c, 2)
    assert e.query("prev(tf, E, 4)") == {"E": "tf(a,c,4)"}
    assert e.query("next(tf, tf(a, b, V)^T, 3.5, inf)") is None
    # a bound value unifies too: the latest record whose value is 1, far back
    assert e.query("prev(tf, tf(A, B, 1)^T, 10)") == {"A": "a", "B": "b", "T": "1"}
    # prev/next for one instance give one answer
    assert len(e.query_all("prev(tf, tf(a, _, V), 10)")) == 1
    assert len(e.query_all("next(tf, tf(a, _, V), 0, 10)")) == 1


def test_bounds_are_inclusive():
    e = _engine("c_mem(m, x(_)-[], inf, inf).\n")
    e.feed_batch([("x(1)", 1), ("x(2)", 2), ("x(3)", 3)])
    assert e.query("prev(m, x(V), 2)") == {"V": "2"}          # a record ending exactly at Zs counts
    assert e.query("prev(m, x(V), 1.99)") == {"V": "1"}
    assert e.query("next(m, x(V), 2, 3)") == {"V": "2"}       # ... at Zs
    assert e.query("next(m, x(V), 2.5, 3)") == {"V": "3"}     # ... at Ze
    assert e.query("next(m, x(V), 3, 3)") == {"V": "3"}
    assert e.query("next(m, x(V), 2.1, 2.9)") is None
    assert e.query("next(m, x(V), 3, 2)") is None              # an empty interval
    assert e.query("prev(m, x(V), 0.5)") is None
    assert _values(e.query_all("mem(m, x(V))", at=2), "V") == [("1",), ("2",)]


def test_interval_records_and_their_time_terms():
    e = _engine("c_mem(m, x(_)-[], inf, inf).\n")
    e.feed_batch([("x(1)", 1, 4), ("x(2)", 3, 3)])
    assert _values(e.query_all("mem(m, x(V)^[S, T])"), "V", "S", "T") == [("2", "3", "3"), ("1", "1", "4")]
    assert e.query_all("mem(m, x(V)^3)") == [{"V": "2"}]      # E^T: T is the end time,
    assert e.query_all("mem(m, x(V)^4)") == [{"V": "1"}]      # as `E^T` in event patterns
    assert e.query("prev(m, x(V)^T, 4)") == {"V": "1", "T": "4"}
    assert e.query("prev(m, x(V)^[S, T], 4)") == {"V": "1", "S": "1", "T": "4"}
    assert e.query("prev(m, x(V)^[S, 3], 4)") == {"V": "2", "S": "3"}


def test_out_of_order_arrivals_keep_end_time_order_and_the_count_forgets_the_oldest_by_end():
    e = _engine("c_mem(m, x(_)-[], 3, inf).\n")
    e.feed_batch([("x(5)", 5), ("x(9)", 9), ("x(7)", 7)])
    assert _values(e.query_all("mem(m, x(V)^T)"), "T") == [("5",), ("7",), ("9",)]
    e.feed_batch([("x(8)", 8)])          # arrives last, but x(5) is the one forgotten
    assert _values(e.query_all("mem(m, x(V)^T)"), "T") == [("7",), ("8",), ("9",)]
    e.feed_batch([("x(3)", 3)])          # older than all three: forgotten at once
    assert _values(e.query_all("mem(m, x(V)^T)"), "T") == [("7",), ("8",), ("9",)]
    e.feed_batch([("x(6)", 6)])
    assert _values(e.query_all("mem(m, x(V)^T)"), "T") == [("7",), ("8",), ("9",)]
    e.feed_batch([("x(8)", 8, 8, "retract")])    # frees a place: x(6) or x(5) do not come back
    assert _values(e.query_all("mem(m, x(V)^T)"), "T") == [("7",), ("9",)]
    e.feed_batch([("x(8)", 8, 8, "retract")])    # nothing (left) to retract
    assert _values(e.query_all("mem(m, x(V)^T)"), "T") == [("7",), ("9",)]


def test_equal_end_times_keep_arrival_order():
    e = _engine("c_mem(m, x(_)-[], 2, inf).\n")
    e.feed_batch([("x(1)", 5), ("x(2)", 6), ("x(3)", 5)])      # x(3) late, after x(1) at 5
    assert _values(e.query_all("mem(m, x(V))"), "V") == [("3",), ("2",)]
    assert e.query("prev(m, x(V), 5)") == {"V": "3"}


def test_at_view_bounds_mem_but_not_prev_and_next():
    e = _engine("c_mem(m, x(_)-[], inf, inf).\n")
    e.feed_batch([("x(1)", 1), ("x(2)", 2), ("x(3)", 3), ("x(4)", 4, 5)])
    assert _values(e.query_all("mem(m, x(V))", at=2), "V") == [("1",), ("2",)]
    assert _values(e.query_all("mem(m, x(V))", at=4.5), "V") == [("1",), ("2",), ("3",)]   # by end time
    assert e.query_all("mem(m, x(V))", at=0) == []
    assert e.query("prev(m, x(V), 10)", at=2) == {"V": "4"}
    assert e.query("next(m, x(V), 2.5, inf)", at=2) == {"V": "3"}
    assert e.query("findall(_V, mem(m, x(_V)), L)", at=3) == {"L": "[1,2,3]"}


def test_time_limits_forget_by_the_clock():
    e = _engine("c_mem(recent, pos(_, _)-[], inf, 2).\n")
    e.feed_batch([("pos(r, 1)", 1), ("pos(r, 2)", 2), ("pos(r, 3)", 3), ("pos(r, 4)", 4)])
    assert _values(e.query_all("mem(recent, pos(_, X))"), "X") == [("2",), ("3",), ("4",)]   # end >= 4 - 2
    e.feed_batch([("pos(r, 9)", 1.5)])       # late and already outside the limit: not kept
    assert _values(e.query_all("mem(recent, pos(_, X))"), "X") == [("2",), ("3",), ("4",)]
    e.feed_batch([("pos(r, 8)", 2.5)])       # late but inside: kept, in its place
    assert _values(e.query_all("mem(recent, pos(_, X))"), "X") == [("2",), ("8",), ("3",), ("4",)]
    e.feed_batch([("other", 5.5)])           # the clock moves with any event
    assert _values(e.query_all("mem(recent, pos(_, X))"), "X") == [("4",)]
    assert e.query("prev(recent, pos(_, X), 3)") is None
    assert e.query("next(recent, pos(_, X), 0, inf)") == {"X": "4"}


# ---- several instances, ids, templates ----------------------------------------------------

PROGRAM_INSTANCES = """
c_mem(obj(cup), seen(O, _)-[O == cup], 2, inf).
c_mem(obj(box), seen(O, _)-[O == box], inf, inf).
memorize(seen(O, P), [P > 0], at(P, O), right, 1).
c_mem(all, seen(_, _)-[], inf, inf).
"""


def test_several_instances_over_one_event_type():
    e = _engine(PROGRAM_INSTANCES)
    e.feed_batch([("seen(cup, 1)", 1), ("seen(box, -2)", 2), ("seen(cup, 3)", 3), ("seen(cup, -4)", 4),
                  ("seen(box, 5)", 5)])
    assert _values(e.query_all("mem(obj(cup), seen(_, P))"), "P") == [("3",), ("-4",)]
    assert _values(e.query_all("mem(obj(box), seen(_, P))"), "P") == [("-2",), ("5",)]
    assert e.query_all("mem(right, E)") == [{"E": "at(5,box)"}]          # its template, its size
    assert len(e.query_all("mem(all, _)")) == 5
    # an unbound id enumerates the instances, in creation order, each oldest first
    assert _values(e.query_all("mem(Id, seen(_, P))"), "Id", "P") == [
        ("obj(cup)", "3"), ("obj(cup)", "-4"), ("obj(box)", "-2"), ("obj(box)", "5"),
        ("all", "1"), ("all", "-2"), ("all", "3"), ("all", "-4"), ("all", "5")]
    assert _values(e.query_all("mem(obj(O), seen(_, P))", at=3), "O", "P") == [("cup", "3"), ("box", "-2")]
    # prev/next with an unbound id: one answer per instance
    assert _values(e.query_all("prev(Id, seen(_, P), 4.5)"), "Id", "P") == [
        ("obj(cup)", "-4"), ("obj(box)", "-2"), ("all", "-4")]
    assert _values(e.query_all("next(obj(O), seen(_, P), 2, inf)"), "O", "P") == [("cup", "3"), ("box", "-2")]
    assert _values(e.query_all("exist_mem(Id)"), "Id") == [("obj(cup)",), ("obj(box)",), ("right",), ("all",)]


def test_d_mem_deletes_the_instances_that_match_and_new_ones_start_empty():
    e = _engine(PROGRAM_INSTANCES)
    e.feed_batch([("seen(cup, 1)", 1), ("seen(box, 2)", 2)])
    e.memory("d_mem(obj(_))")
    assert _values(e.query_all("exist_mem(Id)"), "Id") == [("right",), ("all",)]
    assert e.query_all("mem(obj(_), _)") == []
    e.memory("c_mem(obj(cup), seen(cup, _)-[], inf, inf)")
    assert e.query_all("mem(obj(cup), _)") == []                   # records are not inherited
    e.feed_batch([("seen(cup, 7)", 7)])
    assert e.query_all("mem(obj(cup), E)") == [{"E": "seen(cup,7)"}]
    with pytest.raises(QueryError, match="exists"):
        e.memory("c_mem(all, seen(_, _)-[], 1, inf)")
    e.memory("delete_memory(right)")
    assert e.query("exist_mem(right)") is None


@pytest.mark.parametrize("goal", ["mem(nope, E)", "prev(nope, E^T, 5)", "next(nope, E, 0, inf)",
                                  "access_mem(nope, E, I)", "prev(nope, E, T1, T2, 5)", "next_inf(nope, E, S, T, 0)",
                                  "X = 1, ( prev(nope, E, 5) ; true )"])
def test_a_query_on_an_unknown_or_deleted_memory_is_an_error_naming_it(goal):
    e = _engine(PROGRAM_INSTANCES)
    e.feed_batch([("seen(cup, 1)", 1)])
    for ask in (e.query, e.query_all, lambda g: e.query_synchronized(g, 5), lambda g: e.post_synchronized(g, 5)):
        with pytest.raises(QueryError, match="no memory instance nope") as raised:
            ask(goal)
        assert raised.value.kind == "failed"
    assert e.query("mem(right, E)") is not None
    e.memory("d_mem(right)")                                      # deleted: the same error
    with pytest.raises(QueryError, match="no memory instance right"):
        e.query_all(goal.replace("nope", "right"))
    assert e.query_all("mem(_, seen(box, _))") == []              # an id not given: no error


def test_memory_events_reach_rules_and_memories_follow_do_actions():
    e = _engine("""
null do c_mem(obj(O), seg(X, P)-[X == O], 1, inf) <- seen(O) where \\+ exist_mem(obj(O)).
null do d_mem(obj(O)) <- lost(O).
created(Id) <- memory_created(_, _, _, Id, _).
deleted(Id) <- memory_deleted(Id).
seen_update(Id) <- memory_updated(Id, T).
""")
    out = e.feed_batch([("seg(cup, 1)", 1), ("seen(cup)", 2), ("seg(cup, 2)", 3), ("seg(cup, 3)", 4),
                        ("seen(cup)", 5)])
    assert [(o.event, o.end) for o in out] == [("created(obj(cup))", 2), ("seen_update(obj(cup))", 3),
                                               ("seen_update(obj(cup))", 4)]
    assert e.query_all("mem(obj(cup), seg(_, P))") == [{"P": "3"}]
    out = e.feed_batch([("lost(cup)", 6), ("seg(cup, 4)", 7)])
    assert [(o.event, o.end) for o in out] == [("deleted(obj(cup))", 6)]
    assert e.query("exist_mem(obj(cup))") is None


# ---- errors, spellings, stream forms -----------------------------------------------------

@pytest.mark.parametrize("goal", ["prev(m, E, Z)", "next(m, E, 1, Ze)", "next(m, E, Zs, inf)",
                                  "prev(m, E, _, _, Z)", "next_inf(m, E, _, _, Z)", "prev(x(_), Z)",
                                  "next(x(_), Zs, 3)"])
def test_an_unbound_time_argument_is_an_instantiation_error(goal):
    e = _engine("c_mem(m, x(_)-[], inf, inf).\nuses(T) :- prev(x(_), T).\n")
    e.feed_batch([("x(1)", 1)])
    with pytest.raises(QueryError) as raised:
        e.query(goal)
    assert raised.value.kind == "failed"
    assert "not sufficiently instantiated" in raised.value.message
    assert "time arguments of prev and next must be bound" in raised.value.message


def test_retalis_2015_spellings():
    e = _engine("memorize(pos(R, X), [X > 0], at(R, X), right, 2).\n")
    e.feed_batch([("pos(r1, 1)", 1), ("pos(r2, -1)", 2), ("pos(r1, 2)", 3, 4), ("pos(r2, 3)", 5)])
    assert _values(e.query_all("access_mem(right, at(R, X), [S, T])"), "R", "X", "S", "T") == [
        ("r1", "2", "3", "4"), ("r2", "3", "5", "5")]
    assert e.query("prev(right, at(r1, X), S, T, 10)") == {"X": "2", "S": "3", "T": "4"}
    assert e.query("prev(right, at(R, X), S, T, 4.5)") == {"R": "r1", "X": "2", "S": "3", "T": "4"}
    assert e.query("next(right, at(R, X), S, T, 4.5, 5)") == {"R": "r2", "X": "3", "S": "5", "T": "5"}
    assert e.query("next(right, at(R, X), S, T, 5.5, 9)") is None
    assert e.query("next_inf(right, at(R, X), S, 5, 0)") == {"R": "r2", "X": "3", "S": "5"}
    e.memory("delete_memory(right)")
    assert e.query("exist_mem(right)") is None


def test_stream_forms_read_the_history_of_the_event_type():
    e = _engine("""
color(O, C)^T :- prev(obj(O, C)^_, T).
first_after(O, C, T) :- next(obj(O, C)^T, [0, inf]).
""")
    e.feed_batch([("obj(cup, red)", 1), ("obj(box, green)", 2), ("obj(cup, blue)", 3)])
    assert e.query("prev(obj(cup, C)^T, 2.5)") == {"C": "red", "T": "1"}
    assert e.query("prev(obj(O, C), 10)") == {"O": "cup", "C": "blue"}
    assert e.query("next(obj(O, C)^T, 1.5, 3)") == {"O": "box", "C": "green", "T": "2"}
    assert e.query("next(obj(cup, C)^T, 1.5, inf)") == {"C": "blue", "T": "3"}
    assert e.query("next(obj(cup, C)^T, [1.5, 2.5])") is None
    assert e.query("color(box, C)^10") == {"C": "green"}
    assert e.query("first_after(cup, C, T)") == {"C": "red", "T": "1"}
    with pytest.raises(QueryError, match="stream_history"):
        e.query("prev(seg(_), 3)")                      # no history kept for seg/1
    with pytest.raises(QueryError, match="interval"):
        e.query("next(obj(_, _), 3)")
    assert e.query_all("mem(Id, _)") == []              # the histories are no memory instances


def test_a_declared_stream_history_bounds_the_history():
    e = _engine("stream_history(obj/2, 2, inf).\nc(T) :- prev(obj(_, _), T).\n")
    e.feed_batch([("obj(a, 1)", 1), ("obj(b, 2)", 2), ("obj(c, 3)", 3)])
    assert e.query("next(obj(O, _), 0, inf)") == {"O": "b"}       # obj(a, 1) forgotten
    assert e.query("prev(obj(a, _), 10)") is None


# ---- retalisc query ----------------------------------------------------------------------

def _query(tmp_path, *args):
    program = tmp_path / "p.rtl"
    program.write_text("c_mem(tf, tf(_, _, _)-[], inf, inf).\n")
    events = tmp_path / "e.jsonl"
    events.write_text('{"event": "tf(a, b, 1)", "t": 1}\n{"event": "tf(a, c, 2)", "t": 2}\n'
                      '{"event": "tf(a, b, 3)", "start": 2.5, "end": 3}\n')
    return subprocess.run([sys.executable, "-m", "retalisc", "query", str(program), "--events", str(events),
                           *args], capture_output=True, text=True, timeout=120)


def test_cli_query_answers_and_exit_codes(tmp_path):
    run = _query(tmp_path, "prev(tf, tf(a, b, V)^[S, T], 10)")
    assert run.returncode == 0, run.stderr
    assert [json.loads(line) for line in run.stdout.splitlines()] == [{"V": "3", "S": "2.5", "T": "3"}]

    run = _query(tmp_path, "--at", "2", "mem(tf, tf(_, B, V))")
    assert run.returncode == 0
    assert [json.loads(line) for line in run.stdout.splitlines()] == [{"B": "b", "V": "1"}, {"B": "c", "V": "2"}]
    run = _query(tmp_path, "--at", "2", "--first", "mem(tf, tf(_, B, V))")
    assert [json.loads(line) for line in run.stdout.splitlines()] == [{"B": "b", "V": "1"}]

    run = _query(tmp_path, "exist_mem(tf)")
    assert (run.returncode, run.stdout) == (0, "{}\n")           # a goal without variables

    run = _query(tmp_path, "prev(tf, tf(z, _, _), 10)")
    assert (run.returncode, run.stdout) == (0, "")               # a goal that fails


def test_cli_query_errors(tmp_path):
    run = _query(tmp_path, "prev(tf, E, ")
    assert run.returncode == 2 and run.stdout == ""
    assert "query:1:" in run.stderr and "syntax error" in run.stderr

    run = _query(tmp_path, "shell(ls)")
    assert run.returncode == 2 and run.stdout == ""
    assert "shell" in run.stderr

    run = _query(tmp_path, "prev(tf, E, Z)")
    assert run.returncode == 1 and run.stdout == ""
    assert "instantiated" in run.stderr

    run = _query(tmp_path, "--memory", "d_mem(tf)", "prev(tf, E, 10)")
    assert run.returncode == 1 and run.stdout == ""
    assert "no memory instance tf (never created, or deleted)" in run.stderr


# ---- plunit: rtl_slr internals ------------------------------------------------------------

def test_plunit_rtl_slr(tmp_path):
    program = tmp_path / "slr_host.pl"
    program.write_text(compile_source("host_rule(X) <- host_event(X).\n", "slr_host.rtl",
                                      module="slr_host").prolog)
    proc = subprocess.run(["swipl", "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_slr.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120,
                          env={**os.environ, "SLR_TEST_PROGRAM": str(program)})
    assert proc.returncode == 0, proc.stdout
