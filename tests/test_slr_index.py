"""The index of memory instances and subscriptions (issue 39, item 4) against plain unification.

Instances and subscriptions are found by every constant argument of their pattern
(rtl_pattern_key.pl: a mask of the constant positions and the hash of the constants). Random patterns over `e/3` and `h/2` (each
argument a variable, a repeated variable, a constant: atoms, integers, a float beside the equal
integer, or a nested term with variables and constants inside) are created and deleted through
`Engine.memory` in the middle of a random stream of ground events fed through the Engine; each
live instance must then hold exactly the events since its creation that unify with its pattern
(`unify` below, a plain implementation over Python values), in order; the same stories with
subscriptions (made with `Engine.subscribe`, ended with `Engine.unsubscribe`) must deliver to each
consumer exactly the events between its subscription and its end that unify with its pattern,
in processing order. SLR_INDEX_EXAMPLES sets the number of examples (default 100).
"""
from __future__ import annotations

import os
import itertools
import re
from typing import Dict, List, Optional, Tuple, Union

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine

EXAMPLES = int(os.environ.get("SLR_INDEX_EXAMPLES", "100"))
TYPES = {"e": 3, "h": 2}
ATOMS = ["a", "b"]
NUMBERS = [0, 1, 1.0, -2]

Value = Union[int, float, str, tuple]      # atom (str), number, or (functor, (args...))


def text(value: Value) -> str:
    """writeq text of a ground value (the atoms here need no quotes)."""
    if isinstance(value, tuple):
        return f"{value[0]}({','.join(text(a) for a in value[1])})"
    return repr(value) if isinstance(value, float) else str(value)


# ---- patterns: ("var", name) | ("const", value) | ("term", functor, [patterns]) -------------

def pattern_text(pattern) -> str:
    kind = pattern[0]
    if kind == "var":
        return pattern[1]
    if kind == "const":
        return text(pattern[1])
    return f"{pattern[1]}({', '.join(pattern_text(p) for p in pattern[2])})"


def unify(pattern, value: Value, bindings: dict) -> Optional[dict]:
    """Bindings extended so that PATTERN equals the ground VALUE, or None (no unification)."""
    kind = pattern[0]
    if kind == "var":
        if pattern[1] == "_":
            return bindings
        if pattern[1] in bindings:
            return bindings if same(bindings[pattern[1]], value) else None
        return {**bindings, pattern[1]: value}
    if kind == "const":
        return bindings if same(pattern[1], value) else None
    if not isinstance(value, tuple) or value[0] != pattern[1] or len(value[1]) != len(pattern[2]):
        return None
    for sub, arg in zip(pattern[2], value[1]):
        bindings = unify(sub, arg, bindings)
        if bindings is None:
            return None
    return bindings


def same(a: Value, b: Value) -> bool:
    """Prolog's ==: 1 and 1.0 are different terms."""
    if isinstance(a, tuple) or isinstance(b, tuple):
        return (isinstance(a, tuple) and isinstance(b, tuple) and a[0] == b[0] and len(a[1]) == len(b[1])
                and all(same(x, y) for x, y in zip(a[1], b[1])))
    return type(a) is type(b) and a == b


# ---- strategies ------------------------------------------------------------------------------

constants = st.sampled_from(ATOMS + NUMBERS)


def ground_values(depth: int = 1):
    if depth == 0:
        return constants
    return st.one_of(constants, st.builds(lambda f, args: (f, tuple(args)), st.sampled_from(["f", "g"]),
                                          st.lists(ground_values(depth - 1), min_size=1, max_size=2)))


@st.composite
def events(draw):
    name = draw(st.sampled_from(sorted(TYPES)))
    return (name, tuple(draw(ground_values()) for _ in range(TYPES[name])))


def sub_patterns(depth: int = 1):
    leaves = st.one_of(st.builds(lambda v: ("var", v), st.sampled_from(["_", "X", "Y"])),
                       st.builds(lambda c: ("const", c), constants))
    if depth == 0:
        return leaves
    return st.one_of(leaves, st.builds(lambda f, args: ("term", f, args), st.sampled_from(["f", "g"]),
                                       st.lists(sub_patterns(depth - 1), min_size=1, max_size=2)))


@st.composite
def patterns(draw):
    name = draw(st.sampled_from(sorted(TYPES)))
    return ("term", name, [draw(sub_patterns()) for _ in range(TYPES[name])])


@st.composite
def stories(draw):
    """Steps: ("event", value), ("add", ident, pattern), ("delete", ident)."""
    steps: List[tuple] = []
    live: List[str] = []
    made = 0
    for _ in range(draw(st.integers(1, 4))):
        steps.append(("add", f"m{made}", draw(patterns())))
        live.append(f"m{made}")
        made += 1
    for _ in range(draw(st.integers(5, 40))):
        choice = draw(st.integers(0, 9))
        if choice == 0:
            steps.append(("add", f"m{made}", draw(patterns())))
            live.append(f"m{made}")
            made += 1
        elif choice == 1 and live:
            steps.append(("delete", live.pop(draw(st.integers(0, len(live) - 1)))))
        else:
            steps.append(("event", draw(events())))
    return steps


# ---- running ---------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def engine():
    return Engine.from_source("n(X) <- m(X).\n", "slr_index.rtl")


def run(engine: Engine, steps: List[tuple]) -> Dict[str, Tuple[tuple, List[tuple]]]:
    """Feed STEPS; return the live instances: ident -> (pattern, [(event, end time)] expected)."""
    engine.bridge.once(f"retalis:rtl_use_program({engine.module})")
    engine.clear()
    engine.memory("d_mem(_)")
    live: Dict[str, Tuple[tuple, List[tuple]]] = {}
    batch: List[tuple] = []
    time = 0

    def flush():
        if batch:
            engine.feed_batch(batch)
            batch.clear()

    for step in steps:
        if step[0] == "event":
            time += 1
            batch.append((text(step[1]), time, time, "add"))
            for pattern, held in live.values():
                if unify(pattern, step[1], {}) is not None:
                    held.append((step[1], time))
        elif step[0] == "add":
            flush()
            engine.memory(f"c_mem({step[1]}, {pattern_text(step[2])}-[], inf, inf)")
            live[step[1]] = (step[2], [])
        else:
            flush()
            engine.memory(f"d_mem({step[1]})")
            del live[step[1]]
    flush()
    return live


def describe(steps: List[tuple]) -> str:
    lines = []
    for step in steps:
        if step[0] == "event":
            lines.append(f"  event {text(step[1])}")
        elif step[0] == "add":
            lines.append(f"  add {step[1]}: {pattern_text(step[2])}")
        else:
            lines.append(f"  delete {step[1]}")
    return "\n".join(lines)


SETTINGS = settings(max_examples=EXAMPLES, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@SETTINGS
@given(stories())
def test_each_instance_holds_what_unification_finds(engine, steps):
    live = run(engine, steps)
    for ident, (pattern, held) in live.items():
        expected = [{"E": text(value), "T": str(end)} for value, end in held]
        assert engine.query_all(f"mem({ident}, E^T)") == expected, f"{ident}: {pattern_text(pattern)}\n{describe(steps)}"


def test_the_oracle_is_not_trivial(engine):
    """Instances with constants at different positions, nested terms and a repeated variable
    over one type: each holds only its own events."""
    e = ("term", "e", [("const", "a"), ("var", "X"), ("var", "X")])
    steps = [("add", "m0", e),
             ("add", "m1", ("term", "e", [("var", "_"), ("const", 1), ("var", "_")])),
             ("add", "m2", ("term", "e", [("var", "_"), ("term", "f", [("const", "b")]), ("var", "_")])),
             ("event", ("e", ("a", 1, 1))), ("event", ("e", ("a", 1.0, 1))), ("event", ("e", ("b", ("f", ("b",)), 0))),
             ("delete", "m0"), ("event", ("e", ("a", 0, 0)))]
    live = run(engine, steps)
    assert sorted(live) == ["m1", "m2"]
    assert engine.query_all("mem(m1, E)") == [{"E": "e(a,1,1)"}]
    assert engine.query_all("mem(m2, E)") == [{"E": "e(b,f(b),0)"}]
    assert [len(held) for _, held in live.values()] == [1, 1]


# ---- subscriptions ---------------------------------------------------------------------------

_CONSUMERS = itertools.count()


def run_subscriptions(engine: Engine, steps: List[tuple]) -> Tuple[Dict[str, List[tuple]], Dict[str, List[tuple]]]:
    """Feed STEPS with subscriptions for the memories of the story ("add": subscribe, "delete":
    unsubscribe at the clock); return (delivered, expected) per consumer: [(event text, end)]."""
    engine.bridge.once(f"retalis:rtl_use_program({engine.module})")
    engine.clear()
    engine.memory("d_mem(_)")
    run_id = next(_CONSUMERS)
    consumers: Dict[str, str] = {}                 # story ident -> consumer
    ids: Dict[str, str] = {}
    live: Dict[str, tuple] = {}
    expected: Dict[str, List[tuple]] = {}
    delivered: Dict[str, List[tuple]] = {}
    batch: List[tuple] = []
    time = 0

    def flush():
        if batch:
            for out in engine.feed_batch(batch):
                if out.consumer in delivered:
                    delivered[out.consumer].append((out.event, str(out.end)))
            batch.clear()

    for step in steps:
        if step[0] == "event":
            time += 1
            batch.append((text(step[1]), time, time, "add"))
            for ident, pattern in live.items():
                if unify(pattern, step[1], {}) is not None:
                    expected[consumers[ident]].append((text(step[1]), str(time)))
        elif step[0] == "add":
            flush()
            consumer = consumers[step[1]] = f"c{run_id}_{step[1]}"
            ids[step[1]] = engine.subscribe(consumer, pattern_text(step[2]))
            live[step[1]] = step[2]
            expected[consumer], delivered[consumer] = [], []
        else:
            flush()
            engine.unsubscribe(ids[step[1]], time)
            del live[step[1]]
    flush()
    for ident in live:
        engine.unsubscribe(ids[ident], 0)           # later examples restart the clock
    return delivered, expected


@SETTINGS
@given(stories())
def test_each_subscription_receives_what_unification_finds(engine, steps):
    delivered, expected = run_subscriptions(engine, steps)
    assert delivered == expected, describe(steps)


def test_the_subscription_oracle_is_not_trivial(engine):
    steps = [("add", "m0", ("term", "e", [("const", "a"), ("var", "X"), ("var", "X")])),
             ("add", "m1", ("term", "e", [("var", "_"), ("const", 1), ("var", "_")])),
             ("event", ("e", ("a", 1, 1))), ("event", ("e", ("a", 1.0, 1))), ("delete", "m0"),
             ("event", ("e", ("a", 0, 0))), ("event", ("e", ("b", 1, 0)))]
    delivered, expected = run_subscriptions(engine, steps)
    assert delivered == expected
    assert [len(v) for v in delivered.values()] == [1, 2]


# ---- snapshots -------------------------------------------------------------------------------

def _scramble_keys(path, module: str) -> int:
    """Replace every key of the snapshot's index for the program MODULE (the first argument of
    the watch clauses of rtl_slr and of by_key/7) by another integer, as a runtime hashing
    otherwise would file them; returns how many were changed."""
    lines, changed = [], 0
    key = re.compile(r"^(fact\(rtl_slr,'\$slr_watch [^']*'\(|fact\(rtl_subscriptions,by_key\()(-?\d+),")
    for line in path.read_text(encoding="utf-8").splitlines(keepends=True):
        match = key.match(line)
        if match and f",{module}," in line:
            line = f"{match.group(1)}{int(match.group(2)) + 1},{line[match.end():]}"
            changed += 1
        lines.append(line)
    path.write_text("".join(lines), encoding="utf-8")
    return changed


@pytest.mark.parametrize("scrambled", [False, True])
def test_a_restore_files_instances_and_subscriptions_again(tmp_path, scrambled):
    """The keys of the index are not taken from a snapshot: they are made again from the
    restored patterns, so a snapshot whose keys were computed otherwise (another hash) restores
    an index that finds exactly what unification finds."""
    source = "n(X) <- m(X).\n"
    patterns = {"m0": ("term", "e", [("const", "a"), ("var", "X"), ("var", "X")]),
                "m1": ("term", "e", [("var", "_"), ("const", 1), ("var", "_")]),
                "m2": ("term", "h", [("term", "f", [("const", "b")]), ("const", 1.0)])}
    before = [("e", ("a", 1, 1)), ("e", ("b", 1, 0)), ("h", (("f", ("b",)), 1.0))]
    after = [("e", ("a", 0, 0)), ("e", ("a", 1, 0)), ("h", (("f", ("b",)), 1)), ("h", (("f", ("b",)), 1.0)),
             ("e", ("b", 1, 1))]
    first = Engine.from_source(source, "slr_index_state.rtl")
    for ident, pattern in patterns.items():
        first.memory(f"c_mem({ident}, {pattern_text(pattern)}-[], inf, inf)")
        first.subscribe(f"s_{ident}", pattern_text(pattern))
    first.feed_batch([(text(v), t, t, "add") for t, v in enumerate(before, 1)])
    state = tmp_path / "engine.state"
    first.save_state(state)
    if scrambled:
        assert _scramble_keys(state, first.module) == 2 * len(patterns)
    second = Engine.from_source(source, "slr_index_state.rtl")
    second.restore_state(state)
    outputs = second.feed_batch([(text(v), t, t, "add") for t, v in enumerate(after, len(before) + 1)])
    for ident, pattern in patterns.items():
        held = [(v, t) for t, v in enumerate(before + after, 1) if unify(pattern, v, {}) is not None]
        assert second.query_all(f"mem({ident}, E^T)") == [{"E": text(v), "T": str(t)} for v, t in held]
        got = [(o.event, str(o.end)) for o in outputs if o.consumer == f"s_{ident}"]
        assert got == [(text(v), str(t)) for v, t in held if t > len(before)]
    assert second.query_all("mem(m1, E)") == [{"E": "e(a,1,1)"}, {"E": "e(b,1,0)"}, {"E": "e(a,1,0)"},
                                               {"E": "e(b,1,1)"}]


def test_a_snapshot_of_the_first_argument_index_is_refused(tmp_path):
    """A snapshot of the runtime before this index is refused by its runtime identity
    (snapshot.runtime_version hashes the runtime's sources); one with this identity that holds
    the old index, `by_functor/5`, is refused too: it is no longer state."""
    from retalisc.driver.snapshot import StateError

    engine = Engine.from_source("n(X) <- m(X).\n", "slr_index_old.rtl")
    engine.subscribe("c", "e(a, _, _)")
    state = tmp_path / "engine.state"
    engine.save_state(state)
    old = re.sub(r"fact\(rtl_subscriptions,by_key\(-?\d+,(\w+),(\w+),(\d+),\d+,(\w+),(\w+)\)\)\.",
                 r"fact(rtl_subscriptions,by_functor(\1,\2,\3,\4,\5)).", state.read_text(encoding="utf-8"))
    assert "by_functor(" in old
    state.write_text(old, encoding="utf-8")
    with pytest.raises(StateError, match="not declared state|by_functor"):
        engine.restore_state(state)
    assert engine.query_all("true") == [{}]
