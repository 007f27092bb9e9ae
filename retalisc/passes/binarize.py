"""binarize: split every event rule into binary steps (thesis 6.3.1, first step).

Each operator node of a pattern becomes a step `e_<rule>_<n>(Vars) <- Left OP Right` whose
intermediate event carries every variable of its sub-pattern. The last step derives the
rule's head. A window `(P).Q` applies to every step inside P (a partial match of P never
spans more than the whole match), so the steps can check it early and forget old partial
matches. Where-conditions are checked on the step they follow (or on the event atom they
were pushed to by push_conditions).

An anonymous variable `_` in an event atom gets a fresh name (`Any1`, `Any2`, ...): a partial
match is the events themselves, so two events that differ only where the rule wrote `_` are
different partial matches (for twin replacement under `recent`, and when an event is deleted),
exactly as if the variable had been named.
"""
from __future__ import annotations

from typing import List, Optional, Set

from ..frontend.errors import RetalisSemanticError
from ..frontend.program import Absence, Sliding, Aggregate, Binary, Check, EventAtom, EventRule, Negation, Pattern, Where, Window
from ..frontend.terms import Atom, Compound, Term, Var, conjuncts, distinct_variables, variables, walk
from .unit import BinaryRule, Operand, Step, Unit

name = "binarize"

SUPPORTED_OPERATORS = ("seq", "and", "par", "or", "equals", "meets", "during", "starts", "finishes", "fnot")

# `P check C`: t1(T) and t2(T) in C are P's start and end, written as these placeholders
# until edbc knows the names of the time variables.
START_MARK = Atom("$start")
END_MARK = Atom("$end")


def run(unit: Unit) -> Unit:
    rules = unit.program.event_rules
    labels = {rule.label for rule in rules if rule.label}
    unit.rules = [_Binarizer(rule, _rule_id(rule, index, labels)).binarize()
                  for index, rule in enumerate(rules, start=1)]
    return unit


def _rule_id(rule: EventRule, index: int, labels: Set[str]) -> str:
    """The rule's label (`validate` has checked that labels are unique names), or `r<index>`
    (its position) for an unlabelled rule; when a label already is `r<index>`, the unlabelled
    rule is `r<index>_2` (or `_3`, ...): labels keep their names."""
    if rule.label:
        return rule.label
    rule_id, n = f"r{index}", 2
    while rule_id in labels:
        rule_id, n = f"r{index}_{n}", n + 1
    return rule_id


class _Binarizer:
    def __init__(self, rule: EventRule, rule_id: str):
        self.rule = rule
        self.rule_id = rule_id
        self.steps: List[Step] = []
        self.names: Set[str] = {t.name for t in walk(_rule_terms(rule)) if isinstance(t, Var)}
        self.anonymous = 0

    def binarize(self) -> BinaryRule:
        top = self.lower(self.rule.pattern, None)
        if top.step is None or top.step.derives_head:
            step = self.new_step("pass", top, None, None)
            top = Operand(step.output, step)
        top.step.derives_head = True
        return BinaryRule(self.rule_id, self.rule, self.steps)

    def new_step(self, op: str, left: Operand, right: Optional[Operand], window: Optional[float]) -> Step:
        step_name = f"e_{self.rule_id}_{len(self.steps) + 1}"
        names = _operand_variables(left) + (_operand_variables(right) if right is not None else [])
        output = Compound(step_name, tuple(distinct_variables(names)))
        step = Step(step_name, op, left, right, output, window)
        self.steps.append(step)
        return step

    def name_anonymous(self, term: Term) -> Term:
        """`term` with every `_` replaced by a variable no other variable of the rule is called."""
        if isinstance(term, Var) and term.is_anonymous:
            self.anonymous += 1
            while f"Any{self.anonymous}" in self.names:
                self.anonymous += 1
            return Var(f"Any{self.anonymous}", term.span)
        if isinstance(term, Compound):
            return Compound(term.name, tuple(self.name_anonymous(a) for a in term.args), term.span)
        return term

    def lower(self, pattern: Pattern, window: Optional[float]) -> Operand:
        if isinstance(pattern, EventAtom):
            return Operand(self.name_anonymous(pattern.term), None, [], pattern.start, pattern.end, pattern.span)
        if isinstance(pattern, Where):
            operand = self.lower(pattern.pattern, window)
            goals = conjuncts(pattern.condition)
            if operand.step is None:
                operand.filters.extend(goals)
                return operand
            step = operand.step
            step.conditions.extend(goals)
            # conditions may bind new variables (`where pos_avg(Ls, L)`): the step carries them on
            extra = [v for c in goals for v in variables(c)]
            step.output = Compound(step.output.name, tuple(distinct_variables(list(step.output.args) + extra)))
            return Operand(step.output, step)
        if isinstance(pattern, Window):
            inner_window = pattern.length if window is None else min(window, pattern.length)
            operand = self.lower(pattern.pattern, inner_window)
            if operand.step is not None and (operand.step.window is None or operand.step.window > inner_window):
                operand.step.window = inner_window
            if operand.step is None:
                # a window around a single event: only derived (interval) events can exceed it
                step = self.new_step("pass", operand, None, inner_window)
                return Operand(step.output, step)
            return operand
        if isinstance(pattern, Check):
            condition = _mark_times(pattern.condition)
            return self.lower(Where(pattern.pattern, condition, pattern.span), window)
        if isinstance(pattern, Binary) and pattern.op == "seq" and isinstance(pattern.right, Aggregate):
            aggregate = pattern.right
            if not isinstance(aggregate.value, Var):
                raise RetalisSemanticError("the value of aggregate(F, P, V) must be a variable", aggregate.span)
            left = self.lower(pattern.left, window)
            right = self.lower(aggregate.pattern, window)
            step = self.new_step("aggregate", left, right, window)
            # the result carries the start event's variables and the value, not the P's
            step.output = Compound(step.name, tuple(distinct_variables(_operand_variables(left) + [aggregate.value])))
            step.aggregate = (aggregate.function, aggregate.value)
            return Operand(step.output, step)
        if isinstance(pattern, Binary) and pattern.op == "fnot":
            left = self.lower(pattern.left, window)
            negated = self.lower(pattern.right, window)
            step = self.new_step("fnot", left, None, window)
            step.negated = negated
            return Operand(step.output, step)
        if isinstance(pattern, Binary):
            if pattern.op not in SUPPORTED_OPERATORS:
                raise RetalisSemanticError(f"the operator '{pattern.op}' is not supported", pattern.span)
            left = self.lower(pattern.left, window)
            right = self.lower(pattern.right, window)
            step = self.new_step(pattern.op, left, right, window)
            return Operand(step.output, step)
        if isinstance(pattern, Negation):
            left = self.lower(pattern.first, window)
            right = self.lower(pattern.second, window)
            negated = self.lower(pattern.negated, window)
            step = self.new_step("cnot", left, right, window)
            step.negated = negated
            return Operand(step.output, step)
        if isinstance(pattern, Absence):
            left = self.lower(pattern.first, window)
            negated = self.lower(pattern.negated, window)
            step = self.new_step("absence", left, None, window)
            step.negated = negated
            step.duration = pattern.duration
            return Operand(step.output, step)
        if isinstance(pattern, Sliding):
            inner = self.lower(pattern.pattern, window)
            inner_names = {v.name for v in _operand_variables(inner)}
            for term, what in ((pattern.group, "group"), (_function_argument(pattern.function), "aggregated value")):
                missing = [v.name for v in variables(term) if not v.is_anonymous and v.name not in inner_names] \
                    if term is not None else []
                if missing or (term is not None and any(v.is_anonymous for v in variables(term))):
                    raise RetalisSemanticError(f"the {what} of a sliding aggregate must be made of variables of its "
                                               f"pattern ({', '.join(missing) or '_'} is not)", pattern.span)
            step = self.new_step("sliding", inner, None, None)
            step.output = Compound(step.name, tuple(distinct_variables(list(variables(pattern.group))
                                                                       + [pattern.value])))
            step.sliding = (pattern.function, pattern.group, pattern.value)
            step.duration = pattern.duration
            return Operand(step.output, step)
        if isinstance(pattern, Aggregate):
            raise RetalisSemanticError("aggregate(F, P, V) counts from a start event: write Start seq "
                                       "aggregate(F, P, V)", pattern.span)
        raise TypeError(pattern)


def _rule_terms(rule: EventRule) -> Term:
    """One term holding every term of `rule` (for the names of its variables)."""
    parts = [rule.head] + [t for t in (rule.action, rule.synchronized) if t is not None]
    parts += list(_pattern_terms(rule.pattern))
    return Compound("rule", tuple(parts))


def _pattern_terms(pattern: Pattern):
    if isinstance(pattern, EventAtom):
        yield pattern.term
        for t in (pattern.start, pattern.end):
            if t is not None:
                yield t
        return
    for name_ in ("pattern", "left", "right", "first", "second", "negated"):
        child = getattr(pattern, name_, None)
        if child is not None and not isinstance(child, (Atom, Compound, Var)):
            yield from _pattern_terms(child)
    for name_ in ("condition", "value", "function", "group"):
        term = getattr(pattern, name_, None)
        if isinstance(term, (Atom, Compound, Var)):
            yield term


def _function_argument(function: Term) -> Optional[Term]:
    """X of sum(X), min(X), ...; None for count."""
    return function.args[0] if isinstance(function, Compound) and function.arity == 1 else None


def _mark_times(condition: Term) -> Term:
    """t1(T) -> T = '$start', t2(T) -> T = '$end' (ETALIS `check`)."""
    if isinstance(condition, Compound):
        if condition.name in ("t1", "t2") and condition.arity == 1:
            mark = START_MARK if condition.name == "t1" else END_MARK
            return Compound("=", (condition.args[0], mark))
        return Compound(condition.name, tuple(_mark_times(a) for a in condition.args), condition.span)
    return condition


def _operand_variables(operand: Operand) -> List[Var]:
    found = list(variables(operand.term))
    for t in (operand.start, operand.end):
        if t is not None:
            found.extend(variables(t))
    for f in operand.filters:
        found.extend(variables(f))
    return found

