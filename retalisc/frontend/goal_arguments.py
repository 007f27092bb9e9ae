"""Which arguments of the control constructs and meta-predicates are goals, as the runtime's
table `prolog_runtime/rtl_goal_arguments.pl` says: the compiler's pass `slr_time_terms` rewrites
the time terms in these arguments, as the runtime does in the queries from outside
(rtl_query.pl, rtl_time_goal/2). Read from the runtime that comes with this package."""
from __future__ import annotations

from functools import lru_cache
from typing import Dict, Tuple

from ..runtime_location import bundled_runtime_dir
from .parser import read_program
from .terms import Atom, Compound, Number, Term, list_items

GOAL_ARGUMENTS_FILE = "rtl_goal_arguments.pl"


@lru_cache(maxsize=None)
def goal_arguments() -> Dict[Tuple[str, int], Tuple[int, ...]]:
    """The goal arguments (0-based positions) of the control constructs and meta-predicates,
    by (name, arity), from the runtime's table `rtl_goal_arguments/3` (1-based there)."""
    path = bundled_runtime_dir() / GOAL_ARGUMENTS_FILE
    table = {}
    for clause in read_program(path.read_text(encoding="utf-8"), str(path)):
        term = clause.term
        if isinstance(term, Compound) and term.name == ":-" and term.arity == 1:
            continue                                            # the module directive
        name, arity, positions = _table_row(term)
        table[(name, arity)] = positions
    return table


def _table_row(term: Term) -> Tuple[str, int, Tuple[int, ...]]:
    if isinstance(term, Compound) and term.name == "rtl_goal_arguments" and term.arity == 3:
        name, arity, positions = term.args
        items = list_items(positions)
        if (isinstance(name, Atom) and isinstance(arity, Number) and items is not None
                and all(isinstance(item, Number) for item in items)):
            return name.name, int(arity.value), tuple(int(item.value) - 1 for item in items)
    raise ValueError(f"{GOAL_ARGUMENTS_FILE}: not a fact rtl_goal_arguments(Name, Arity, Positions): {term}")
