"""Which consumption policy each rule's steps run under, and which events a policy step takes
as input (the rules deriving them then number their arrivals, rtl_policy.pl)."""
from __future__ import annotations

from typing import List, Optional, Set, Tuple

from ...frontend.errors import RetalisSemanticError
from ...frontend.terms import Atom, Compound, Term
from ..unit import BinaryRule, Unit

#: The selections a rule may ask for with the property `consumption_policy`: the program's
#: policies, and `first` (each left instance pairs with its first matching right instance).
RULE_POLICIES = ("unrestricted", "recent", "chronological", "first")


def signature(term: Term) -> Optional[Tuple[str, int]]:
    if isinstance(term, Compound):
        return term.name, term.arity
    if isinstance(term, Atom):
        return term.name, 0
    return None


def policy_inputs(rules: List[BinaryRule], policies: List[str]) -> Set[Tuple[str, int]]:
    """The events that a step under `recent` or `chronological` takes as input: a rule
    without such a policy deriving one of them numbers the arrivals of its input events and
    records when it made each result (`_made`), so that the policy step deletes the very
    arrival a deletion takes back, and receives a result made late where it would have been
    made (rtl_policy.pl)."""
    consumed: Set[Tuple[str, int]] = set()
    for rule, policy in zip(rules, policies):
        if policy not in ("recent", "chronological"):
            continue
        for step in rule.steps:
            for operand in (step.left, step.right, step.negated):
                if operand is not None and operand.is_event and signature(operand.term) is not None:
                    consumed.add(signature(operand.term))
    return consumed


def rule_policy(unit: Unit, rule: BinaryRule) -> str:
    """The rule's own consumption policy (label property or `event_rule_property/3` fact
    `consumption_policy`, or ETALIS's name `event_consumption_policy`), else the program's."""
    properties = dict(rule.rule.properties or {})
    if rule.rule.label is not None:
        properties.update(unit.settings.rule_properties.get(rule.rule.label, {}))
    value = properties.get("consumption_policy", properties.get("event_consumption_policy"))
    if value is None:
        return unit.settings.consumption_policy
    if not (isinstance(value, Atom) and value.name in RULE_POLICIES):
        raise RetalisSemanticError(f"the consumption_policy of a rule must be one of {', '.join(RULE_POLICIES)}",
                                   rule.rule.span)
    return value.name

