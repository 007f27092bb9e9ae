"""Tabled Optimized transformation (thesis 6.6).

Every sub-goal on a predicate with rules goes through a table shared by all active queries,
keyed by variant (or reusing a subsuming table with `subsumption=True`); facts are resolved in
place.  A predicate with both rules and facts gets one more rule that reads its stored facts.
The runtime (`prolog_runtime/rtl_aq.pl`, mode `tabled`) makes tabling answer-invariant,
propagates additions and deletes with basic DRed.
"""
from __future__ import annotations

from .aq_optimized import classify_literals
from .unit import AqUnit

name = "aq_tabled"
mode = "tabled"  # runs only when this transformation is asked for


def run(unit: AqUnit) -> AqUnit:
    program = unit.program = classify_literals(unit.program, facts_as_tables=False)
    program.mode = mode
    program.subsumption = unit.subsumption
    return unit
