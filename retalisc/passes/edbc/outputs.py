"""A step's result (`e(Vars, S, E)` and `e_retract`): its conditions checked, then passed to
the next step or, for the last step, the head derived (or synchronized, or an alarm set), with
the record of when it was made for a policy step that takes it."""
from __future__ import annotations

from ...frontend.terms import Atom, Term
from ..unit import Step
from . import alarms
from .alarms import alarm_head
from .clauses import C, V, clause, conj
from .generator import RuleGenerator


def output_clauses(g: RuleGenerator, step: Step) -> None:
    """`e(Vars, S, E)`: check the step's conditions, then pass the result on (or derive
    the head); `e_retract(Vars, S, E)` takes it back the same way."""
    s, e = g.t("S"), g.t("E")
    conditions = [g.times(c, s, e) for c in step.conditions]
    arrivals = V(g.fresh("Arrivals")) if g.provenance else None
    for retract in (False, True):
        head = g.output(step, s, e, retract, arrivals if g.carries(step) else None)
        numbered = []
        if g.provenance and not g.carries(step):
            # (a sliding aggregate's value arrives when it is made; its deletion takes the
            # latest)
            numbered = [] if retract else [C("rtl_policy_arrival", arrivals)]
            arrivals = V("_") if retract else arrivals
        if step.derives_head:
            rule = g.rule.rule
            derive = "rtl_underived" if retract else "rtl_derived"
            action = C("rtl_action", rule.action) if rule.action is not None and not retract else None
            if rule.synchronized is not None:
                sync = "rtl_synchronized_retract" if retract else "rtl_synchronized"
                result = C(sync, *rule.synchronized.args, s, e)
            elif alarm_head(rule.head):
                result = alarms.alarm(g, step, rule.head, s, e, retract)
            else:
                result = None if rule.head == Atom("null") else C(derive, rule.head, s, e)
            detected = None if retract else C("rtl_detected", Atom(g.rule.rule_id))
            if g.provenance and result is not None and result.name in ("rtl_derived", "rtl_underived"):
                result = made(g, step, result, retract, arrivals)
            then = conj(numbered + [detected, action, result]) if (detected or action or result) else Atom("true")
        else:
            consumer, takes_arrivals = g.consumers[step.name]
            then = conj(numbered + [C(consumer + ("_retract" if retract else ""), *step.output.args,
                                      *([arrivals] if takes_arrivals else []), s, e)])
        body = [C("forall", conj(conditions), then)] if conditions else [then]
        g.clauses.append(clause(head, body))


def made(g: RuleGenerator, step: Step, result: Term, retract: bool, arrivals: Term) -> Term:
    """A result that a policy step takes as input, with the record of when it was made
    (`_made`, kept for the retraction horizon, with the arrival numbers it was made from):
    taking it back tells the policy step which of several identical arrivals to delete
    (rtl_policy_made/5, rtl_policy_unmade/5)."""
    s, e = g.t("S"), g.t("E")
    position = V(g.time_names.setdefault("Made", g.fresh("Made")))
    made = C(f"{step.name}_made", *step.output.args, s, e, arrivals, position)
    if not g.is_rotated(made):
        g.record(step, "made", list(made.args), rotated=True)
    return C("rtl_policy_unmade" if retract else "rtl_policy_made", *g.generations(made), arrivals, position,
             result)
