"""Pass `slr_goal_sets`: the dynamic goal set of every static predicate (thesis Def. 28).

A synchronized query `<Goal, Z>` may only run once the histories it can read are complete up
to Z. Which histories those are is known from the program: the memory instances named by the
`mem`, `prev` and `next` terms (and the event types of the stream forms) in the bodies of the
rules through which Goal can be proven. This pass computes that set for every static
predicate, through the call graph, and adds a start-up declaration
`goal_set(Name/Arity, MemoryIds, StreamTypes)` for each predicate whose set is not empty. A
memory id that is not ground in the program (`prev(obj(O), ...)`) stays a pattern: every
instance it may name counts.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Dict, List, Set, Tuple

from ..frontend.program import Declaration, StaticClause
from ..frontend.terms import Atom, Compound, Number, Term, indicator, make_list, span_of, walk
from ..frontend.writer import write_term
from .unit import Unit

name = "slr_goal_sets"

Indicator = Tuple[str, int]

# (name, arity) of a memory query -> the argument holding the memory id
_MEMORY_QUERIES = {("mem", 2): 0, ("prev", 3): 0, ("next", 4): 0, ("prev", 5): 0, ("next", 6): 0,
                   ("next_inf", 5): 0, ("access_mem", 3): 0}
_STREAM_QUERIES = {("prev", 2), ("next", 3), ("next", 2)}


def run(unit: Unit) -> Unit:
    calls: Dict[Indicator, Set[Indicator]] = {}
    memories: Dict[Indicator, Dict[str, Term]] = {}
    streams: Dict[Indicator, Set[Indicator]] = {}
    for clause in unit.program.clauses:
        if not isinstance(clause, StaticClause) or clause.body is None:
            continue
        head = indicator(clause.head)
        if head is None:
            continue
        for term in walk(clause.body):
            key = indicator(term)
            if key is None:
                continue
            calls.setdefault(head, set()).add(key)
            if key in _MEMORY_QUERIES:
                memory_id = term.args[_MEMORY_QUERIES[key]]
                memories.setdefault(head, {})[write_term(memory_id, 999)] = memory_id
            elif key in _STREAM_QUERIES:
                event = term.args[0]
                if isinstance(event, Compound) and event.name == "^" and event.arity == 2:
                    event = event.args[0]
                stream = indicator(event)
                if stream is not None:
                    streams.setdefault(head, set()).add(stream)
    added = []
    for predicate in sorted(calls):
        ids, types = _closure(predicate, calls, memories, streams)
        if not ids and not types:
            continue
        span = span_of(next(c.term for c in unit.program.clauses
                            if isinstance(c, StaticClause) and indicator(c.head) == predicate))
        goal = Compound("goal_set", (_indicator_term(predicate),
                                     make_list([ids[k] for k in sorted(ids)]),
                                     make_list([_indicator_term(t) for t in sorted(types)])), span)
        added.append(Declaration(goal, span, write_term(goal, 999)))
    if added:
        unit.program = replace(unit.program, clauses=list(unit.program.clauses) + added)
    return unit


def _closure(start: Indicator, calls, memories, streams):
    seen: Set[Indicator] = set()
    stack: List[Indicator] = [start]
    ids: Dict[str, Term] = {}
    types: Set[Indicator] = set()
    while stack:
        predicate = stack.pop()
        if predicate in seen:
            continue
        seen.add(predicate)
        ids.update(memories.get(predicate, {}))
        types |= streams.get(predicate, set())
        stack.extend(c for c in calls.get(predicate, ()) if c in calls)
    return ids, types


def _indicator_term(key: Indicator) -> Term:
    return Compound("/", (Atom(key[0]), Number(key[1])))
