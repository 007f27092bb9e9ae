"""aq_program: check that the rule bodies of a definite program are definite (thesis 6.2), and
mark each body literal `builtin`, `call` (a predicate with rules) or `fact` (stored facts only).

Body literals are user predicates or the builtins of `frontend.definite.BUILTINS` (`true` is
dropped), or their negation `\\+ G` (after `aq_normalise`, which also turned `not/1`, `tnot/1`,
disjunction and if-then-else into clauses). A negated builtin is evaluated in place; a negated
user literal is marked `negated`, and the program must be stratified: no predicate may depend
negatively on itself through the rules (a `file:line:col` error at the negation that closes
such a cycle). Every rule gets the stratum of its head. Everything else (cut, meta-calls, side
effects) is rejected with a `file:line:col` error, as is a call of a predicate with neither
rules nor facts nor a `:- dynamic` declaration.
"""
from __future__ import annotations

from typing import Dict, List, Tuple

from ..frontend.definite import BUILTINS, REJECTED, Indicator, Literal, Program, Rule, program_error
from ..frontend.terms import Compound, Var, indicator
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
            negated = isinstance(goal, Compound) and goal.name == "\\+" and goal.arity == 1
            if negated:
                goal = goal.args[0]
            if isinstance(goal, Var):
                raise program_error("a variable cannot be a goal (meta-call) in a definite program", goal, rule.span)
            ind = indicator(goal)
            if ind is None:
                raise program_error("a number cannot be a goal", goal, rule.span)
            if ind in REJECTED:
                raise program_error(REJECTED[ind], goal, rule.span)
            if ind in BUILTINS:
                if negated:
                    body.append(Literal(lit.term, "builtin"))
                elif ind != ("true", 0):
                    body.append(Literal(goal, "builtin"))
                continue
            if ind not in known:
                raise program_error(
                    f"unknown predicate {ind[0]}/{ind[1]}: define it, give it facts or declare "
                    f"`:- dynamic {ind[0]}/{ind[1]}.`", goal, rule.span)
            body.append(Literal(goal, "call" if ind in rule_preds else "fact", negated))
        rule.body = body
    stratify(program)
    return unit


def stratify(program: Program) -> None:
    """Give every rule the stratum of its head; raise a located error for a predicate that
    depends negatively on itself (an unstratified program)."""
    edges: Dict[Indicator, List[Tuple[Indicator, bool, Literal, Rule]]] = {}
    for rule in program.rules:
        for lit in rule.body:
            if lit.kind != "builtin":
                edges.setdefault(rule.indicator, []).append((lit.indicator, lit.negated, lit, rule))
    comp = _components(edges)
    for head, out in edges.items():
        for dep, negated, lit, rule in out:
            if negated and comp.get(dep) == comp.get(head):
                cycle = "itself" if dep == head else \
                    f"{dep[0]}/{dep[1]}, which depends on {head[0]}/{head[1]}"
                raise program_error(
                    f"unstratified negation: {head[0]}/{head[1]} depends negatively on {cycle} "
                    f"(a negation must not be part of a recursion)", lit.term, rule.span)
    stratum: Dict[Indicator, int] = {}

    def level(ind: Indicator) -> int:
        # components are acyclic through negation: the recursion terminates within a component
        # because positive edges inside it add nothing
        if ind in stratum:
            return stratum[ind]
        stratum[ind] = 0
        best = 0
        members = [i for i, c in comp.items() if c == comp[ind]] if ind in comp else [ind]
        for member in members:
            stratum[member] = 0
        for member in members:
            for dep, negated, _, _ in edges.get(member, []):
                if comp.get(dep) == comp.get(ind) and dep in comp:
                    continue
                best = max(best, level(dep) + (1 if negated else 0))
        for member in members:
            stratum[member] = best
        return best

    for rule in program.rules:
        rule.stratum = level(rule.indicator)


def _components(edges) -> Dict[Indicator, int]:
    """Strongly connected components of the predicate dependency graph (Tarjan, iterative)."""
    index: Dict[Indicator, int] = {}
    low: Dict[Indicator, int] = {}
    comp: Dict[Indicator, int] = {}
    stack: List[Indicator] = []
    on_stack = set()
    counter = [0]
    nodes = list(edges) + [d for out in edges.values() for d, *_ in out]
    for root in nodes:
        if root in index:
            continue
        work = [(root, 0)]
        while work:
            node, i = work.pop()
            if i == 0:
                index[node] = low[node] = counter[0]
                counter[0] += 1
                stack.append(node)
                on_stack.add(node)
            succ = edges.get(node, [])
            if i < len(succ):
                work.append((node, i + 1))
                nxt = succ[i][0]
                if nxt not in index:
                    work.append((nxt, 0))
                elif nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
                continue
            if low[node] == index[node]:
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp[w] = index[node]
                    if w == node:
                        break
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
    return comp


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
