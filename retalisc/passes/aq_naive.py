"""Naive transformation (thesis 6.4): EDBC rules per query.

Every user literal goes through a table that is local to the query id and holds the complete
relation of its predicate (the EDBC rules derive every fact of the relevant predicate set,
bottom-up); stored facts are copied into such tables when a query is registered (the
initialisation step: add(f) for every relevant fact).  Only the query's own goal keeps its
bindings (the substituted EDBC_s rules of Def. 34).  Unregistering removes the query's rules,
tables and goal records.
"""
from __future__ import annotations

from .aq_optimized import classify_literals
from .unit import AqUnit

name = "aq_naive"
mode = "naive"  # runs only when this transformation is asked for


def run(unit: AqUnit) -> AqUnit:
    program = unit.program = classify_literals(unit.program, facts_as_tables=True)
    program.mode = mode
    program.subsumption = False
    return unit
