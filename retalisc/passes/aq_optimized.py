"""Optimized transformation (thesis 6.5, Algorithms 6-11).

Rules become binary rules whose first step is the activation term e_k0 carrying the sub-goal's
arguments (`'$aq_act'(Head, T)`); facts are resolved in place and the only record is the
goal(a_i, e_ki) record of a state waiting for literal a_i.  Every call activates the relevant
rules afresh, local to the query id (no reuse between sub-goals: left recursion does not
terminate, as the thesis notes).
"""
from __future__ import annotations

import copy

from ..frontend.definite import Literal, Program, Rule
from ..frontend.terms import Atom, Compound, Var
from .unit import AqUnit

name = "aq_optimized"
mode = "optimized"  # runs only when this transformation is asked for


def classify_literals(program: Program, facts_as_tables: bool) -> Program:
    """Copy `program`, mark each user literal `call` (through a table) or `fact` (resolved in
    place), and add the rule `p(X1..Xn) :- <stored p(X1..Xn)>` for every predicate whose stored
    facts are reached through a table (predicates with rules and facts; with `facts_as_tables`,
    every dynamic predicate)."""
    program = copy.deepcopy(program)
    rule_preds = set(program.rule_predicates)
    dynamic = list(program.dynamic)
    tabled_facts = [ind for ind in dynamic if facts_as_tables or ind in rule_preds]
    for rule in program.rules:
        for lit in rule.body:
            if lit.kind == "builtin":
                continue
            lit.kind = "call" if (lit.indicator in rule_preds or lit.indicator in tabled_facts) else "fact"
    next_k = len(program.rules) + 1
    for ind in tabled_facts:
        args = tuple(Var(f"A{i}") for i in range(1, ind[1] + 1))
        head = Compound(ind[0], args) if args else Atom(ind[0])
        program.rules.append(Rule(next_k, head, [Literal(head, "fact")], None,
                                  f"stored facts of {ind[0]}/{ind[1]}", synthetic=True))
        next_k += 1
    return program


def run(unit: AqUnit) -> AqUnit:
    program = unit.program = classify_literals(unit.program, facts_as_tables=False)
    program.mode = mode
    program.subsumption = False
    return unit
