"""Pass `slr_time_terms`: time terms `E^T` and `E^[T1, T2]` in goal positions (thesis 4.2.3).

SLR writes the time of a state-based fact as `color(O, C)^T :- prev(obj(O, C)^Z, T).`: the
clause defines `color/2` at time T. Following the thesis's event terms (Def. 10: the start
and end times are the last two arguments), the clause head and every goal `E^[T1, T2]`
becomes `E` with `T1, T2` appended, and `E^T` becomes `E` with `T, T` appended. The rewrite
applies to static clauses, `where` conditions and actions, through the goal arguments of the
control constructs and meta-predicates listed in `prolog_runtime/rtl_goal_arguments.pl`, the
table the runtime rewrites the queries from outside with (rtl_query.pl, rtl_time_goal/2).
Inside prev, next and mem the `^` is data for the runtime and stays.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Optional

from ..frontend.program import Absence, Sliding, Check, EventRule, StaticClause, Where, Binary, Negation, Window, Aggregate
from ..frontend.goal_arguments import goal_arguments
from ..frontend.terms import Atom, Compound, Term, list_items, span_of
from .unit import Unit

name = "slr_time_terms"

def run(unit: Unit) -> Unit:
    clauses = []
    for clause in unit.program.clauses:
        if isinstance(clause, StaticClause):
            clauses.append(replace(clause, term=_clause(clause.term)))
        elif isinstance(clause, EventRule):
            action = timed_goal(clause.action) if clause.action is not None else None
            clauses.append(replace(clause, pattern=_pattern(clause.pattern), action=action))
        else:
            clauses.append(clause)
    unit.program = replace(unit.program, clauses=clauses)
    return unit


def _clause(term: Term) -> Term:
    if isinstance(term, Compound) and term.name == ":-" and term.arity == 2:
        head, body = term.args
        return Compound(":-", (_timed(head) or head, timed_goal(body)), term.span)
    return _timed(term) or term


def _pattern(pattern):
    if isinstance(pattern, (Where, Check)):
        return replace(pattern, pattern=_pattern(pattern.pattern), condition=timed_goal(pattern.condition))
    if isinstance(pattern, Binary):
        return replace(pattern, left=_pattern(pattern.left), right=_pattern(pattern.right))
    if isinstance(pattern, Window):
        return replace(pattern, pattern=_pattern(pattern.pattern))
    if isinstance(pattern, Negation):
        return replace(pattern, negated=_pattern(pattern.negated), first=_pattern(pattern.first),
                       second=_pattern(pattern.second))
    if isinstance(pattern, Absence):
        return replace(pattern, negated=_pattern(pattern.negated), first=_pattern(pattern.first))
    if isinstance(pattern, Sliding):
        return replace(pattern, pattern=_pattern(pattern.pattern))
    if isinstance(pattern, Aggregate):
        return replace(pattern, pattern=_pattern(pattern.pattern))
    return pattern


def timed_goal(goal: Term) -> Term:
    """`goal` with its time terms rewritten (see the module docstring)."""
    timed = _timed(goal)
    if timed is not None:
        return timed
    if isinstance(goal, Compound):
        positions = goal_arguments().get((goal.name, goal.arity))
        if positions:
            args = tuple(timed_goal(a) if i in positions else a for i, a in enumerate(goal.args))
            return Compound(goal.name, args, goal.span)
    return goal


def _timed(term: Term) -> Optional[Term]:
    """`E^T` / `E^[T1, T2]` as `E(..., T1, T2)`; None for anything else."""
    if not (isinstance(term, Compound) and term.name == "^" and term.arity == 2):
        return None
    event, time = term.args
    if not isinstance(event, (Atom, Compound)):
        return None
    times = list_items(time)
    start, end = (times[0], times[1]) if times is not None and len(times) == 2 else (time, time)
    args = event.args if isinstance(event, Compound) else ()
    return Compound(event.name, tuple(args) + (start, end), span_of(event) or term.span)
