"""Joins: the binary operators (`seq`, `and`, `par`, `equals`, `meets`, `during`, `starts`,
`finishes`) on symmetric stores keyed by the join variables, and `or` and single-operand steps,
whose every operand instance is a result. Under `first` a join selects (`first`); under
`recent` and `chronological` it consumes (`policies`)."""
from __future__ import annotations

from typing import List, Optional

from ...frontend.terms import Atom, Term, Var, substitute
from ..unit import Step
from . import first, policies, relations
from .clauses import C, V, clause, conj, list_term, operand_vars, split_key
from .generator import RuleGenerator


def forward_clauses(g: RuleGenerator, step: Step) -> None:
    """`or` and single-operand steps: every operand instance is a result."""
    s1, e1 = g.t("S1"), g.t("E1")
    for side, operand in (("left", step.left), ("right", step.right)):
        if operand is None:
            continue
        handler = f"{step.name}_{side}"
        arrivals = g.arrivals(step, "left")
        g.arrival(operand, handler, s1, e1, *arrivals)
        params = operand_vars(operand)
        window = g.window_check(step, s1, e1)
        for suffix, retract in (("", False), ("_retract", True)):
            output = g.output(step, s1, e1, retract, *arrivals)
            if step.name in g.branches:
                output = substitute(output, {g.branches[step.name].name: Atom(side)})
            g.clauses.append(clause(C(handler + suffix, *params, *arrivals, s1, e1), [window, output]))


def join_clauses(g: RuleGenerator, step: Step) -> None:
    if g.first:
        first.first_join_clauses(g, step)
        return
    relation, start_expr, end_expr = relations.relation(step.op)
    s1, e1, s2, e2 = g.t("S1"), g.t("E1"), g.t("S2"), g.t("E2")
    left_vars, right_vars = operand_vars(step.left), operand_vars(step.right)
    key, left_other = split_key(left_vars, right_vars)
    _, right_other = split_key(right_vars, left_vars)
    recent = g.policy == "recent"
    pl, pr = policies.positions(g)
    al, ar = g.arrivals(step, "left"), g.arrivals(step, "right")
    lefts = g.store(step, "lefts", key + left_other + pl + al + [s1, e1], newest_first=recent)
    rights = g.store(step, "rights", key + right_other + pr + ar + [s2, e2], newest_first=recent)
    s, start_goals = g.interval(start_expr, g.t("S"))
    e, end_goals = g.interval(end_expr, g.t("E"))
    match = g.expr(relation) + start_goals + end_goals + [g.window_check(step, s, e)]
    matched = policies.matched_record(g, step, lefts, rights, s, e)
    sides = (("left", step.left, left_vars, al, lefts, rights),
             ("right", step.right, right_vars, ar, rights, lefts))
    for side, operand, own_vars, own_arrivals, own_store, partner_store in sides:
        handler = f"{step.name}_{side}"
        os_, oe = (s1, e1) if side == "left" else (s2, e2)
        g.arrival(operand, handler, os_, oe, *own_arrivals)
        # A left instance of `seq` ending no earlier than every start seen so far has no
        # right partner stored (rtl_started_after/1): in time order, the common case.
        skip = C("rtl_started_after", oe) if step.op == "seq" and side == "left" else None
        found = conj([skip, g.lookup(step, partner_store, oe)] + match)
        join_handlers(g, step, handler, own_vars, own_arrivals, os_, oe, own_store, partner_store, found,
                           matched, s, e, key, side, pair_arrivals(al, ar))
    policies.policy_facts(g, step, key, lefts, rights, matched, s, e)


def join_handlers(g: RuleGenerator, step: Step, handler: str, own_vars: List[Var], own_arrivals: List[Var], os_: Var,
                  oe: Var, own_store: Term, partner_store: Term, found: Term, matched: Optional[Term], s: Term,
                  e: Term, key: List[Var], side: str, arrivals: Optional[Term]) -> None:
    """The add and delete rules of one side of a join (also of `cnot`): unrestricted, every
    partner found makes a result, and deleting takes back what the instance made with the
    partners still stored; under a policy, see consuming_join/consumed_retract."""
    head = C(handler, *own_vars, *own_arrivals, os_, oe)
    retract_head = C(handler + "_retract", *own_vars, *own_arrivals, os_, oe)
    if matched is None:
        g.clauses.append(clause(head, [C("forall", found, g.output(step, s, e, arrivals=arrivals)),
                                          C("assertz", own_store)]))
        take = g.take_arrival if own_arrivals else g.if_own_stored
        g.clauses.append(clause(retract_head, [
            take(step, own_store, own_vars + [os_, oe],
                 C("forall", found, g.output(step, s, e, retract=True, arrivals=arrivals)))]))
        return
    # A partner that fails the step's conditions is not a match: it is neither chosen nor
    # consumed, as when the condition is pushed onto an event (the output checks them again).
    selected = conj([found] + [g.times(c, s, e) for c in step.conditions])
    position = own_store.args[-3]
    at = C(handler + "_at", position, *own_vars, os_, oe)
    body = policies.consuming_join(g, step, selected, partner_store, own_store, matched, g.output(step, s, e))
    runtime_key = None if step.name in g.loose else key
    g.clauses.append(clause(head, [policies.positioned(g, step, runtime_key, position, at, body)]))
    g.clauses.append(clause(at, [body]))
    g.clauses.append(clause(retract_head, [
        C("rtl_policy_delete", Atom(step.name), Atom(side),
          V("_") if runtime_key is None else list_term(key), own_store)]))


def pair_arrivals(al: List[Var], ar: List[Var]) -> Optional[Term]:
    """The arrival numbers of a pair's result: `LArrivals-RArrivals`."""
    return C("-", al[0], ar[0]) if al else None
