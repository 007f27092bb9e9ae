"""Oracle tests of SLR memory instances and queries (thesis 4.2.2-4.2.4, Def. 19-24).

Random streams of `a(P, I)`, `b(I)` and `c(I, U)` events (small atoms and integers, point
and interval events, equal end times) are delivered in a random arrival order (late events
included) with random retractions of events added before, to random memory instances
(c_mem/5 and memorize/5: a pattern with some arguments fixed, a condition on an argument,
a template, a size N and a time limit L). Then mem/2 (with `at` views), prev/3, next/4,
their Retalis 2015 spellings and the stream forms prev/2, next/3, next/2 (the program keeps
a history of every type) are answered by the runtime and by `Model`, a brute-force
evaluation of the definitions over plain Python lists.

What a memory holds (Def. 21): among the matching events present, those whose end time is
within the last L seconds of the clock (the largest end time processed; a record ending at
E is gone once E + L < clock), and of those the N latest by end time; among equal end times
records go by start time, then by the standard order of terms of the record (the runtime's
documented rule: order-free, so ties are generated freely and arrival orders do not show).
With no retraction that is a function of the set of events present (`held_by_definition`,
checked against the model).
Retractions make it depend on history, and the model follows the runtime's choice:

  * an event that a count or time limit has forgotten stays forgotten: retracting a held
    record frees a place but does not bring the forgotten older record back;
  * a retraction removes one held record equal to the event's record (same template, start
    and end; equal records are indistinguishable), whichever event it came from
    (records do not remember their event). Retracting an event whose own record was
    forgotten therefore removes an equal record of another event if one is held; the model
    does the same. Only events present (added and not yet retracted) are retracted.

prev(Id, E, Zs) is the latest record ending =< Zs that unifies with E, next(Id, E, Zs, Ze)
the earliest ending in [Zs, Ze] that unifies (in the order of records); `E^T` binds T to
the end time (as `E^T` in event patterns does), `E^[S, T]` binds both. The `at` view bounds mem/2 only. SLR_EXAMPLES sets the number of examples (default 150).
"""
from __future__ import annotations

import os
from collections import Counter
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple, Union

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine

EXAMPLES = int(os.environ.get("SLR_EXAMPLES", "150"))

# The event types and the values each argument takes.
TYPES: Dict[str, Tuple[list, ...]] = {
    "a": (["p", "q"], [0, 1, 2, 3]),
    "b": ([0, 1, 2, 3],),
    "c": ([0, 1, 2], ["u", "v"]),
}

# The program only declares the stream histories of the three types (through the stream
# forms its clause uses); memories are created for each example through Engine.memory.
PROGRAM = """
uses_histories(T) :- prev(a(_, _), T), prev(b(_), T), next(c(_, _), T, inf).
added(Id, R) <- memory_record_added(Id, R).
forgotten(Id, R) <- memory_record_forgotten(Id, R).
"""

Value = Union[int, str, tuple]          # int, atom, or (functor, (args...))


def text(value: Value) -> str:
    """writeq text of a ground value (atoms here need no quotes)."""
    if isinstance(value, tuple):
        return f"{value[0]}({','.join(text(a) for a in value[1])})"
    return str(value)


def number_text(z) -> str:
    return "inf" if z == float("inf") else repr(z)


# ---- patterns ---------------------------------------------------------------------------
# ("var", Name) | ("const", value) | ("term", functor, [patterns])

def unify(pattern, value, bindings: dict) -> Optional[dict]:
    kind = pattern[0]
    if kind == "var":
        if pattern[1] in bindings:
            return bindings if bindings[pattern[1]] == value else None
        return {**bindings, pattern[1]: value}
    if kind == "const":
        return bindings if type(pattern[1]) is type(value) and pattern[1] == value else None
    if not isinstance(value, tuple) or value[0] != pattern[1] or len(value[1]) != len(pattern[2]):
        return None
    for p, v in zip(pattern[2], value[1]):
        bindings = unify(p, v, bindings)
        if bindings is None:
            return None
    return bindings


def pattern_text(pattern) -> str:
    if pattern[0] == "var":
        return pattern[1]
    if pattern[0] == "const":
        return text(pattern[1])
    return f"{pattern[1]}({', '.join(pattern_text(a) for a in pattern[2])})"


def pattern_vars(pattern, out: list) -> list:
    if pattern[0] == "var":
        if pattern[1] not in out:
            out.append(pattern[1])
    elif pattern[0] == "term":
        for a in pattern[2]:
            pattern_vars(a, out)
    return out


@dataclass(frozen=True)
class Query:
    """A record pattern: `inner`, `inner^T` (times = ("pt", T)) or `inner^[S, T]` (("iv", S, T))."""
    inner: tuple
    times: Optional[tuple] = None

    def text(self) -> str:
        if self.times is None:
            return pattern_text(self.inner)
        if self.times[0] == "pt":
            return f"{pattern_text(self.inner)}^{pattern_text(self.times[1])}"
        return f"{pattern_text(self.inner)}^[{pattern_text(self.times[1])}, {pattern_text(self.times[2])}]"

    def match(self, record: "Record", bindings: dict) -> Optional[dict]:
        b = unify(self.inner, record.value, bindings)
        if b is None or self.times is None:
            return b
        if self.times[0] == "pt":
            return unify(self.times[1], record.end, b)
        b = unify(self.times[1], record.start, b)
        return None if b is None else unify(self.times[2], record.end, b)

    def variables(self) -> List[str]:
        out = pattern_vars(self.inner, [])
        for p in (self.times or ())[1:]:
            pattern_vars(p, out)
        return out


# ---- memories and the model --------------------------------------------------------------

@dataclass(frozen=True)
class Event:
    name: str
    args: tuple
    start: int
    end: int

    def value(self) -> Value:
        return (self.name, self.args)

    def text(self) -> str:
        return text(self.value())


def standard_order_key(value: Value) -> tuple:
    """Prolog's standard order of terms for the values here: numbers < atoms < compounds,
    compounds by arity, then name, then arguments."""
    if isinstance(value, tuple):
        return (2, len(value[1]), value[0], tuple(standard_order_key(a) for a in value[1]))
    if isinstance(value, str):
        return (1, value)
    return (0, value)


@dataclass(frozen=True)
class Record:
    end: float
    start: float
    value: Value

    def order(self) -> tuple:
        """The order of records: end time, then start time, then the record's standard order."""
        return (self.end, self.start, standard_order_key(self.value))


def beyond_bound(end: float, clock: float, bound: Optional[float]) -> bool:
    """docs/runtime.md: a time `end` lies beyond `bound` seconds behind the clock when
    end + bound < clock (a bound of None is inf)."""
    return bound is not None and end + bound < clock


@dataclass(frozen=True)
class MemorySpec:
    ident: str
    kind: str                   # "c_mem" | "memorize" | "stream"
    type_name: str
    pattern: tuple              # per argument ("var", "X<i>") or ("const", value)
    cond: Optional[tuple]       # (var name, operator, constant)
    template: Optional[tuple]   # None: the event itself; else ("t", [("var", X) | ("const", c)])
    n: Optional[int]            # None: inf
    limit: Optional[float]      # None: inf

    def request(self, record_events: bool = False) -> str:
        pattern = f"{self.type_name}({', '.join(pattern_text(p) for p in self.pattern)})"
        conds = f"[{self.cond[0]} {self.cond[1]} {text(self.cond[2])}]" if self.cond else "[]"
        n = "inf" if self.n is None else str(self.n)
        if self.kind == "c_mem":
            limit = "inf" if self.limit is None else repr(self.limit)
            options = ", [record_events(true)]" if record_events else ""
            return f"c_mem({self.ident}, {pattern}-{conds}, {n}, {limit}{options})"
        template = "_" if self.template is None else pattern_text(("term", self.template[0], self.template[1]))
        return f"memorize({pattern}, {conds}, {template}, {self.ident}, {n})"

    def record_value(self, event: Event) -> Optional[Value]:
        """The record this memory makes of `event`, None when the event does not match."""
        if event.name != self.type_name:
            return None
        bindings: Optional[dict] = {}
        for p, v in zip(self.pattern, event.args):
            bindings = unify(p, v, bindings)
            if bindings is None:
                return None
        if self.cond is not None:
            name, op, k = self.cond
            v = bindings[name]
            holds = {">": v > k if isinstance(v, int) else None, "=<": v <= k if isinstance(v, int) else None,
                     "=\\=": v != k, "==": v == k, "\\==": v != k}[op]
            if not holds:
                return None
        if self.template is None:
            return event.value()
        return (self.template[0], tuple(bindings[a[1]] if a[0] == "var" else a[1] for a in self.template[1]))

    def shape(self) -> Tuple[str, List[list]]:
        """The functor of the records and the values each argument may take."""
        if self.template is None:
            return self.type_name, [list(d) for d in TYPES[self.type_name]]
        domains = {f"X{i}": TYPES[self.type_name][i] for i in range(len(TYPES[self.type_name]))}
        return self.template[0], [list(domains[a[1]]) if a[0] == "var" else [a[1]] for a in self.template[1]]


class MemoryModel:
    """One memory instance, updated the way Def. 21 keeps records (see the module doc)."""

    def __init__(self, spec: MemorySpec):
        self.spec = spec
        self.held: List[Record] = []

    def add(self, event: Event, clock: float) -> None:
        value = self.spec.record_value(event)
        if value is None:
            return
        self.held.append(Record(event.end, event.start, value))
        self.held.sort(key=Record.order)
        if self.spec.n is not None:
            self.held = self.held[-self.spec.n:]
        self.held = self.within_limit(self.held, clock)

    def retract(self, event: Event) -> None:
        value = self.spec.record_value(event)
        for i, r in enumerate(self.held):
            if value is not None and (r.start, r.end, r.value) == (event.start, event.end, value):
                del self.held[i]
                return

    def within_limit(self, records: List[Record], clock: float) -> List[Record]:
        if self.spec.limit is None:
            return records
        return [r for r in records if not beyond_bound(r.end, clock, self.spec.limit)]

    def records(self, clock: float) -> List[Record]:
        return self.within_limit(self.held, clock)

    def held_by_definition(self, arrivals: List[Tuple[int, Event]], clock: float) -> List[Record]:
        """Def. 21 as a function of the events present (valid when none was retracted)."""
        matching = [Record(e.end, e.start, self.spec.record_value(e)) for _, e in arrivals
                    if self.spec.record_value(e) is not None]
        kept = sorted(self.within_limit(matching, clock), key=Record.order)
        return kept if self.spec.n is None else kept[len(kept) - self.spec.n:] if len(kept) > self.spec.n else kept


class Model:
    def __init__(self, specs: List[MemorySpec]):
        self.memories = {s.ident: MemoryModel(s) for s in specs}
        self.order = [s.ident for s in specs if s.kind != "stream"]
        self.streams = {s.type_name: self.memories[s.ident] for s in specs if s.kind == "stream"}
        self.clock = float("-inf")

    def run(self, ops: List[Tuple[str, Event]]) -> None:
        for op, event in ops:
            if op == "add":
                self.clock = max(self.clock, event.end)
                for m in self.memories.values():
                    m.add(event, self.clock)
            else:
                for m in self.memories.values():
                    m.retract(event)

    def records(self, ident: str) -> List[Record]:
        return self.memories[ident].records(self.clock)

    # The queries: a list of binding dicts (variable name -> value), in the runtime's order.

    def mem(self, ident: str, q: Query, at: Optional[float], id_var: Optional[str] = None) -> List[dict]:
        out = []
        for i in ([ident] if id_var is None else self.order):
            for r in self.records(i):
                if at is not None and r.end > at:
                    continue
                b = q.match(r, {id_var: i} if id_var else {})
                if b is not None:
                    out.append(b)
        return out

    @staticmethod
    def latest(records: List[Record], q: Query, zs: float, bindings: dict) -> List[dict]:
        for r in reversed(records):
            if r.end <= zs:
                b = q.match(r, bindings)
                if b is not None:
                    return [b]
        return []

    @staticmethod
    def earliest(records: List[Record], q: Query, zs: float, ze: float, bindings: dict) -> List[dict]:
        for r in records:
            if zs <= r.end <= ze:
                b = q.match(r, bindings)
                if b is not None:
                    return [b]
        return []

    def prev(self, ident: Optional[str], q: Query, zs: float, id_var: Optional[str] = None) -> List[dict]:
        if ident is not None:
            return self.latest(self.records(ident), q, zs, {})
        return [b for i in self.order for b in self.latest(self.records(i), q, zs, {id_var: i})]

    def next(self, ident: Optional[str], q: Query, zs: float, ze: float, id_var: Optional[str] = None) -> List[dict]:
        if ident is not None:
            return self.earliest(self.records(ident), q, zs, ze, {})
        return [b for i in self.order for b in self.earliest(self.records(i), q, zs, ze, {id_var: i})]

    def stream_prev(self, q: Query, zs: float) -> List[dict]:
        return self.latest(self.streams[q.inner[1]].records(self.clock), q, zs, {})

    def stream_next(self, q: Query, zs: float, ze: float) -> List[dict]:
        return self.earliest(self.streams[q.inner[1]].records(self.clock), q, zs, ze, {})


STREAMS = [MemorySpec(f"'$stream'({t}/{len(d)})", "stream", t, tuple(("var", f"X{i}") for i in range(len(d))),
                      None, None, None, None) for t, d in TYPES.items()]


# ---- strategies --------------------------------------------------------------------------

@st.composite
def events(draw, unique_ends=False, max_size=30):
    def one(name):
        return st.tuples(*[st.sampled_from(d) for d in TYPES[name]]).map(lambda args: (name, args))
    kinds = st.sampled_from(sorted(TYPES)).flatmap(one)
    ends = st.integers(2, 14 if unique_ends else draw(st.sampled_from([14, 7])))   # 7: many equal ends
    if unique_ends:
        end_list = draw(st.lists(ends, min_size=8, max_size=max_size, unique=True))
    else:
        end_list = draw(st.lists(ends, min_size=8, max_size=max_size))
    out = []
    for end in end_list:
        name, args = draw(kinds)
        length = draw(st.sampled_from([0, 0, 0, 1, 2]))
        out.append(Event(name, args, end - length, end))
    return out


@st.composite
def memory_spec(draw, index, types, unlimited=False):
    type_name = draw(st.sampled_from(sorted(types)))
    domains = TYPES[type_name]
    pattern = tuple(("const", draw(st.sampled_from(d))) if draw(st.integers(0, 5)) == 0 else ("var", f"X{i}")
                    for i, d in enumerate(domains))
    variables = [(p[1], domains[i]) for i, p in enumerate(pattern) if p[0] == "var"]
    cond = None
    if variables and draw(st.integers(0, 2)) == 0:
        name, domain = draw(st.sampled_from(variables))
        if isinstance(domain[0], int):
            cond = (name, draw(st.sampled_from([">", "=<", "=\\="])), draw(st.integers(0, 3)))
        else:
            cond = (name, draw(st.sampled_from(["==", "\\=="])), domain[0])
    kind = draw(st.sampled_from(["c_mem", "memorize"]))
    template = None
    if kind == "memorize" and draw(st.integers(0, 3)) > 0:
        args = draw(st.lists(st.sampled_from([("var", v) for v, _ in variables] + [("const", "z")]),
                             min_size=1, max_size=3))
        template = ("t", args)
    n = None if unlimited else draw(st.one_of(st.none(), st.integers(1, 6)))
    limit = None
    if kind == "c_mem" and not unlimited:
        limit = draw(st.one_of(st.none(), st.sampled_from([0, 1, 1.5, 2, 3, 5, 8])))
    ident = f"m{index}" if index % 2 == 0 else f"m({index})"
    return MemorySpec(ident, kind, type_name, pattern, cond, template, n, limit)


@st.composite
def record_query(draw, functor, domains, bare_ok=True, timed_iv=False, seed: Optional[Record] = None):
    """A pattern for records of this shape: partially bound, possibly with its times. The
    constants come from the record `seed` (when given and of this shape) or the domains."""
    seed_args = None
    if seed is not None and isinstance(seed.value, tuple) and seed.value[0] == functor \
            and len(seed.value[1]) == len(domains):
        seed_args = seed.value[1]
    if bare_ok and draw(st.integers(0, 6)) == 0:
        inner = ("var", "E")
    else:
        names: List[str] = []
        args = []
        for i, d in enumerate(domains):
            choice = draw(st.integers(0, 9))
            if choice <= 4:
                names.append(f"V{len(names)}")
                args.append(("var", names[-1]))
            elif choice == 5 and names:
                args.append(("var", draw(st.sampled_from(names))))       # a repeated variable
            elif choice <= 8 and seed_args is not None:
                args.append(("const", seed_args[i]))
            elif choice <= 8:
                args.append(("const", draw(st.sampled_from(d))))
            else:
                args.append(("const", draw(st.sampled_from(list(d) + [9]))))
        inner = ("term", functor, args)

    def time_term(name, seed_time):
        choice = draw(st.integers(0, 7))
        if choice <= 4:
            return ("var", name)
        if choice <= 6 and seed is not None:
            return ("const", seed_time)
        return ("const", draw(st.integers(0, 14)))
    start, end = (seed.start, seed.end) if seed is not None else (None, None)
    if timed_iv:
        return Query(inner, ("iv", time_term("S", start), time_term("T", end)))
    form = draw(st.sampled_from(["none", "pt", "iv", "iv"]))
    if form == "none":
        return Query(inner)
    if form == "pt":
        return Query(inner, ("pt", time_term("T", end)))
    return Query(inner, ("iv", time_term("S", start), time_term("T", end)))


time_point = st.one_of(st.integers(-1, 15), st.integers(-1, 15).map(lambda i: i + 0.5))


@st.composite
def deliveries(draw, evs, retract=True):
    """The events in a random arrival order with random retractions of present events."""
    order = draw(st.permutations(evs))
    ops: List[Tuple[str, Event]] = []
    present: List[Event] = []
    for event in order:
        ops.append(("add", event))
        present.append(event)
        while retract and present and draw(st.integers(0, 3)) == 0:
            gone = present.pop(draw(st.integers(0, len(present) - 1)))
            ops.append(("retract", gone))
    return ops


# ---- running -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def engine():
    return Engine.from_source(PROGRAM, "slr_oracle.rtl")


def _reset(engine: Engine, specs: List[MemorySpec], record_events: bool = False) -> None:
    engine.bridge.once(f"retalis:rtl_use_program({engine.module})")   # other tests may load programs
    engine.clear()
    engine.memory("d_mem(_)")
    for spec in specs:
        engine.memory(spec.request(record_events))


def _feed(engine: Engine, ops: List[Tuple[str, Event]]) -> None:
    engine.feed_batch([(e.text(), e.start, e.end, op) for op, e in ops])


def _texts(answers: List[dict]) -> List[dict]:
    return [{k: text(v) for k, v in a.items()} for a in answers]


@st.composite
def query_cases(draw, specs: List[MemorySpec], model: Model):
    """(goal text, at, model evaluation as a function of the Model). Constants and time
    points are often taken from a record the memory holds (a time point exactly at, just
    before or just after its end), so that the queries are not mostly about nothing."""
    def seed_of(records):
        return draw(st.sampled_from(records)) if records and draw(st.integers(0, 9)) < 8 else None

    def point(seed):
        if seed is not None and draw(st.booleans()):
            return seed.end + draw(st.sampled_from([-0.5, 0, 0, 0.5]))
        return draw(time_point)

    cases = []
    for _ in range(draw(st.integers(8, 16))):
        spec = draw(st.sampled_from(specs))
        functor, domains = spec.shape()
        what = draw(st.sampled_from(["mem", "mem", "mem_any", "access_mem", "prev", "prev", "prev_any",
                                     "prev5", "next", "next", "next_any", "next6", "next_inf",
                                     "stream_prev", "stream_next", "stream_next2"]))
        if what.startswith("stream"):
            functor = draw(st.sampled_from(sorted(TYPES)))
            domains = TYPES[functor]
            seed = seed_of(model.streams[functor].records(model.clock))
        else:
            seed = seed_of(model.records(spec.ident))
        at = draw(st.one_of(st.none(), st.just(point(seed))))
        zs = point(seed)
        ze = draw(st.one_of(st.just(point(seed)), st.just(float("inf"))))
        if zs > ze and draw(st.booleans()):
            zs, ze = ze, zs
        if what in ("mem", "mem_any"):
            q = draw(record_query(functor, domains, seed=seed))
            if what == "mem":
                cases.append((f"mem({spec.ident}, {q.text()})", at, lambda m, s=spec, q=q, at=at: m.mem(s.ident, q, at)))
            else:
                cases.append((f"mem(Id, {q.text()})", at,
                              lambda m, q=q, at=at: m.mem(None, q, at, "Id")))
        elif what == "access_mem":
            q = draw(record_query(functor, domains, timed_iv=True, seed=seed))
            goal = f"access_mem({spec.ident}, {pattern_text(q.inner)}, [{pattern_text(q.times[1])}, {pattern_text(q.times[2])}])"
            cases.append((goal, at, lambda m, s=spec, q=q, at=at: m.mem(s.ident, q, at)))
        elif what in ("prev", "prev_any"):
            q = draw(record_query(functor, domains, seed=seed))
            ident = spec.ident if what == "prev" else "Id"
            cases.append((f"prev({ident}, {q.text()}, {number_text(zs)})", at,
                          lambda m, s=spec, q=q, zs=zs, w=what: m.prev(s.ident, q, zs) if w == "prev"
                          else m.prev(None, q, zs, "Id")))
        elif what == "prev5":
            q = draw(record_query(functor, domains, timed_iv=True, seed=seed))
            goal = (f"prev({spec.ident}, {pattern_text(q.inner)}, {pattern_text(q.times[1])}, "
                    f"{pattern_text(q.times[2])}, {number_text(zs)})")
            cases.append((goal, at, lambda m, s=spec, q=q, zs=zs: m.prev(s.ident, q, zs)))
        elif what in ("next", "next_any"):
            q = draw(record_query(functor, domains, seed=seed))
            ident = spec.ident if what == "next" else "Id"
            cases.append((f"next({ident}, {q.text()}, {number_text(zs)}, {number_text(ze)})", at,
                          lambda m, s=spec, q=q, zs=zs, ze=ze, w=what: m.next(s.ident, q, zs, ze) if w == "next"
                          else m.next(None, q, zs, ze, "Id")))
        elif what in ("next6", "next_inf"):
            q = draw(record_query(functor, domains, timed_iv=True, seed=seed))
            times = f"{pattern_text(q.times[1])}, {pattern_text(q.times[2])}"
            if what == "next6":
                goal = f"next({spec.ident}, {pattern_text(q.inner)}, {times}, {number_text(zs)}, {number_text(ze)})"
            else:
                goal, ze = f"next_inf({spec.ident}, {pattern_text(q.inner)}, {times}, {number_text(zs)})", float("inf")
            cases.append((goal, at, lambda m, s=spec, q=q, zs=zs, ze=ze: m.next(s.ident, q, zs, ze)))
        else:
            q = draw(record_query(functor, domains, bare_ok=False, seed=seed))
            if what == "stream_prev":
                cases.append((f"prev({q.text()}, {number_text(zs)})", at, lambda m, q=q, zs=zs: m.stream_prev(q, zs)))
            elif what == "stream_next":
                cases.append((f"next({q.text()}, {number_text(zs)}, {number_text(ze)})", at,
                              lambda m, q=q, zs=zs, ze=ze: m.stream_next(q, zs, ze)))
            else:
                cases.append((f"next({q.text()}, [{number_text(zs)}, {number_text(ze)}])", at,
                              lambda m, q=q, zs=zs, ze=ze: m.stream_next(q, zs, ze)))
    return cases


def _describe(specs, ops) -> str:
    lines = [s.request() for s in specs]
    lines += [f"{op} {e.text()}^[{e.start},{e.end}]" for op, e in ops]
    return "\n".join(lines)


SETTINGS = settings(max_examples=EXAMPLES, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                           HealthCheck.data_too_large])


@SETTINGS
@given(st.data())
def test_queries_agree_with_the_model(engine, data):
    evs = data.draw(events(), label="events")
    types = {e.name for e in evs}
    specs = [data.draw(memory_spec(i, types), label=f"memory {i}") for i in range(data.draw(st.integers(1, 3)))]
    ops = data.draw(deliveries(evs), label="delivery")
    _reset(engine, specs)
    _feed(engine, ops)
    model = Model(specs + STREAMS)
    model.run(ops)
    story = _describe(specs, ops)

    if all(op == "add" for op, _ in ops):          # the model agrees with Def. 21 read directly
        arrivals = list(enumerate(e for _, e in ops))
        for s in specs:
            assert model.records(s.ident) == model.memories[s.ident].held_by_definition(arrivals, model.clock)

    for s in specs:                                   # the whole memory, in end-time order
        expected = [{"E": text(r.value), "S": text(r.start), "T": text(r.end)} for r in model.records(s.ident)]
        assert engine.query_all(f"mem({s.ident}, E^[S, T])") == expected, f"{s.ident}\n{story}"
    for goal, at, evaluate in data.draw(query_cases(specs, model), label="queries"):
        expected = _texts(evaluate(model))
        assert engine.query_all(goal, at=at) == expected, f"{goal} at {at}\n{story}"


def _assert_same_answers(engine, data, specs, shuffled, in_order) -> None:
    """The queries drawn for these memories answer the same after both deliveries."""
    model = Model(specs + STREAMS)
    model.run(shuffled)
    cases = data.draw(query_cases(specs, model), label="queries")
    goals = [(f"mem({s.ident}, E^[S, T])", None) for s in specs] + [(goal, at) for goal, at, _ in cases]
    answers = []
    for ops in (in_order, shuffled):
        _reset(engine, specs)
        _feed(engine, ops)
        answers.append([engine.query_all(goal, at=at) for goal, at in goals])
    assert answers[0] == answers[1], _describe(specs, shuffled)


@settings(SETTINGS, max_examples=max(EXAMPLES // 2, 1))
@given(st.data())
def test_arrival_order_does_not_matter_without_forgetting(engine, data):
    """N = inf, L = inf: the same events (distinct end times, so no ties to order) delivered
    in end-time order, then the retractions, give the same answers as any interleaving."""
    evs = data.draw(events(unique_ends=True), label="events")
    types = {e.name for e in evs}
    specs = [data.draw(memory_spec(i, types, unlimited=True), label=f"memory {i}")
             for i in range(data.draw(st.integers(1, 3)))]
    shuffled = data.draw(deliveries(evs), label="delivery")
    retracted = [e for op, e in shuffled if op == "retract"]
    in_order = [("add", e) for e in sorted(evs, key=lambda e: e.end)] + [("retract", e) for e in retracted]
    _assert_same_answers(engine, data, specs, shuffled, in_order)


def test_the_model_is_not_trivial(engine):
    """A stream where count forgetting, a late arrival, a retraction and a partially bound
    prev all matter, checked against answers written by hand."""
    spec = MemorySpec("m0", "c_mem", "a", (("var", "X0"), ("var", "X1")), None, None, 2, None)
    ops = [("add", Event("a", ("p", 1), 5, 5)), ("add", Event("a", ("q", 2), 7, 7)),
           ("add", Event("a", ("p", 3), 6, 6)),        # late: goes between, forgets p(1)@5
           ("add", Event("a", ("q", 0), 4, 4)),        # older than both: forgotten at once
           ("retract", Event("a", ("q", 2), 7, 7))]    # frees a place; p(1)@5 does not come back
    _reset(engine, [spec])
    _feed(engine, ops)
    model = Model([spec] + STREAMS)
    model.run(ops)
    assert [text(r.value) for r in model.records("m0")] == ["a(p,3)"]
    assert engine.query_all("mem(m0, E)") == [{"E": "a(p,3)"}]
    assert engine.query_all("prev(a(q, X)^T, 10)") == [{"X": "0", "T": "4"}]     # the stream keeps all
    assert _texts(model.stream_prev(Query(("term", "a", [("const", "q"), ("var", "X")]), ("pt", ("var", "T"))), 10)) \
        == [{"X": "0", "T": "4"}]


# ---- memory events (thesis 4.2.4) ---------------------------------------------------------

def _announced(model: Model, idents: List[str], before: Dict[str, List[Record]]) -> Counter:
    """What the memory events of one input must say: every record a memory holds now and did
    not hold before was added, every one it held before and holds no more was forgotten
    (by count, by time as the clock moved, or by a deletion)."""
    out: Counter = Counter()
    for i in idents:
        old, new = Counter(before[i]), Counter(model.records(i))
        for r, k in (new - old).items():
            out[("added", i, text(r.value))] += k
        for r, k in (old - new).items():
            out[("forgotten", i, text(r.value))] += k
    return out


@settings(SETTINGS, max_examples=max(EXAMPLES // 3, 1))
@given(st.data())
def test_memory_events_announce_every_change_when_it_happens(engine, data):
    """Items 1 and 2 of issue 40: memory_record_added/forgotten say exactly how the records
    of a memory (with record_events(true)) change with each input, in that input: a record
    leaves by its time limit when the clock moves beyond it (whatever event moved it), and a
    late record that a full memory does not keep is neither added nor forgotten."""
    evs = data.draw(events(), label="events")
    types = {e.name for e in evs}
    specs = []
    for i in range(data.draw(st.integers(1, 2))):
        spec = data.draw(memory_spec(i, types), label=f"memory {i}")
        specs.append(MemorySpec(spec.ident, "c_mem", spec.type_name, spec.pattern, spec.cond, None, spec.n,
                                data.draw(st.one_of(st.none(), st.sampled_from([0, 1, 2, 3.5, 5])), label="L")))
    ops = data.draw(deliveries(evs), label="delivery")
    _reset(engine, specs, record_events=True)
    model = Model(specs)
    idents = [s.ident for s in specs]
    story = "\n".join(s.request(True) for s in specs)
    for op, event in ops:
        before = {i: list(model.records(i)) for i in idents}
        model.run([(op, event)])
        produced = engine.feed(event.text(), event.start, event.end, op)
        said = Counter((o.name, text(_value(o.args[0])), text(_value(o.args[1]))) for o in produced
                       if o.op == "add" and o.name in ("added", "forgotten"))
        story += f"\n{op} {event.text()}^[{event.start},{event.end}]"
        assert said == _announced(model, idents, before), story


def _value(arg) -> Value:
    """An argument of an output event (engine.Term, atom str or number) as a Value."""
    if isinstance(arg, (str, int)):
        return arg
    return (arg.name, tuple(_value(a) for a in arg.args))


@settings(SETTINGS, max_examples=max(EXAMPLES // 3, 1))
@given(st.data())
def test_arrival_order_does_not_show_through_ties_or_limits(engine, data):
    """Item 6 of issue 40: without deletions what a memory holds is a function of the events
    (Def. 21), equal end times and count and time limits included, so any arrival order gives
    the answers of the end-time order."""
    evs = data.draw(events(), label="events")
    types = {e.name for e in evs}
    specs = [data.draw(memory_spec(i, types), label=f"memory {i}") for i in range(data.draw(st.integers(1, 3)))]
    shuffled = data.draw(deliveries(evs, retract=False), label="delivery")
    in_order = [("add", e) for e in sorted(evs, key=lambda e: e.end)]
    _assert_same_answers(engine, data, specs, shuffled, in_order)


def test_a_record_leaves_by_time_at_the_clock_move_that_passes_it():
    """Issue 40 item 1: L = 4, p(1)@1 then z(1)@10: forgotten at z(1)@10, not at the next p."""
    e = Engine.from_source("c_mem(m, p(_)-[], inf, 4, [record_events(true)]).\n"
                           "forgotten(R) <- memory_record_forgotten(m, R).\n")
    assert [o.event for o in e.feed("p(1)", 1)] == []
    assert [o.event for o in e.feed("z(1)", 10)] == ["forgotten(p(1))"]
    assert e.query_all("mem(m, X)") == []
    assert [o.event for o in e.feed("p(5)", 13)] == []
    e.feed("p(6)", 15)
    e.feed("p(7)", 19)                               # 15 + 4 is not before 19: p(6) stays
    assert e.query_all("mem(m, p(X))") == [{"X": "6"}, {"X": "7"}]
    assert [o.event for o in e.advance_clock(30)] == ["forgotten(p(6))", "forgotten(p(7))"]   # a heartbeat too


def test_a_late_record_a_full_memory_does_not_keep_raises_nothing():
    """Issue 40 item 2: N = 1, p(2)@2 then the late p(1)@1: no event at all for p(1)."""
    e = Engine.from_source("c_mem(m, p(_)-[], 1, inf, [record_events(true)]).\n"
                           "added(R) <- memory_record_added(m, R).\n"
                           "forgotten(R) <- memory_record_forgotten(m, R).\n")
    assert [o.event for o in e.feed("p(2)", 2)] == ["added(p(2))"]
    assert [o.event for o in e.feed("p(1)", 1)] == []
    assert e.query_all("mem(m, p(X))") == [{"X": "2"}]


def test_equal_end_times_are_ordered_by_start_then_record_not_by_arrival():
    """Issue 40 item 6: with N = 2 and three records ending at 5, either arrival order keeps
    the two greatest by (start, standard order), and prev at 5 answers the greatest."""
    answers = []
    for order in (["p(c)", "p(a)", "p(b)"], ["p(b)", "p(c)", "p(a)"]):
        e = Engine.from_source("c_mem(m, p(_)-[], 2, inf).\n")
        for ev in order:
            e.feed(ev, 5)
        e.feed("p(z)", 4, 5)                          # starts earlier: goes first, and is forgotten
        answers.append((e.query_all("mem(m, p(X))"), e.query("prev(m, p(X), 5)")))
    assert answers[0] == answers[1] == ([{"X": "b"}, {"X": "c"}], {"X": "c"})


def test_e_caret_t_binds_the_end_time_as_in_event_patterns():
    """Issue 40 item 6: an instant given as start 2, end 2.0, and an interval [1, 3]."""
    e = Engine.from_source("c_mem(m, p(_)-[], inf, inf).\n")
    e.feed("p(1)", 2, 2.0)
    e.feed("p(2)", 1, 3)
    assert e.query_all("mem(m, p(X)^T)") == [{"X": "1", "T": "2.0"}, {"X": "2", "T": "3"}]
    assert e.query("prev(m, p(X)^T, 3)") == {"X": "2", "T": "3"}


def test_engine_memory_accepts_c_mem_5_and_checks_its_options():
    """Issue 40 item 6: Engine.memory() takes the c_mem/5 form programs accept."""
    e = Engine.from_source("added(R) <- memory_record_added(m, R).\n")
    e.memory("c_mem(m, p(_)-[], inf, inf, [record_events(true)])")
    assert [o.event for o in e.feed("p(1)", 1)] == ["added(p(1))"]
    with pytest.raises(Exception, match="record_events"):
        e.memory("c_mem(m2, p(_)-[], inf, inf, [record_events(maybe)])")
