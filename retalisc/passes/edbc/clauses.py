"""The building blocks of generated clauses, shared by every operator family of `edbc`:
terms (`C`, `V`), conjunctions and clauses, the variables of an operand and the join key."""
from __future__ import annotations

from typing import List, Optional, Tuple

from ...frontend.terms import Atom, Compound, Term, Var, distinct_variables, make_list, variables
from ..unit import Operand


def list_term(items: List[Term]) -> Term:
    return make_list(items)


def V(name_: str) -> Var:
    return Var(name_)


def C(name_: str, *args: Term) -> Compound:
    return Compound(name_, tuple(args))


def conj(goals: List[Optional[Term]]) -> Term:
    goals = [g for g in goals if g is not None]
    if not goals:
        return Atom("true")
    result = goals[-1]
    for g in reversed(goals[:-1]):
        result = C(",", g, result)
    return result


def clause(head: Term, body: List[Optional[Term]]) -> Term:
    goals = [g for g in body if g is not None]
    return C(":-", head, conj(goals)) if goals else head


def operand_vars(operand: Operand) -> List[Var]:
    if operand.step is not None:
        return list(operand.step.output.args)
    times = [x for x in (operand.start, operand.end) if isinstance(x, Var)]
    return distinct_variables(v for t in [operand.term, *times, *operand.filters] for v in variables(t))


def split_key(own: List[Var], other: List[Var]) -> Tuple[List[Var], List[Var]]:
    """(key, rest): the variables of `own` shared with `other` (the join key), then the others."""
    other_names = {v.name for v in other}
    key = [v for v in own if v.name in other_names]
    return key, [v for v in own if v.name not in other_names]


def plain_number(value: float):
    return int(value) if float(value).is_integer() else value
