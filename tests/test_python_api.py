"""The Python API as a Python user meets it: output terms as data, every time form of the
event files (checked by the same check, with the same reasons), datetimes and ROS stamps,
the Engine as a context manager."""
from __future__ import annotations

import datetime as dt
import json
import math
from types import SimpleNamespace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine, OutputEvent, QueryAnswer, Term, Variable
from retalisc.driver.values import String, read_term

ECHO = "out(X) <- echo(X).\nnull do true <- tick.\n"


@pytest.fixture(scope="module")
def engine():
    engine = Engine.from_source(ECHO, "echo.rtl")
    engine.set_flag("max_delay", "inf")
    return engine


def test_output_term_as_data():
    with Engine.from_source("seen(P, [X, Y], at(Room, -2.5), 'Big Door', \"s\") <- "
                            "person(P, X, Y) where (Room = kitchen).\n", "people.rtl") as engine:
        [out] = engine.feed("person(anna, 1, 2)", 1)
    assert out.name == "seen"
    assert out.args == ("anna", [1, 2], Term("at", ("kitchen", -2.5)), "Big Door", "s")
    assert out.term == Term("seen", out.args)
    assert out.text == out.event == "seen(anna,[1,2],at(kitchen,-2.5),'Big Door',\"s\")"
    assert (out.start, out.end, out.op, out.consumer) == (1, 1, "add", None)
    assert out.term.arity == 5 and out.term[2].name == "at"
    assert type(out.args[3]) is str and type(out.args[4]) is String       # an atom, a Prolog string


def test_atom_event_and_unbound_variable():
    with Engine.from_source("door_open <- door(open).\nr(X) <- a(X) or b(Y).\n", "doors.rtl") as engine:
        [out] = engine.feed("door(open)", 1)
        assert (out.term, out.name, out.args) == ("door_open", "door_open", ())
        [unbound] = engine.feed("b(1)", 2)
        assert isinstance(unbound.args[0], Variable)


def test_retraction_and_consumer_as_attributes(engine):
    engine.subscribe("log", "out(X)", callback=None)
    added = engine.feed("echo(k1)", 10)
    assert {(o.name, o.consumer, o.op) for o in added} == {("out", None, "add"), ("out", "log", "add")}
    retracted = engine.feed("echo(k1)", 10, op="retract")
    assert {(o.consumer, o.op) for o in retracted} == {(None, "retract"), ("log", "retract")}


# ---- terms as data: a property test with the generated value as oracle ------------------

# Unassigned and private-use code points are left out: SWI-Prolog's writeq/1 escapes them as
# \xHEX\ and cannot read all of them back.
ATOMS = st.one_of(st.from_regex(r"[a-z][a-zA-Z0-9_]{0,6}", fullmatch=True),
                  st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc", "Cn", "Co")), min_size=1, max_size=5))
NUMBERS = st.one_of(st.integers(-10 ** 20, 10 ** 20),
                    st.floats(allow_nan=False, allow_infinity=False, width=64))


def prolog_text(value) -> str:
    """The test's own writer: a Python value as Prolog text."""
    if isinstance(value, str):
        return "'" + value.replace("\\", "\\\\").replace("'", "\\'") + "'"
    if isinstance(value, bool):
        raise TypeError(value)
    if isinstance(value, int):
        return f"({value})"
    if isinstance(value, float):
        return f"({value!r})"
    if isinstance(value, list):
        return "[" + ", ".join(prolog_text(v) for v in value) + "]"
    return f"{prolog_text(value.name)}(" + ", ".join(prolog_text(a) for a in value.args) + ")"


VALUES = st.recursive(
    st.one_of(ATOMS, NUMBERS),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.builds(lambda n, a: Term(n, tuple(a)), ATOMS, st.lists(inner, min_size=1, max_size=3))),
    max_leaves=12)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(VALUES)
def test_output_values_are_the_values_fed(engine, value):
    out = [o for o in engine.feed(f"echo({prolog_text(value)})", 1) if o.consumer is None]
    assert len(out) == 1
    got = out[0].args[0]
    assert got == value or (isinstance(value, float) and isinstance(got, float) and math.isclose(got, value))
    engine.feed(f"echo({prolog_text(value)})", 1, op="retract")


def test_symbol_characters_writeq_leaves_unquoted(engine):
    # writeq/1 writes out('¡') as out(¡): the term is read back by SWI-Prolog itself
    [out] = [o for o in engine.feed("echo('¡')", 1) if o.consumer is None]
    assert out.event == "out(¡)" and out.args == ("¡",)
    engine.feed("echo('¡')", 1, op="retract")


def test_read_term_deep_and_bad():
    deep = "f(" * 1000 + "a" + ")" * 1000            # the deepest term an input line may carry
    value = read_term(deep)
    for _ in range(1000):
        value = value.args[0]
    assert value == "a"
    with pytest.raises(ValueError):
        read_term("f(")
    assert read_term("p(a - b, \"s\", 'A b', [1, 2.5])") == Term("p", (Term("-", ("a", "b")), String("s"), "A b",
                                                                     [1, 2.5]))


def test_a_deep_output_term_comes_as_data(engine):
    deep = "f(" * 998 + "'A'" + ")" * 998
    [out] = [o for o in engine.feed(f"echo({deep})", 1) if o.consumer is None]
    value = out.args[0]
    for _ in range(998):
        value = value.args[0]
    assert value == "A" and type(value) is str


# ---- times: the check of the file reader -------------------------------------------------

TIMES = st.one_of(
    st.integers(-10 ** 12, 10 ** 12),
    st.floats(allow_nan=False, width=64),
    st.lists(st.integers(-2, 2 * 10 ** 9), min_size=2, max_size=2),
    st.lists(st.one_of(st.integers(0, 5), st.floats(0, 5), st.text(max_size=2)), min_size=0, max_size=3),
)


def file_verdict(engine, fields: dict):
    """What the event-file reader says of a line with these time fields: None (processed) or
    the reason it was rejected."""
    line = json.dumps(dict(event="tick", **fields))
    _, rejections = engine.feed_lines(line + "\n")
    return rejections[0].reason if rejections else None


def api_verdict(engine, *times):
    try:
        engine.feed("tick", *times)
    except ValueError as error:
        return str(error).split(": ", 1)[1]         # after "event 0 of the batch: "
    return None


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(TIMES, st.one_of(st.none(), TIMES))
def test_feed_checks_times_exactly_as_the_file_reader(engine, start, end):
    if any(isinstance(t, float) and not math.isfinite(t) for t in (start, end)):
        fields_ok = False               # JSON has no infinities: the file cannot say it
    else:
        fields_ok = True
    fields = {"t": start} if end is None else {"start": start, "end": end}
    api = api_verdict(engine, start) if end is None else api_verdict(engine, start, end)
    if fields_ok:
        assert api == file_verdict(engine, fields)
    else:
        assert api is not None and "finite" in api


def test_datetime_and_ros_stamps_are_exact(engine):
    stamp = dt.datetime(2015, 6, 1, 12, 30, 5, 250000)
    [out] = [o for o in engine.feed("echo(d)", stamp) if o.consumer is None]
    assert out.start == pytest.approx(1433161805.25)
    aware = dt.datetime(2015, 6, 1, 14, 30, 5, 250000, tzinfo=dt.timezone(dt.timedelta(hours=2)))
    ros2 = SimpleNamespace(sec=1433161805, nanosec=250000000)
    ros1 = SimpleNamespace(secs=1433161805, nsecs=250000000)
    for when in (aware, ros2, ros1, [1433161805, 250000000], (1433161805, 250000000)):
        [again] = [o for o in engine.feed("echo(d)", when) if o.consumer is None]
        assert again.start == out.start
    with pytest.raises(TypeError):
        engine.feed("echo(d)", "yesterday")
    with pytest.raises(TypeError):
        engine.feed("echo(d)", None)


# ---- the context manager -------------------------------------------------------------------


def test_context_manager_runs_pending_queries_and_closes():
    seen = []
    with Engine.from_source("c_mem(m, seg(_)-[], inf, inf).\n", "mem.rtl") as engine:
        engine.on_output(seen.append)
        future = engine.query_synchronized("prev(m, seg(X)^T, 5)", 5)
        engine.feed("seg(a)", 1)
        assert not future.done()
    assert future.result() and engine.closed
    answers = [o for o in seen if o.op == "answer"]
    assert len(answers) == 1 and isinstance(answers[0], OutputEvent)
    answer = answers[0].answer
    assert isinstance(answer, QueryAnswer) and answers[0].term == answer
    assert (answer.status, answer.at, answer.answers, answer.message) == ("answered", 5, ({"X": "a", "T": "1"},), "")
    assert answer.query.startswith("py")             # the id query_synchronized gave it
    assert (answers[0].name, answers[0].args) == ("answer", ())      # every output has a name
    assert all(o.answer is None for o in seen if o.op != "answer")
    with pytest.raises(RuntimeError, match="closed"):
        engine.feed("seg(b)", 2)
    assert engine.close() == []                     # closing twice does nothing


def test_context_manager_on_an_exception_drops_pending_work():
    with pytest.raises(KeyError):
        with Engine.from_source("c_mem(m, seg(_)-[], inf, inf).\n", "mem.rtl") as engine:
            future = engine.query_synchronized("prev(m, seg(X)^T, 5)", 5)
            raise KeyError("boom")
    assert engine.closed
    assert future.exception().kind == "dropped"


def test_the_echo_of_an_input_is_marked_and_told_from_a_derived_event():
    with Engine.from_source("b(X) <- a(X).\na(X) <- c(X).\n", "echo_mark.rtl") as engine:
        engine.set_flag("echo_input", "true")
        out = engine.feed("c(1)", 1) + engine.feed("a(2)", 2)
    assert [(o.event, o.input) for o in out] == [("c(1)", True), ("a(1)", False), ("b(1)", False),
                                                 ("a(2)", True), ("b(2)", False)]
    assert all(('"input": true' in o.line) == o.input for o in out)
