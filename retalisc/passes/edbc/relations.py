"""The temporal relation and result interval of each binary operator (docs/language.md has
the same table)."""
from __future__ import annotations

from typing import Dict, List, Tuple

from ...frontend.terms import Compound, Term, Var

# Temporal relation and result interval of each binary operator, on the intervals
# [S1, E1] (left) and [S2, E2] (right), as terms over these variable names (renamed per rule).
_S1, _E1, _S2, _E2 = Var("S1"), Var("E1"), Var("S2"), Var("E2")


def _lt(a: Term, b: Term) -> Term:
    return Compound("<", (a, b))


def _eq(a: Term, b: Term) -> Term:
    return Compound("=:=", (a, b))


_MIN, _MAX = Compound("min", (_S1, _S2)), Compound("max", (_E1, _E2))

RELATIONS: Dict[str, Tuple[List[Term], Term, Term]] = {
    "seq": ([_lt(_E1, _S2)], _S1, _E2),
    "and": ([], _MIN, _MAX),
    "par": ([_lt(_S1, _E2), _lt(_S2, _E1)], _MIN, _MAX),
    "equals": ([_eq(_S1, _S2), _eq(_E1, _E2)], _S1, _E1),
    "meets": ([_eq(_E1, _S2)], _S1, _E2),
    "during": ([_lt(_S2, _S1), _lt(_E1, _E2)], _S2, _E2),
    "starts": ([_eq(_S1, _S2), _lt(_E1, _E2)], _S1, _E2),
    "finishes": ([_eq(_E1, _E2), _lt(_S2, _S1)], _S2, _E1),
    "cnot": ([_lt(_E1, _S2)], _S1, _E2),
}
