"""Pass `slr_stream_histories`: keep the histories the stream forms of prev and next query.

`prev(E, Zs)`, `next(E, Zs, Ze)` and `next(E, [Zs, Ze])` (thesis Def. 19-20) query the whole
stream of events of E's type, so the runtime must keep that history. For every event type
such a query names in a static clause, a `where` condition or an action, this pass adds the
start-up declaration `stream_history(Name/Arity)` (everything, no limit), unless the program
declares `stream_history(Name/Arity, N, L)` for that type itself.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Dict, Optional, Tuple

from ..frontend.program import Declaration, Directive, EventRule, StaticClause, pattern_conditions
from ..frontend.terms import Atom, Compound, Number, Term, list_items, span_of, walk
from .unit import Unit

name = "slr_stream_histories"


def run(unit: Unit) -> Unit:
    wanted: Dict[Tuple[str, int], Compound] = {}
    declared = set()
    for clause in unit.program.clauses:
        for term in _code_of(clause):
            for sub in walk(term):
                found = _stream_query_type(sub)
                if found is not None and found not in wanted:
                    wanted[found] = sub
        goal = getattr(clause, "goal", None) if isinstance(clause, (Declaration, Directive)) else None
        if isinstance(goal, Compound) and goal.name == "stream_history" and goal.arity in (1, 3):
            kind = _indicator(goal.args[0])
            if kind is not None:
                declared.add(kind)
    added = []
    for (functor, arity), query in wanted.items():
        if (functor, arity) in declared:
            continue
        span = span_of(query)
        goal = Compound("stream_history", (Compound("/", (Atom(functor), Number(arity))),), span)
        added.append(Declaration(goal, span, f"stream_history({functor}/{arity})"))
    if added:
        unit.program = replace(unit.program, clauses=added + list(unit.program.clauses))
    return unit


def _code_of(clause):
    if isinstance(clause, StaticClause):
        yield clause.term
    elif isinstance(clause, EventRule):
        if clause.action is not None:
            yield clause.action
        yield from pattern_conditions(clause.pattern)


def _stream_query_type(term: Term) -> Optional[Tuple[str, int]]:
    if not isinstance(term, Compound):
        return None
    if (term.name, term.arity) not in (("prev", 2), ("next", 3), ("next", 2)):
        return None
    if term.name == "next" and term.arity == 2 and list_items(term.args[1]) is None:
        return None
    event = term.args[0]
    if isinstance(event, Compound) and event.name == "^" and event.arity == 2:
        event = event.args[0]
    if isinstance(event, Atom):
        return (event.name, 0)
    if isinstance(event, Compound):
        return (event.name, event.arity)
    return None


def _indicator(term: Term) -> Optional[Tuple[str, int]]:
    if (isinstance(term, Compound) and term.name == "/" and term.arity == 2 and isinstance(term.args[0], Atom)
            and isinstance(term.args[1], Number)):
        return (term.args[0].name, int(term.args[1].value))
    return None
