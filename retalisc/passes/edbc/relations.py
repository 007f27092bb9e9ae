"""The temporal relations of the operators, from the runtime's table
(prolog_runtime/rtl_relations.pl, read by retalisc/frontend/relations.py), which `retalisc
explain` evaluates too: the comparisons and result interval of each binary operator, what
blocks a negation, an absence's result and a window, as goals over the canonical time
variables (S1-E1 left, S2-E2 right, SN-EN blocker), renamed per rule by the generator."""
from __future__ import annotations

from typing import List, Tuple

from ...frontend.relations import relation_table
from ...frontend.terms import Term, Var, substitute, variables


def relation(op: str) -> Tuple[List[Term], Term, Term]:
    """The comparisons on [S1, E1] (left) and [S2, E2] (right) under which `op` holds, and
    the start and end of its result."""
    return relation_table().relations[op]


def blocker(op: str) -> List[Term]:
    """The comparisons under which a negated event over [SN, EN] blocks a match of `op`."""
    return relation_table().blockers[op]


def blocker_window(op: str) -> Tuple[Term, Term]:
    """The span [From, To] of a blocker of `op` that a window bounds."""
    return relation_table().blocker_windows[op]


def absence_result() -> Tuple[Term, Term]:
    """The start and end of an absence's result, over S1, E1 and the duration D."""
    return relation_table().absence_result


def window_goal(start: Term, end: Term, length: Term) -> Term:
    """The goal by which [start, end] fits the window `length`."""
    return substitute(relation_table().window, {"From": start, "To": end, "W": length})


def over(goals: List[Term], names: set) -> List[Term]:
    """The goals whose variables all have one of `names` (canonical names)."""
    return [g for g in goals if {v.name for v in variables(g)} <= names]


def plain_var(term: Term, what: str) -> Var:
    """A result bound that must be one of the operands' own (a variable)."""
    if not isinstance(term, Var):
        raise ValueError(f"rtl_relations.pl: the {what} must be an operand's start or end, not {term}")
    return term
