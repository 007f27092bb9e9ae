"""Tabled Optimized transformation (thesis 6.6).

Every sub-goal on a predicate with rules goes through a table shared by all active queries,
keyed by variant (or reusing a subsuming table with `subsumption=True`); facts are resolved in
place.  A predicate with both rules and facts gets one more rule that reads its stored facts.
The runtime (`prolog_runtime/rtl_aq.pl`, mode `tabled`) makes tabling answer-invariant,
propagates additions and deletes with basic DRed.
"""
from __future__ import annotations

from .aq_program import Program
from .aq_optimized import classify_literals

name = "aq_tabled"


def run(program: Program, subsumption: bool = False) -> Program:
    program = classify_literals(program, facts_as_tables=False)
    program.mode = "tabled"
    program.subsumption = subsumption
    return program
