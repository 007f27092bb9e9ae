"""Absence `not(N).[L, D]`: no N in the D seconds after L ends, decided on a timer once no
blocker within the delay bound can come any more."""
from __future__ import annotations

from dataclasses import replace

from ...frontend.terms import Atom, Number, substitute
from ..unit import Step
from . import negation
from .clauses import C, V, clause, conj, operand_vars, plain_number, split_key
from .generator import RuleGenerator
from .relations import absence_result, blocker, plain_var


def absence_clauses(g: RuleGenerator, step: Step) -> None:
    """not(N).[L, D]: no N in the D seconds after L ends (N starts after L's end and ends by
    L's end + D). Each L waits on a timer until the clock has passed its end + D + max_delay
    (rtl_absence_wait/2): then no blocker within the delay bound can come any more, and the
    result [L's start, L's end + D] is derived unless a stored N blocks it. The decided L's
    are kept (window D) so that a late blocker takes the result back and deleting the
    blocker derives it again; deleting L takes back its result or cancels its timer."""
    duration = plain_number(step.duration)
    s1, e1, sn, en = (g.t(n) for n in ("S1", "E1", "SN", "EN"))
    close = V(g.fresh("Close"))
    left_vars, negated_vars = operand_vars(step.left), operand_vars(step.negated)
    negated_key, negated_other = split_key(negated_vars, left_vars)
    left_key, left_other = split_key(left_vars, negated_vars)
    # both stores count as windowed by 2D: a decided L is stored by [L's end, L's end + D],
    # a blocker by its own interval; an L within the delay bound needs neither once it is
    # older than D, and a result (decided D + max_delay after L) stays exact for deletions
    # for another D (the retraction horizon is max_delay plus the largest window)
    stores = replace(step, window=2 * float(step.duration))
    # (a result a policy step takes arrives when it is decided)
    decided_at = [V(g.fresh("DecidedAt"))] if g.carries(step) else []
    arrivals = decided_at[0] if decided_at else None
    decided = g.store(stores, "decided", left_key + left_other + decided_at + [s1, e1, close])
    negs = g.store(stores, "negs", negated_key + negated_other + [sn, en])
    # the result's interval and what blocks it (rtl_relations.pl): the result's end is `close`
    start, end = absence_result()
    s = g.renamed(plain_var(start, "start of an absence"))
    blocking = g.expr([substitute(b, {"E2": close}) for b in blocker("absence")])
    inside = blocking + [Atom("!")]
    unblocked = negation.unblocked_goal(g, stores, f"{step.name}_blocked", negated_key + [e1, close], negs, inside, e1)
    closing = C("is", close, g.renamed(substitute(end, {"D": Number(duration)})))
    decide = C(f"{step.name}_decide", *left_vars, s1, e1)
    window = g.window_check(step, s, close)
    derivable = conj([window, unblocked])
    # L arrives: wait for the clock; L is deleted: cancel the wait, or take back the result
    handler = f"{step.name}_left"
    g.arrival(step.left, handler, s1, e1)
    g.clauses.append(clause(C(handler, *left_vars, s1, e1), [closing, C("rtl_absence_wait", close, decide)]))
    g.clauses.append(clause(C(handler + "_retract", *left_vars, s1, e1), [
        closing,
        C(";", C("->", C("rtl_timer_cancel", decide), Atom("true")),
          g.if_stored(stores, decided, C(";", C("->", derivable, g.output(step, s, close, retract=True,
                                                                                arrivals=arrivals)),
                                                Atom("true"))))]))
    g.clauses.append(clause(decide, [
        closing] + [C("rtl_policy_arrival", a) for a in decided_at] + [C("assertz", decided),
        C(";", C("->", derivable, g.output(step, s, close, arrivals=arrivals)), Atom("true"))]))
    # a blocker takes back the decided results it falls inside of; deleting it restores them
    handler = f"{step.name}_negated"
    g.arrival(step.negated, handler, sn, en)
    found = conj([g.lookup(stores, decided, en)] + blocking + [derivable])
    g.clauses.append(clause(C(handler, *negated_vars, sn, en), [
        C("forall", found, g.output(step, s, close, retract=True, arrivals=arrivals)), C("assertz", negs)]))
    g.clauses.append(clause(C(handler + "_retract", *negated_vars, sn, en), [
        g.if_stored(stores, negs, g.restoring(C("forall", found, g.output(step, s, close,
                                                                                  arrivals=arrivals))))]))
