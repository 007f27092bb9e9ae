"""collect_settings: program-wide settings from directives and declarations.

`set_etalis_flag(event_consumption_policy, P)`, `print_trigger(F/A)` and
`event_rule_property(Label, Name, Value)` may be written as directives (`:- G.`) or, in the
style of Retalis's goalPredicates.txt, as facts. ETALIS flags with no meaning here are
accepted with a warning.
"""
from __future__ import annotations

from ..frontend.errors import RetalisSemanticError
from ..frontend.terms import Atom, Compound, Number, Term, conjuncts, span_of
from ..frontend.writer import write_term
from .unit import Unit

name = "collect_settings"

CONSUMPTION_POLICIES = ("unrestricted", "recent", "chronological")


def run(unit: Unit) -> Unit:
    settings = unit.settings
    for item in unit.program.directives + unit.program.declarations:
        for goal in conjuncts(item.goal):
            if _is(goal, "set_etalis_flag", 2):
                flag, value = goal.args
                if flag == Atom("event_consumption_policy"):
                    if not (isinstance(value, Atom) and value.name in CONSUMPTION_POLICIES):
                        raise RetalisSemanticError(
                            f"event_consumption_policy must be one of {', '.join(CONSUMPTION_POLICIES)}",
                            span_of(value) or item.span)
                    settings.consumption_policy = value.name
                else:
                    unit.warnings.append(f"{item.span}: warning: ETALIS flag {write_term(flag)} has no "
                                         "meaning in retalisc and is ignored")
            elif _is(goal, "set_retalis_flag", 2):
                unit.warnings.append(f"{item.span}: warning: set_retalis_flag/2 has no meaning in retalisc and is "
                                     "ignored")
            elif _is(goal, "print_trigger", 1):
                spec = goal.args[0]
                if _is(spec, "/", 2) and isinstance(spec.args[0], Atom) and isinstance(spec.args[1], Number):
                    settings.printed = (settings.printed or []) + [(spec.args[0].name, int(spec.args[1].value))]
                elif _is(spec, "/", 2):
                    # print_trigger(_) or print_trigger(_/_): print everything
                    settings.printed = settings.printed
                else:
                    raise RetalisSemanticError("print_trigger takes Name/Arity", span_of(spec) or item.span)
            elif _is(goal, "event_rule_property", 3):
                label, prop, value = goal.args
                if not isinstance(label, Atom) or not isinstance(prop, Atom):
                    raise RetalisSemanticError("event_rule_property(RuleLabel, Property, Value) needs atoms",
                                               item.span)
                settings.rule_properties.setdefault(label.name, {})[prop.name] = value
    return unit



def _is(term: Term, name_: str, arity: int) -> bool:
    return isinstance(term, Compound) and term.name == name_ and term.arity == arity
