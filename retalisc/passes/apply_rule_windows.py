"""apply_rule_windows: the ETALIS rule property `event_rule_window` becomes a window around
the whole pattern, as the thesis writes it: `(Pattern).Q`.

The property comes from the rule label (`r([property(event_rule_window, 3)]) 'rule:' ...`) or
from an `event_rule_property(r, event_rule_window, 3)` declaration.
"""
from __future__ import annotations

from dataclasses import replace

from ..frontend.errors import RetalisSemanticError
from ..frontend.program import Window
from ..frontend.terms import Number
from .unit import Unit

name = "apply_rule_windows"


def run(unit: Unit) -> Unit:
    clauses = []
    for clause in unit.program.clauses:
        properties = dict(getattr(clause, "properties", {}) or {})
        label = getattr(clause, "label", None)
        if label is not None:
            properties.update(unit.settings.rule_properties.get(label, {}))
        window = properties.get("event_rule_window")
        if window is not None and hasattr(clause, "pattern"):
            if not isinstance(window, Number) or window.value < 0:
                raise RetalisSemanticError("event_rule_window must be a non-negative number of seconds",
                                           clause.span)
            clause = replace(clause, pattern=Window(clause.pattern, window.value, clause.span))
        clauses.append(clause)
    unit.program = replace(unit.program, clauses=clauses)
    return unit
