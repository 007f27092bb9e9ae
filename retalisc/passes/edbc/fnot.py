"""`L fnot N`: L, unless an N ended before L started (within the window, if any)."""
from __future__ import annotations

from ...frontend.terms import Atom
from ..unit import Step
from . import negation
from .clauses import C, clause, conj, operand_vars, split_key
from .generator import RuleGenerator
from .relations import blocker, blocker_window


def fnot_clauses(g: RuleGenerator, step: Step) -> None:
    """L fnot N: L, unless an N ended before L started (within the window, if any)."""
    s1, e1, sn, en = (g.t(n) for n in ("S1", "E1", "SN", "EN"))
    left_vars, negated_vars = operand_vars(step.left), operand_vars(step.negated)
    negated_key, negated_other = split_key(negated_vars, left_vars)
    left_key, left_other = split_key(left_vars, negated_vars)
    al = g.arrivals(step, "left")
    arrivals = al[0] if al else None
    lefts = g.store(step, "lefts", left_key + left_other + al + [s1, e1])
    negs = g.store(step, "negs", negated_key + negated_other + [sn, en])
    # what blocks L, and the span of a blocker the window bounds (rtl_relations.pl)
    blocking = g.expr(blocker("fnot"))
    within = g.window_check(step, *(g.renamed(t) for t in blocker_window("fnot")))
    before = blocking + [within, Atom("!")]
    unblocked = negation.unblocked_goal(g, step, f"{step.name}_blocked", negated_key + [s1, e1], negs,
                                        [goal for goal in before if goal is not None], e1)
    handler = f"{step.name}_left"
    g.arrival(step.left, handler, s1, e1, *al)
    derivable = conj([unblocked, g.window_check(step, s1, e1)])
    g.clauses.append(clause(C(handler, *left_vars, *al, s1, e1), [
        C(";", C("->", derivable, g.output(step, s1, e1, arrivals=arrivals)), Atom("true")),
        C("assertz", lefts)]))
    undo = C(";", C("->", derivable, g.output(step, s1, e1, retract=True, arrivals=arrivals)), Atom("true"))
    taken = (g.take_arrival(step, lefts, left_vars + [s1, e1], undo) if al
             else g.if_stored(step, lefts, undo))
    g.clauses.append(clause(C(handler + "_retract", *left_vars, *al, s1, e1), [taken]))
    handler = f"{step.name}_negated"
    g.arrival(step.negated, handler, sn, en)
    after = conj([g.lookup(step, lefts, en)] + blocking + [within, unblocked])
    g.clauses.append(clause(C(handler, *negated_vars, sn, en), [
        C("forall", after, g.output(step, s1, e1, retract=True, arrivals=arrivals)), C("assertz", negs)]))
    g.clauses.append(clause(C(handler + "_retract", *negated_vars, sn, en), [
        g.if_stored(step, negs,
                       g.restoring(C("forall", after, g.output(step, s1, e1, arrivals=arrivals))))]))
