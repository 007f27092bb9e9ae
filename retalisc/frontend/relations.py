"""The temporal relations of the operators, as the runtime's table
`prolog_runtime/rtl_relations.pl` says: the compiler's pass `edbc` compiles them into the
clauses of every step, and `retalisc explain` (rtl_trace.pl) evaluates the rules' patterns with
the same facts. Read from the runtime that comes with this package.

The intervals of a fact are renamed by position to the names the compiler uses: the left
operand's S1-E1, the right one's S2-E2, a blocker's SN-EN, an absence's duration D, a window W
over [From, To]."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Dict, List, Tuple

from ..runtime_location import bundled_runtime_dir
from .parser import read_program
from .terms import Atom, Compound, Term, Var, list_items, substitute

RELATIONS_FILE = "rtl_relations.pl"


@dataclass(frozen=True)
class RelationTable:
    #: binary operator -> (comparisons on S1, E1, S2, E2; the result's start; its end)
    relations: Dict[str, Tuple[List[Term], Term, Term]]
    #: negation (`cnot`, `fnot`, `absence`) -> the comparisons under which SN-EN blocks its match
    blockers: Dict[str, List[Term]]
    #: negation -> (From, To): the span of a blocker that a window bounds
    blocker_windows: Dict[str, Tuple[Term, Term]]
    #: the interval of an absence's result, over S1, E1 and D
    absence_result: Tuple[Term, Term]
    #: the goal by which [From, To] fits the window W
    window: Term


def _interval(term: Term, start: str, end: str, names: Dict[str, Term]) -> None:
    """Name the variables of the interval `term` (S-E, or `none`)."""
    if term == Atom("none"):
        return
    if not (isinstance(term, Compound) and term.name == "-" and term.arity == 2
            and all(isinstance(a, Var) for a in term.args)):
        raise ValueError(f"{RELATIONS_FILE}: not an interval Start-End: {term}")
    for var, name in zip(term.args, (start, end)):
        _name(var, name, names)


def _name(var: Term, name: str, names: Dict[str, Term]) -> None:
    if not isinstance(var, Var):
        raise ValueError(f"{RELATIONS_FILE}: not a variable: {var}")
    names[var.name] = Var(name)


def _goals(term: Term, names: Dict[str, Term]) -> List[Term]:
    items = list_items(term)
    if items is None:
        raise ValueError(f"{RELATIONS_FILE}: not a list of goals: {term}")
    return [substitute(item, names) for item in items]


@lru_cache(maxsize=None)
def relation_table() -> RelationTable:
    path = bundled_runtime_dir() / RELATIONS_FILE
    relations: Dict[str, Tuple[List[Term], Term, Term]] = {}
    blockers: Dict[str, List[Term]] = {}
    blocker_windows: Dict[str, Tuple[Term, Term]] = {}
    absence_result = window = None
    for read in read_program(path.read_text(encoding="utf-8"), str(path)):
        term = read.term
        if isinstance(term, Compound) and term.name == ":-" and term.arity == 1:
            continue                                            # the module directive
        names: Dict[str, Term] = {}
        key = (term.name, term.arity) if isinstance(term, Compound) else None
        if key in (("rtl_relation", 6), ("rtl_blocker", 5), ("rtl_blocker_window", 5)) \
                and not isinstance(term.args[0], Atom):
            raise ValueError(f"{RELATIONS_FILE}: not an operator name: {term.args[0]}")
        if key == ("rtl_relation", 6):
            op, left, right, goals, start, end = term.args
            _interval(left, "S1", "E1", names)
            _interval(right, "S2", "E2", names)
            relations[op.name] = (_goals(goals, names), substitute(start, names), substitute(end, names))
        elif key == ("rtl_blocker", 5):
            op, left, right, blocker, goals = term.args
            _interval(left, "S1", "E1", names)
            _interval(right, "S2", "E2", names)
            _interval(blocker, "SN", "EN", names)
            blockers[op.name] = _goals(goals, names)
        elif key == ("rtl_blocker_window", 5):
            op, left, blocker, start, end = term.args
            _interval(left, "S1", "E1", names)
            _interval(blocker, "SN", "EN", names)
            blocker_windows[op.name] = (substitute(start, names), substitute(end, names))
        elif key == ("rtl_absence_result", 4):
            left, duration, start, end = term.args
            _interval(left, "S1", "E1", names)
            _name(duration, "D", names)
            absence_result = (substitute(start, names), substitute(end, names))
        elif key == ("rtl_window", 4):
            start, end, length, goal = term.args
            for var, name in zip((start, end, length), ("From", "To", "W")):
                _name(var, name, names)
            window = substitute(goal, names)
        else:
            raise ValueError(f"{RELATIONS_FILE}: not a fact of the table: {term}")
    if absence_result is None or window is None:
        raise ValueError(f"{RELATIONS_FILE}: rtl_absence_result/4 or rtl_window/4 is missing")
    return RelationTable(relations, blockers, blocker_windows, absence_result, window)
