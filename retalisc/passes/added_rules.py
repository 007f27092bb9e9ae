"""added_rules: event rules added to a running program (ETALIS `ins_event_rule`) are checked
and named before they go through the event pipeline.

Only event rules and `event_rule_property/3` declarations are allowed; a rule's label names its
generated predicates, so it must match `[a-z][A-Za-z0-9_]*`, and unlabelled rules are named
`<unit.rule_prefix>_1`, `_2`, ... so that the runtime can keep their ids fresh.
"""
from __future__ import annotations

import re

from ..frontend.errors import RetalisSemanticError
from ..frontend.program import Declaration, EventRule
from ..frontend.terms import Atom, Compound
from .unit import Unit

name = "added_rules"

RULE_ID = re.compile(r"[a-z][A-Za-z0-9_]*")

# Declarations allowed next to the rules: they configure the rules being compiled.
_RULE_SETTINGS = {("event_rule_property", 3)}


def run(unit: Unit) -> Unit:
    program = unit.program
    unlabelled = 0
    for clause in program.clauses:
        if isinstance(clause, EventRule):
            if clause.label is None:
                unlabelled += 1
                clause.label = f"{unit.rule_prefix}_{unlabelled}"
            elif not RULE_ID.fullmatch(clause.label):
                raise RetalisSemanticError(
                    f"the label {clause.label!r} of a rule added at runtime must match [a-z][A-Za-z0-9_]* "
                    "(it names the rule's predicates)", clause.span)
        elif isinstance(clause, Declaration) and _key(clause.goal) in _RULE_SETTINGS:
            continue
        else:
            raise RetalisSemanticError("only event rules (Head <- Pattern) and event_rule_property/3 can be "
                                       "added to a running program here; use ins_static_rule/1 for static "
                                       "clauses", clause.span)
    labels = [c.label for c in program.event_rules]
    duplicates = sorted({label for label in labels if labels.count(label) > 1})
    if duplicates:
        raise RetalisSemanticError(f"two rules are labelled {duplicates[0]}", program.event_rules[0].span)
    return unit


def _key(goal):
    if isinstance(goal, Compound):
        return goal.name, goal.arity
    if isinstance(goal, Atom):
        return goal.name, 0
    return None
