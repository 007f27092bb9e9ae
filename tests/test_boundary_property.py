"""A property of the boundary of untrusted goals (issue 35): every goal it accepts, run under
the runtime's limits, creates no file, changes no Prolog flag, global variable or program
predicate, opens no stream and ends.

Goals are generated from the predicates SWI-Prolog defines (the system module and the
autoloadable library index), half of them from the list the runtime allows (so that accepted
goals are common), with arguments from a small pool: canary goals that create a file in the
test's directory, format strings with `~@` and `~W`, file names there, streams, flags, global
variable names, write options; composed with the control constructs. The query road runs in
process; a few goals go through a subscription condition and an added rule's condition."""
from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from retalisc.driver.bridge import PrologError
from retalisc.driver.engine import Engine, QueryError
from retalisc.frontend.errors import RetalisError

PROGRAM = """
located(s1, kitchen).
located(s2, kitchen).
nearby(A, B) :- located(A, R), located(B, R).
:- dynamic counter/1.
counter(0).
r1 : fire(S) <- smoke(S) seq heat(S).
"""

ARGUMENTS = [
    "X", "Y", "_", "0", "1", "-1", "3.5", "100000", "a", "[]", "[1,2,3]", "[a|b]", "f(X, Y)", "{x}", "0'a",
    "'{d}/file1'", '"{d}/file2"', '"touch {d}/canary1"',
    "shell('touch {d}/canary2')", "[shell('touch {d}/canary3')]", "X^shell('touch {d}/canary4')",
    'format("~@", [shell("touch {d}/canary5")])', "print_message(error, format(\"~@\", [shell('touch {d}/canary6')]))",
    "(a :- shell('touch {d}/canary7'))", "[portray_goal(shell)]", "[portray(true)]",
    '"~@"', '"~W"', '"~p"', '"~w ~a"', "'~@'",
    "user_output", "user_error", "user_input", "atom(A)", "string(S)", "codes(C)",
    "double_quotes", "unknown", "rtl_clock", "rtl_raised", "'$aborted'", "time_limit_exceeded",
    "write", "call", "true", "fail", "freeze", "shell", "assertz(foo)", "counter(N)", "nearby(s1, W)",
    "located(A, B)", "repeat", "(repeat, fail)",
]


def goal_strategy(names):
    def call(name_arity):
        name, arity = name_arity
        if arity == 0:
            return st.just(name)
        return st.lists(st.sampled_from(ARGUMENTS), min_size=arity, max_size=arity).map(
            lambda args: f"{name}({', '.join(args)})")

    atomic = names.flatmap(call)
    return st.recursive(atomic, lambda inner: st.one_of(
        st.tuples(inner, inner).map(lambda p: f"({p[0]}, {p[1]})"),
        st.tuples(inner, inner).map(lambda p: f"({p[0]} ; {p[1]})"),
        inner.map(lambda g: f"catch({g}, _, true)"),
        inner.map(lambda g: f"findall(x, {g}, _)"),
        inner.map(lambda g: f"\\+ {g}"),
        inner.map(lambda g: f"call({g})"),
        inner.map(lambda g: f"with_output_to(string(_), {g})"),
        st.tuples(st.sampled_from(["lists", "system", "user", "apply", "sandbox"]), inner).map(
            lambda p: f"{p[0]}:({p[1]})"),
    ), max_leaves=3)


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    directory = tmp_path_factory.mktemp("boundary_property")
    engine = Engine.from_source(PROGRAM, "property.rtl")
    engine.set_flag("max_delay", "inf")
    engine.set_flag("echo_input", "false")
    engine.set_flag("query_time_limit", "0.1")
    engine.set_flag("max_steps", "200000")
    engine.query("true")                    # the query road's own state (its view of the memories)
    pl = engine.bridge
    system = pl.all("predicate_property(system:H, defined), \\+ predicate_property(system:H, imported_from(_)), "
                    "functor(H, N, A), \\+ sub_atom(N, 0, _, _, '$')", "N/A")
    library = pl.all("'$autoload':library_index(H, _, _), functor(H, N, A)", "N/A")
    allowed = pl.all("rtl_sandbox:allowed_list(L), member(N/A, L)", "N/A")

    def parse(texts):
        pairs = set()
        for text in texts:
            name, _, arity = text.rpartition("/")
            pairs.add((name, int(arity)))
        return sorted(pairs)

    return engine, directory, parse(system + library), parse(allowed)


def observable(engine: Engine) -> dict:
    """What an accepted goal must not change: flags, global variables, the program's and
    user's predicates, the open streams."""
    pl, m = engine.bridge, engine.module
    return {
        "flags": pl.all("current_prolog_flag(F, V), \\+ memberchk(F, [last_call_optimisation]), "
                        "catch(variant_sha1(V, H), _, H = -)", "F-H"),
        "globals": sorted(pl.all("nb_current(K, V), \\+ sub_atom(K, 0, _, _, '$'), K \\== retalisc_bridge_pending, "
                                 "catch(variant_sha1(V, H), _, H = -)", "K-H")),
        "predicates": sorted(pl.all(f"member(M, [{m}, user]), current_predicate(M:N/A), functor(G, N, A), "
                                    "\\+ predicate_property(M:G, imported_from(_)), "
                                    "aggregate_all(count, catch(clause(M:G, _), _, fail), C)", "M:N/A-C")),
        "streams": sorted(pl.all("stream_property(S, file_name(F))", "F")),
    }


def files(directory) -> list:
    return sorted(os.listdir(directory)) + sorted(os.listdir(os.getcwd()))


def run_goal(engine: Engine, goal: str) -> bool:
    try:
        engine.query_all(goal)
    except QueryError as refused:
        return refused.kind != "unsafe"        # accepted, and raised or ran out of time
    return True


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(data=st.data())
def test_every_goal_the_boundary_accepts_is_side_effect_free(world, data):
    engine, directory, everything, allowed = world
    names = st.one_of(st.sampled_from(everything), st.sampled_from(allowed))
    goal = data.draw(goal_strategy(names)).replace("{d}", str(directory))
    before, present = observable(engine), files(directory)
    event("accepted" if run_goal(engine, goal) else "refused")
    assert files(directory) == present, goal
    after = observable(engine)
    for key, value in before.items():
        assert after[key] == value, (goal, key, set(after[key]) ^ set(value))
    assert engine.query("nearby(s1, X)") == {"X": "s1"}


@settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(data=st.data())
def test_accepted_conditions_are_side_effect_free_on_the_event_road(world, data):
    """A few goals through the other roads: a subscription condition and an added rule's
    condition, run by an event under the step limit."""
    engine, directory, _, allowed = world
    goal = data.draw(goal_strategy(st.sampled_from(allowed))).replace("{d}", str(directory))
    present = files(directory)
    installed = []
    try:
        installed.append(("sub", engine.subscribe("ops", "probe(_)", conditions_text=f"[{goal}]")))
    except PrologError:
        pass
    try:
        installed.append(("rule", engine.add_rules(f"probed(X) <- probe(X) where ({goal}).")[0]))
    except (PrologError, RetalisError):             # refused, or not a condition the compiler takes
        pass
    before = observable(engine)
    engine.feed_lines('{"event": "probe(1)", "t": 1}\n')
    assert files(directory) == present, goal
    after = observable(engine)
    assert after["flags"] == before["flags"] and after["predicates"] == before["predicates"], goal
    assert after["streams"] == before["streams"], goal
    for kind, ident in installed:
        if kind == "sub":
            engine.unsubscribe(ident)
        else:
            engine.remove_rule(ident)
