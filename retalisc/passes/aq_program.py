"""aq_program: check that the rule bodies of a definite program are definite (thesis 6.2), and
mark each body literal `builtin`, `call` (a predicate with rules) or `fact` (stored facts only).

Body literals are user predicates or the builtins of `frontend.definite.BUILTINS` (`true` is
dropped). Everything else that is not definite (negation, cut, if-then-else, disjunction,
meta-calls, side effects) is rejected with a `file:line:col` error, as is a call of a predicate
with neither rules nor facts nor a `:- dynamic` declaration.
"""
from __future__ import annotations

from typing import Dict, List

from ..frontend.definite import BUILTINS, REJECTED, Indicator, Literal, Program, Rule, program_error
from ..frontend.terms import Var, indicator
from .unit import AqUnit

name = "aq_program"


def run(unit: AqUnit) -> AqUnit:
    program = unit.program
    rule_preds = set(program.rule_predicates)
    known = rule_preds | set(program.dynamic)
    for rule in program.rules:
        body = []
        for lit in rule.body:
            goal = lit.term
            if isinstance(goal, Var):
                raise program_error("a variable cannot be a goal (meta-call) in a definite program", goal, rule.span)
            ind = indicator(goal)
            if ind is None:
                raise program_error("a number cannot be a goal", goal, rule.span)
            if ind in REJECTED:
                raise program_error(REJECTED[ind], goal, rule.span)
            if ind in BUILTINS:
                if ind != ("true", 0):
                    body.append(Literal(goal, "builtin"))
                continue
            if ind not in known:
                raise program_error(
                    f"unknown predicate {ind[0]}/{ind[1]}: define it, give it facts or declare "
                    f"`:- dynamic {ind[0]}/{ind[1]}.`", goal, rule.span)
            body.append(Literal(goal, "call" if ind in rule_preds else "fact"))
        rule.body = body
    return unit


def relevant_predicates(program: Program, goal_ind: Indicator) -> List[Indicator]:
    """Relevant predicate set (Def. 33): predicates SLD resolution could reach from `goal_ind`."""
    seen: Dict[Indicator, None] = {goal_ind: None}
    stack = [goal_ind]
    while stack:
        ind = stack.pop()
        for rule in program.rules_for(ind):
            for lit in rule.body:
                if lit.kind != "builtin" and lit.indicator not in seen:
                    seen[lit.indicator] = None
                    stack.append(lit.indicator)
    return list(seen)


def relevant_rules(program: Program, goal_ind: Indicator) -> List[Rule]:
    """Relevant rule set (Def. 30): the rules of the relevant predicates."""
    preds = set(relevant_predicates(program, goal_ind))
    return [r for r in program.rules if r.indicator in preds and not r.synthetic]
