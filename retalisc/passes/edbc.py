"""edbc: generate the event-driven backward-chaining rules of every step (thesis 6.3.1,
Algorithm 1) as Prolog clause terms.

For a step `e <- L op R` the generated code is, per side (shown for the left side):

    e_left(LVars, S1, E1) :-                       % an instance of L has occurred
        forall(( e_rights(Key, ROther, S2, E2),    % every R seen so far with the same key
                 <temporal relation of op>, <window> ),
               e(Vars, S, E)),                     % ... completes e
        assertz(e_lefts(Key, LOther, S1, E1)).     % remember L for R's still to come

Stores are symmetric, so a match is found whichever of its events arrives last: the
result does not depend on arrival order (thesis 3.3.2). The join variables come first in
a stored partial match, so SWI-Prolog's just-in-time index finds the partners by key
instead of scanning every pending match (the bottleneck of the original ETALIS).
`e(Vars, S, E)` then checks the step's where-conditions and passes the match on to the
step that consumes it, or derives the rule's head.
"""
from __future__ import annotations

from typing import Dict, List, Optional, Set

from ..frontend.program import pattern_text
from ..frontend.terms import Atom, Compound, Number, Term, Var, variables
from ..frontend.writer import write_term
from .unit import BinaryRule, GeneratedRule, Operand, Step, Unit

name = "edbc"

# Temporal relation and result interval of each binary operator, on the intervals
# [S1, E1] (left) and [S2, E2] (right). Interval operators come with the full ELE issue.
_RELATIONS = {
    "seq": ("E1 < S2", "S1", "E2"),
    "and": (None, "min(S1, S2)", "max(E1, E2)"),
}


def run(unit: Unit) -> Unit:
    unit.generated = [_RuleGenerator(rule).generate() for rule in unit.rules]
    return unit


def V(name_: str) -> Var:
    return Var(name_)


def C(name_: str, *args: Term) -> Compound:
    return Compound(name_, tuple(args))


def conj(goals: List[Term]) -> Term:
    goals = [g for g in goals if g is not None]
    if not goals:
        return Atom("true")
    result = goals[-1]
    for g in reversed(goals[:-1]):
        result = C(",", g, result)
    return result


def clause(head: Term, body: List[Term]) -> Term:
    goals = [g for g in body if g is not None]
    return C(":-", head, conj(goals)) if goals else head


class _RuleGenerator:
    def __init__(self, rule: BinaryRule):
        self.rule = rule
        used: Set[str] = set()
        source = rule.rule
        for t in [source.head] + ([source.action] if source.action is not None else []):
            used.update(v.name for v in variables(t))
        for step in rule.steps:
            for operand in (step.left, step.right):
                if operand is not None:
                    used.update(v.name for v in variables(operand.term))
                    used.update(v.name for f in operand.filters for v in variables(f))
            used.update(v.name for c in step.conditions for v in variables(c))
        self.time_names: Dict[str, str] = {}
        readable = {"S": "Start", "E": "End", "S1": "LStart", "E1": "LEnd", "S2": "RStart", "E2": "REnd"}
        for base, fresh in readable.items():
            while fresh in used:
                fresh += "_"
            self.time_names[base] = fresh
        self.clauses: List[Term] = []
        self.triggers: List[Term] = []
        self.stores: List[tuple] = []

    def t(self, base: str) -> Var:
        return V(self.time_names[base])

    def expr(self, text: str) -> Term:
        """A small arithmetic expression over the time variables, e.g. `min(S1, S2)`."""
        from ..frontend.parser import read_term

        renamed = read_term(text)
        mapping = {k: V(v) for k, v in self.time_names.items()}
        from ..frontend.terms import substitute

        return substitute(renamed, mapping)

    def generate(self) -> GeneratedRule:
        self.consumers: Dict[str, str] = {}
        for step in self.rule.steps:
            for side, operand in (("left", step.left), ("right", step.right)):
                if operand is not None and operand.step is not None:
                    self.consumers[operand.step.name] = f"{step.name}_{side}"
        for step in self.rule.steps:
            self.step_clauses(step)
        source = self.rule.rule
        comment = f"{source.span}: {source.source.strip()}"
        return GeneratedRule(self.rule.rule_id, comment, self.clauses, self.triggers, self.stores)

    # ---- arrivals ---------------------------------------------------------------------

    def arrival(self, operand: Operand, handler: str, s: Var, e: Var) -> None:
        """For an event atom: an `ele_trigger/3` clause that runs `handler(Vars, S, E)` when the
        event occurs (after the where-conditions pushed onto it). A step's output reaches its
        handler through the step's own clause (see step_output)."""
        if not operand.is_event:
            return
        if isinstance(operand.end, Var) and operand.start == operand.end:
            start, end = s, operand.end                      # E^T: T is the end time
        else:
            start = operand.start if isinstance(operand.start, Var) else s
            end = operand.end if isinstance(operand.end, Var) else e
        call = C(handler, *operand_vars(operand), start, end)
        self.triggers.append(clause(C("ele_trigger", operand.term, start, end), list(operand.filters) + [call]))

    # ---- steps ------------------------------------------------------------------------

    def step_clauses(self, step: Step) -> None:
        s1, e1, s2, e2 = self.t("S1"), self.t("E1"), self.t("S2"), self.t("E2")
        if step.right is None or step.op == "or":
            for side, operand in (("left", step.left), ("right", step.right)):
                if operand is None:
                    continue
                handler = f"{step.name}_{side}"
                self.arrival(operand, handler, s1, e1)
                params = operand_vars(operand)
                window = self.window_check(step, s1, e1)
                self.clauses.append(clause(C(handler, *params, s1, e1),
                                           [window, C(step.name, *step.output.args, s1, e1)]))
        else:
            self.join_clauses(step)
        self.step_output(step)

    def join_clauses(self, step: Step) -> None:
        relation, start_expr, end_expr = _RELATIONS[step.op]
        left_vars = operand_vars(step.left)
        right_vars = operand_vars(step.right)
        right_names = {v.name for v in right_vars}
        key = [v for v in left_vars if v.name in right_names]
        key_names = {v.name for v in key}
        left_other = [v for v in left_vars if v.name not in key_names]
        right_other = [v for v in right_vars if v.name not in key_names]
        lefts, rights = f"{step.name}_lefts", f"{step.name}_rights"
        s1, e1, s2, e2, s, e = (self.t(n) for n in ("S1", "E1", "S2", "E2", "S", "E"))
        self.stores.append((lefts, len(key) + len(left_other) + 2, step.window))
        self.stores.append((rights, len(key) + len(right_other) + 2, step.window))

        interval = []
        if start_expr in ("S1", "S2"):
            s = self.t(start_expr)
        else:
            interval.append(C("is", s, self.expr(start_expr)))
        if end_expr in ("E1", "E2"):
            e = self.t(end_expr)
        else:
            interval.append(C("is", e, self.expr(end_expr)))
        match = ([self.expr(relation)] if relation else []) + interval + [self.window_check(step, s, e)]
        output = C(step.name, *step.output.args, s, e)

        for side, own, own_other, other_store, other_other, own_store, (os, oe) in (
                ("left", left_vars, left_other, rights, right_other, lefts, (s1, e1)),
                ("right", right_vars, right_other, lefts, left_other, rights, (s2, e2))):
            handler = f"{step.name}_{side}"
            operand = step.left if side == "left" else step.right
            self.arrival(operand, handler, os, oe)
            ps, pe = (s2, e2) if side == "left" else (s1, e1)
            partner = C(other_store, *key, *other_other, ps, pe)
            remember = C("assertz", C(own_store, *key, *own_other, os, oe))
            if step.op == "seq" and side == "right":
                # a right-hand event only waits for left-hand events that may still arrive
                remember = C("->", C("rtl_may_precede", os), remember)
                remember = C(";", remember, Atom("true"))
            self.clauses.append(clause(C(handler, *own, os, oe),
                                       [C("forall", conj([partner] + [m for m in match if m is not None]), output),
                                        remember]))

    def window_check(self, step: Step, s: Var, e: Var) -> Optional[Term]:
        if step.window is None:
            return None
        return C("=<", C("-", e, s), Number(_number(step.window)))

    def step_output(self, step: Step) -> None:
        s, e = self.t("S"), self.t("E")
        head = C(step.name, *step.output.args, s, e)
        if step.derives_head:
            rule = self.rule.rule
            action = C("rtl_action", rule.action) if rule.action is not None else None
            derive = None if rule.head == Atom("null") else C("rtl_derived", rule.head, s, e)
            then = conj([g for g in (action, derive) if g is not None])
        else:
            then = C(self.consumers[step.name], *step.output.args, s, e)
        if step.conditions:
            body = [C("forall", conj(step.conditions), then)]
        else:
            body = [then]
        self.clauses.append(clause(head, body))


def operand_vars(operand: Operand) -> List[Var]:
    if operand.step is not None:
        return list(operand.step.output.args)
    found: List[Var] = []
    seen: Set[str] = set()
    for t in [operand.term] + [x for x in (operand.start, operand.end) if isinstance(x, Var)]:
        for v in variables(t):
            if v.name not in seen:
                seen.add(v.name)
                found.append(Var(v.name))
    for f in operand.filters:
        for v in variables(f):
            if v.name not in seen:
                seen.add(v.name)
                found.append(Var(v.name))
    return found


def _number(value: float):
    return int(value) if float(value).is_integer() else value


def dump(unit: Unit) -> str:
    from ..backends.prolog.render import render_rule

    return "\n\n".join(render_rule(g) for g in unit.generated)


def describe(rule: BinaryRule) -> str:
    return f"{rule.rule_id}: {write_term(rule.rule.head)} <- {pattern_text(rule.rule.pattern)}"
