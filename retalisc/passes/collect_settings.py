"""collect_settings: program-wide settings from directives and declarations.

`set_etalis_flag(event_consumption_policy, P)`, `print_trigger(F/A)` and
`event_rule_property(Label, Name, Value)` may be written as directives (`:- G.`) or, in the
style of Retalis's goalPredicates.txt, as facts. ETALIS flags with no meaning here are
accepted with a warning.

`ros_strings(Mode)` says how a ROS message's string field (a frame id, a name) is an atom:
`plain` (the default: frame id `odom` is the atom `odom`) or `quoted`, the 2015 release's form
(the atom `'"odom"'`). A program that reads its rules with `compile_event_file` (the release's
two-file form) is `quoted` unless it says otherwise.
"""
from __future__ import annotations

from ..frontend.errors import RetalisSemanticError
from ..frontend.terms import Atom, Compound, Number, Term, Var, conjuncts, span_of
from ..frontend.writer import write_term
from .unit import Unit

name = "collect_settings"

CONSUMPTION_POLICIES = ("unrestricted", "recent", "chronological")
ROS_STRINGS = ("plain", "quoted")


def run(unit: Unit) -> Unit:
    settings = unit.settings
    everything = False
    if unit.program.reads_event_file:
        settings.ros_strings = "quoted"
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
                    warning = _flag_warning(flag, value)
                    if warning:
                        unit.warnings.append(f"{item.span}: warning: {warning}")
            elif _is(goal, "ros_strings", 1):
                mode = goal.args[0]
                if not (isinstance(mode, Atom) and mode.name in ROS_STRINGS):
                    raise RetalisSemanticError(f"ros_strings takes one of {', '.join(ROS_STRINGS)}",
                                               span_of(mode) or item.span)
                settings.ros_strings = mode.name
            elif _is(goal, "set_retalis_flag", 2):
                unit.warnings.append(f"{item.span}: warning: set_retalis_flag/2 has no meaning in retalisc and is "
                                     "ignored")
            elif isinstance(goal, Compound) and goal.arity == 1 and goal.name in PRINT_DECLARATIONS:
                printed = _printed(goal.args[0], item.span)
                if printed == ALL:
                    everything = True
                else:
                    settings.printed = (settings.printed or []) + [printed]
            elif _is(goal, "event_rule_property", 3):
                label, prop, value = goal.args
                if not isinstance(label, Atom) or not isinstance(prop, Atom):
                    raise RetalisSemanticError("event_rule_property(RuleLabel, Property, Value) needs atoms",
                                               item.span)
                settings.rule_properties.setdefault(label.name, {})[prop.name] = value
    if everything:
        settings.printed = None             # print_trigger(_): every derived event
    return unit


# ETALIS's declarations of the derived events to print (external_trigger: to notify).
PRINT_DECLARATIONS = ("print_trigger", "print_event", "external_trigger")
ALL = ("all",)


def _printed(spec: Term, span):
    """What print_trigger(Spec) selects: ALL, ("functor", Name or None, Arity or None) or
    ("pattern", Term). Spec is Name/Arity (either may be a variable: `_/0` is every event
    of arity 0), `all_defined_events` or `_` (every event), or an event pattern."""
    if isinstance(spec, Var) or spec == Atom("all_defined_events") or spec == Atom("all_events"):
        return ALL
    if _is(spec, "/", 2):
        name, arity = spec.args
        if not (isinstance(name, (Atom, Var)) and (isinstance(arity, Var) or
                                                  (isinstance(arity, Number) and isinstance(arity.value, int)))):
            raise RetalisSemanticError("print_trigger takes Name/Arity (or an event pattern)",
                                       span_of(spec) or span)
        if isinstance(name, Var) and isinstance(arity, Var):
            return ALL
        return ("functor", name.name if isinstance(name, Atom) else None,
                int(arity.value) if isinstance(arity, Number) else None)
    if isinstance(spec, (Atom, Compound)):
        return ("pattern", spec)
    raise RetalisSemanticError("print_trigger takes Name/Arity (or an event pattern)", span_of(spec) or span)


# ETALIS flags (other than event_consumption_policy): the values that are what retalisc
# always does (no warning), and what to say otherwise.
_FLAGS = {
    "subPatterns": (("on",), "subpatterns (Head <- Pattern) inside a pattern are always read"),
    "binarization_flag": (("on",), "rules are always binarized"),
    "out_of_order": (("on",), "events out of order are always handled, within --max-delay"),
    "revision_flag": (("on",), "deleting events (retractions) is always possible, within the retraction horizon"),
    "garbage_control": ((), "partial matches are collected by windows ((P).Q, event_rule_window) and the delay "
                            "bound, not by this flag"),
    "garbage_window": ((), "partial matches are collected by windows ((P).Q, event_rule_window), not by this "
                           "flag"),
    "garbage_window_step": ((), "partial matches are collected by windows, not by this flag"),
}


def _flag_warning(flag: Term, value: Term):
    name = flag.name if isinstance(flag, Atom) else write_term(flag)
    known = _FLAGS.get(name)
    if known is None:
        return f"ETALIS flag {write_term(flag)} has no meaning in retalisc and is ignored"
    silent, meaning = known
    if isinstance(value, Atom) and value.name in silent:
        return None
    return f"ETALIS flag {name} is ignored: {meaning}"



def _is(term: Term, name_: str, arity: int) -> bool:
    return isinstance(term, Compound) and term.name == name_ and term.arity == arity
