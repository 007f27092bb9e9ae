"""validate: semantic checks that the reader cannot make.

- every variable of an event rule's head occurs in its pattern (thesis Def. 5);
- an event predicate (one that occurs in a pattern or is derived by a rule) is not called as
  a static goal, nor defined by static clauses;
- declarations have their documented arity, and a pattern does not use a derived event
  with another arity than the rules that derive it.
"""
from __future__ import annotations

from typing import Dict, Iterable, Set, Tuple

from ..frontend.errors import RetalisSemanticError
from ..frontend.program import (DECLARATIONS, Aggregate, Check, EventAtom, EventRule, Pattern, Sliding, Where,
                                pattern_conditions, walk_pattern)
from ..frontend.terms import Atom, Compound, Term, Var, indicator, span_of, variables
from .unit import Unit

name = "validate"

# Declaration names users may get wrong, with their arities.
_DECLARATION_ARITIES: Dict[str, Set[int]] = {}
for _name, _arity in DECLARATIONS:
    _DECLARATION_ARITIES.setdefault(_name, set()).add(_arity)

# Control constructs whose arguments are goals.
_CONTROL = {(",", 2), (";", 2), ("->", 2), ("*->", 2), ("\\+", 1), ("call", 1), ("findall", 3),
            ("forall", 2), ("aggregate_all", 3), ("once", 1), ("ignore", 1), ("bagof", 3), ("setof", 3)}
_GOAL_ARGS = {("findall", 3): (1,), ("bagof", 3): (1,), ("setof", 3): (1,), ("aggregate_all", 3): (1,),
              ("forall", 2): (0, 1)}


def run(unit: Unit) -> Unit:
    program = unit.program
    event_arities = _event_arities(program.event_rules)
    derived = {indicator(r.head) for r in program.event_rules if r.synchronized is None}
    static = {indicator(c.head) for c in program.static_clauses}

    _check_labels(program.event_rules)
    for rule in program.event_rules:
        _check_head_variables(rule)
        _check_aggregate_variables(rule)
        _check_pattern_arities(rule.pattern, derived)
        for condition in pattern_conditions(rule.pattern):
            _check_static_goals(condition, event_arities, static, "a where condition")
    for clause in program.static_clauses:
        key = indicator(clause.head)
        if key in derived:
            raise RetalisSemanticError(
                f"{key[0]}/{key[1]} is derived by event rules; it cannot also be defined by a static clause",
                clause.span)
        if clause.body is not None:
            _check_static_goals(clause.body, event_arities, static, "a static rule")
    for item in program.declarations + program.directives:
        _check_declaration_arity(item.goal, item.span)
    return unit


def _check_labels(rules) -> None:
    """Labels name the generated predicates and are the ids `del_event_rule/1` takes: two
    rules cannot share one."""
    labelled: Dict[str, EventRule] = {}
    for rule in rules:
        if rule.label is None:
            continue
        first = labelled.get(rule.label)
        if first is not None:
            raise RetalisSemanticError(f"two rules are labelled {rule.label} (the first one at line "
                                       f"{first.span.line}); rule labels must be unique", rule.span)
        labelled[rule.label] = rule


def _event_arities(rules: Iterable[EventRule]) -> Set[Tuple[str, int]]:
    found = set()
    for rule in rules:
        if rule.synchronized is None and rule.head != Atom("null"):
            found.add(indicator(rule.head))
        for atom in _atoms(rule.pattern):
            found.add(indicator(atom.term))
    return found


def _atoms(pattern: Pattern):
    for p in walk_pattern(pattern):
        if isinstance(p, EventAtom):
            yield p


def _pattern_variables(pattern: Pattern) -> Set[str]:
    names = set()
    for atom in _atoms(pattern):
        names.update(v.name for v in variables(atom.term))
        for t in (atom.start, atom.end):
            if t is not None:
                names.update(v.name for v in variables(t))
    for condition in pattern_conditions(pattern):
        names.update(v.name for v in variables(condition))
    for node in _aggregates(pattern):
        names.update(v.name for v in variables(node.value))
    return names


def _aggregates(pattern: Pattern):
    for p in walk_pattern(pattern):
        if isinstance(p, (Aggregate, Sliding)):
            yield p


def _check_head_variables(rule: EventRule) -> None:
    if rule.synchronized is not None:
        return                      # the query binds the event's variables (thesis A.2.5.2)
    bound = _pattern_variables(rule.pattern)
    repeated = set()
    for node in _aggregates(rule.pattern):
        if isinstance(node, Aggregate) and node.star:     # `A seq P star_times` derives at A already, before any P binds them
            repeated |= _pattern_variables(node.pattern)
    bound_at_start = _pattern_variables_outside_stars(rule.pattern)
    head = rule.head
    for var in variables(head):
        if var.name not in bound:
            raise RetalisSemanticError(
                f"variable {var.name} of the rule head does not occur in the pattern (it would stay unbound)",
                span_of(var) or rule.span)
        if var.name in repeated and var.name not in bound_at_start:
            raise RetalisSemanticError(
                f"variable {var.name} of the rule head occurs only in the pattern repeated by star_times (the rule "
                "derives at the start event already, where it would stay unbound)", span_of(var) or rule.span)


def _pattern_variables_outside_stars(pattern: Pattern) -> Set[str]:
    names = set()
    for p in walk_pattern(pattern, into=lambda p: not (isinstance(p, Aggregate) and p.star)):
        if isinstance(p, EventAtom):
            names.update(v.name for v in variables(p.term))
            for t in (p.start, p.end):
                if t is not None:
                    names.update(v.name for v in variables(t))
        elif isinstance(p, (Where, Check)):
            names.update(v.name for v in variables(p.condition))
    return names


def _check_aggregate_variables(rule: EventRule) -> None:
    """`aggregate(sum(X), P, V)`: X is a variable of P (its value in each P is aggregated)."""
    for node in _aggregates(rule.pattern):
        if not isinstance(node.function, Compound):
            continue
        argument = node.function.args[0]
        where = span_of(argument) or node.span or rule.span
        if not isinstance(argument, Var) or argument.is_anonymous:
            raise RetalisSemanticError(f"{node.function.name}(X) aggregates a variable X of the pattern", where)
        if argument.name not in _pattern_variables(node.pattern):
            raise RetalisSemanticError(f"the variable {argument.name} of {node.function.name}({argument.name}) does "
                                       "not occur in the aggregated pattern", where)


def _check_pattern_arities(pattern: Pattern, derived: Set[Tuple[str, int]]) -> None:
    by_name: Dict[str, Set[int]] = {}
    for name_, arity in derived:
        by_name.setdefault(name_, set()).add(arity)
    for atom in _atoms(pattern):
        key = indicator(atom.term)
        if key in derived or key[0] not in by_name:
            continue
        arities = ", ".join(f"{key[0]}/{a}" for a in sorted(by_name[key[0]]))
        raise RetalisSemanticError(
            f"wrong arity: {key[0]}/{key[1]} is used here, but the rules derive {arities}",
            atom.span)


def _check_static_goals(goal: Term, events: Set[Tuple[str, int]], static: Set[Tuple[str, int]],
                        where: str) -> None:
    for g in _goals(goal):
        key = indicator(g)
        if key is None:
            continue
        if key in events and key not in static:
            raise RetalisSemanticError(
                f"{key[0]}/{key[1]} is an event predicate; it cannot be called as a static goal in {where}",
                span_of(g))


def _goals(goal: Term):
    if isinstance(goal, Compound) and (goal.name, goal.arity) in _CONTROL:
        positions = _GOAL_ARGS.get((goal.name, goal.arity), range(goal.arity))
        for i in positions:
            yield from _goals(goal.args[i])
    else:
        yield goal


def _check_declaration_arity(goal: Term, span) -> None:
    for g in _goals(goal):
        if isinstance(g, (Atom, Compound)):
            arity = getattr(g, "arity", 0)
            arities = _DECLARATION_ARITIES.get(g.name)
            if arities and arity not in arities:
                expected = " or ".join(f"{g.name}/{a}" for a in sorted(arities))
                raise RetalisSemanticError(f"wrong arity: {g.name}/{arity}; expected {expected}",
                                           span_of(g) or span)
