"""The two roads that rewrite the time terms of goals (`E^T`, `E^[T1, T2]`, thesis 4.2.3) rewrite
alike: the compiler's pass slr_time_terms for the program and the runtime's rtl_time_goal/2
(rtl_query.pl) for the queries from outside, both through the one table of goal arguments
prolog_runtime/rtl_goal_arguments.pl. Goals are generated over every construct of that table
and a few that are not in it (whose arguments stay as written), rewritten by both and compared
as Prolog terms; then the query `call(place(box, P)^5)`, refused before the runtime used the
table, answers like the program on each road a query takes. The plunit suite
prolog_runtime/tests/test_time_goal.pl (rtl_time_goal/2 case by case) is run from here too."""
import json
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine
from retalisc.frontend.goal_arguments import goal_arguments
from retalisc.frontend.terms import Atom, Compound, Number, Term, Var, make_list, to_prolog
from retalisc.passes.slr_time_terms import timed_goal

ROOT = Path(__file__).resolve().parent.parent
PLACE = ("place(box, P)^T :- prev(seen(box, P)^_, T).\n"
         "ok :- call(place(box, _)^5).\n")
SEEN = '{"event": "seen(box, shelf)", "t": 3}\n'

# Terms that take goals but are not in the table: the rewrite leaves their arguments alone.
OUTSIDE_THE_TABLE = [("catch", 3), ("setof", 3), ("not", 1), ("call", 2), ("prev", 3)]


@pytest.fixture(scope="module")
def engine():
    return Engine.from_source(PLACE, "place.rtl")


_variables = st.sampled_from([Var("X"), Var("Y"), Var("T"), Var("T2")])
_plain = st.one_of(
    st.sampled_from([Atom("q"), Atom("true"), Atom("!")]),
    st.builds(lambda v: Compound("p", (v,)), _variables),
    st.builds(lambda a, b: Compound("place", (a, b)), st.sampled_from([Atom("box"), Var("X")]), _variables))
_times = st.one_of(
    _variables, st.sampled_from([Number(5), Number(2.5)]),
    st.builds(lambda a, b: make_list([a, b]), _variables, _variables),          # E^[T1, T2]
    st.builds(lambda a: make_list([a]), _variables),                            # one item: a time
    st.builds(lambda a, tail: make_list([a], tail), _variables, _variables))    # a partial list
_time_terms = st.builds(lambda event, time: Compound("^", (event, time)),
                        st.one_of(_plain, st.sampled_from([Number(1), Var("E")])), _times)
_leaves = st.one_of(_plain, _time_terms, _variables)


def _construct(children):
    constructs = sorted(goal_arguments()) + OUTSIDE_THE_TABLE
    return st.sampled_from(constructs).flatmap(
        lambda key: st.tuples(*[children for _ in range(key[1])]).map(lambda args: Compound(key[0], args)))


_goals = st.recursive(_leaves, _construct, max_leaves=8)


def _rewrites_alike(engine: Engine, goal: Term) -> bool:
    program_road = to_prolog(timed_goal(goal))
    # Both texts are read in one goal, so that their variables of the same name are shared.
    return engine.bridge.once(f"Goal0 = ({to_prolog(goal)}), Program = ({program_road}), "
                              f"rtl_query:rtl_time_goal(Goal0, Query), Query == Program")


@settings(max_examples=150, deadline=None)
@given(goal=_goals)
def test_the_program_and_the_query_road_rewrite_alike(engine, goal):
    assert _rewrites_alike(engine, goal), to_prolog(goal)


@pytest.mark.parametrize("key", sorted(goal_arguments()), ids=lambda key: f"{key[0]}/{key[1]}")
def test_every_construct_of_the_table_is_entered_on_both_roads(engine, key):
    name, arity = key
    goal = Compound(name, tuple(Compound("^", (Compound("p", (Var(f"A{i}"),)), Var("T"))) for i in range(arity)))
    rewritten = timed_goal(goal)
    for i in range(arity):
        entered = i in goal_arguments()[key]
        assert (rewritten.args[i] == Compound("p", (Var(f"A{i}"), Var("T"), Var("T")))) == entered
    assert _rewrites_alike(engine, goal)


def test_the_table_is_read_from_the_runtime():
    assert goal_arguments()[("*->", 2)] == (0, 1) and goal_arguments()[("aggregate_all", 4)] == (2,)
    assert ("setof", 3) not in goal_arguments()        # its `^` quantifies variables


# ---- call(place(box, P)^5) answers like the program on every road ------------------------------

CALLED = ["call(place(box, P)^5)", "(place(box, P)^5 *-> true ; fail)", "findall(P, place(box, P)^5, L, [])",
          "aggregate_all(count, P, place(box, P)^5, N)"]


def test_engine_queries_through_every_construct(engine):
    engine.clear()
    engine.feed_lines(SEEN)
    assert engine.query("place(box, P)^5") == {"P": "shelf"}
    assert engine.query("ok") == {}
    assert engine.query("call(place(box, P)^5)") == {"P": "shelf"}
    assert engine.query("(place(box, P)^5 *-> true ; fail)") == {"P": "shelf"}
    assert engine.query("findall(P, place(box, P)^5, L, [])")["L"] == "[shelf]"
    assert engine.query("aggregate_all(count, P, place(box, P)^5, N)")["N"] == "1"


def test_cli_query_and_synchronized_query(tmp_path):
    program, events = tmp_path / "place.rtl", tmp_path / "seen.jsonl"
    program.write_text(PLACE)
    events.write_text(SEEN)
    done = subprocess.run([sys.executable, "-m", "retalisc", "query", str(program), "--events", str(events),
                           "call(place(box, P)^5)"], capture_output=True, text=True, timeout=120)
    assert (done.returncode, done.stdout) == (0, '{"P": "shelf"}\n'), done.stderr
    done = subprocess.run([sys.executable, "-m", "retalisc", "run", str(program), "--events", str(events),
                           "--query", "5", "call(place(box, P)^5)"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    answers = [json.loads(line) for line in done.stdout.splitlines() if '"query"' in line]
    assert [(a["status"], a["answers"]) for a in answers] == [("answered", [{"P": "shelf"}])]


def test_plunit_rtl_time_goal():
    proc = subprocess.run(["swipl", "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_time_goal.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout
