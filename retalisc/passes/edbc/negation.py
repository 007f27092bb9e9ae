"""Negation `not(N).[L, R]` (`cnot`): L seq R with no N strictly between, derived eagerly and
taken back when a blocker arrives late; the sweep that forgets blockers of unwindowed steps;
and the blocker search (`unblocked_goal`) that `fnot` and `absence` share."""
from __future__ import annotations

from typing import List

from ...frontend.terms import Atom, Number, Term, Var, distinct_variables, variables
from ..unit import Step
from . import joins, policies
from .clauses import C, V, clause, conj, operand_vars, split_key
from .generator import RuleGenerator
from .relations import blocker, over, plain_var, relation
from .rule_policies import signature


def negation_clauses(g: RuleGenerator, step: Step) -> None:
    """not(N).[L, R]: L seq R with no N strictly between L's end and R's start. Under a
    consumption policy, L and R pair up as in a join and a later N takes nothing back."""
    s1, e1, s2, e2, sn, en = (g.t(n) for n in ("S1", "E1", "S2", "E2", "SN", "EN"))
    left_vars, right_vars = operand_vars(step.left), operand_vars(step.right)
    negated_vars = operand_vars(step.negated)
    key, left_other = split_key(left_vars, right_vars)
    _, right_other = split_key(right_vars, left_vars)
    pair_vars = distinct_variables(left_vars + right_vars)
    negated_key, negated_other = split_key(negated_vars, pair_vars)
    recent = g.policy == "recent"
    pl, pr = policies.positions(g)
    pn = [V(g.fresh("NPos"))] if pl else []
    al, ar = g.arrivals(step, "left"), g.arrivals(step, "right")
    arrivals = joins.pair_arrivals(al, ar)
    lefts = g.store(step, "lefts", key + left_other + pl + al + [s1, e1], newest_first=recent)
    rights = g.store(step, "rights", key + right_other + pr + ar + [s2, e2], newest_first=recent)
    negs = g.store(step, "negs", negated_key + negated_other + pn + [sn, en])
    # the pair's relation and what blocks it (rtl_relations.pl)
    relation_goals, start, end = relation("cnot")
    s, e = g.renamed(plain_var(start, "start of a cnot")), g.renamed(plain_var(end, "end of a cnot"))
    blocking = blocker("cnot")
    between = g.expr(blocking) + [Atom("!")]
    if pn:
        # under a policy a blocker blocks the pairs made after it arrived (rtl_policy.pl)
        between.insert(0, C("<", pn[0], C("max", pl[0], pr[0])))
    unblocked = unblocked_goal(g, step, f"{step.name}_blocked", negated_key + [e1, s2] + pl + pr, negs, between, e)
    window = g.window_check(step, s, e)
    pair = g.expr(relation_goals) + [window, unblocked]
    matched = policies.matched_record(g, step, lefts, rights, s, e)
    forget_blockers(g, step, lefts, negs, s1, e1, sn, en)
    for side, operand, own_vars, own_arrivals, own_store, partner_store in (
            ("left", step.left, left_vars, al, lefts, rights),
            ("right", step.right, right_vars, ar, rights, lefts)):
        handler = f"{step.name}_{side}"
        os_, oe = (s1, e1) if side == "left" else (s2, e2)
        g.arrival(operand, handler, os_, oe, *own_arrivals)
        skip = C("rtl_started_after", oe) if side == "left" else None     # as for `seq` (join_clauses)
        found = conj([skip, g.lookup(step, partner_store, oe)] + pair)
        joins.join_handlers(g, step, handler, own_vars, own_arrivals, os_, oe, own_store, partner_store, found,
                           matched, s, e, key, side, arrivals)
    policies.policy_facts(g, step, key, lefts, rights, matched, s, e, negs if pn else None)
    # a blocker takes back the results it falls inside of; deleting it restores them
    handler = f"{step.name}_negated"
    g.arrival(step.negated, handler, sn, en)
    # (the blocker's comparisons with L as soon as L is found, then those with R)
    with_left = over(blocking, {"S1", "E1", "SN", "EN"})
    inside = conj([g.lookup(step, lefts, en)] + g.expr(with_left) + [g.lookup(step, rights, en)]
                  + g.expr([b for b in blocking if b not in with_left]) + [
                   window, unblocked])
    if g.policy != "unrestricted":
        # the pairs made after the blocker arrived are made again without it, or with it
        # when it comes from a replay (rtl_policy.pl)
        at = C(handler + "_at", pn[0], *negated_vars, sn, en)
        g.clauses.append(clause(C(handler, *negated_vars, sn, en), [
            policies.positioned(g, step, None, pn[0], at, C("assertz", negs))]))
        g.clauses.append(clause(at, [C("assertz", negs)]))
        g.clauses.append(clause(C(handler + "_retract", *negated_vars, sn, en), [
            C("rtl_policy_delete", Atom(step.name), Atom("negated"), V("_"), negs)]))
        return
    g.clauses.append(clause(C(handler, *negated_vars, sn, en), [
        C("forall", inside, g.output(step, s, e, retract=True, arrivals=arrivals)), C("assertz", negs)]))
    g.clauses.append(clause(C(handler + "_retract", *negated_vars, sn, en), [
        g.if_stored(step, negs,
                       g.restoring(C("forall", inside, g.output(step, s, e, arrivals=arrivals))))]))


def forget_blockers(g: RuleGenerator, step: Step, lefts: Term, negs: Term, s1: Var, e1: Var, sn: Var, en: Var) -> None:
    """The sweep of an unwindowed `not(N).[L, R]` whose R is an event: `ele_forget_blockers(Clock)`
    drops each N that ended before `Before` together with the waiting Ls it blocks (those that
    ended before it started). `rtl_blockers_due/4` says whether this step's sweep is due and
    gives a `Before` that no later R can start before (the delay bound and the longest
    interval of an R seen) and that lies outside the retraction horizon: such an L can never
    pair again, and no later L can end before such an N starts, so the N can block nothing
    more. Only when N's key is L's (else an N blocks an L only for some Rs)."""
    if step.window is not None or not step.right.is_event or signature(step.right.term) is None:
        return
    left_names = {v.name for v in operand_vars(step.left)}
    if not {v.name for v in operand_vars(step.negated)} & (left_names | {v.name for v in operand_vars(step.right)}) \
            <= left_names:
        return
    clock, before = V(g.fresh("Clock")), V(g.fresh("Before"))
    name, arity = signature(step.right.term)
    blocked_lefts = conj([lefts, C("<", e1, sn)])
    g.clauses.append(clause(C("ele_forget_blockers", clock), [
        C("rtl_blockers_due", Atom(step.name), C("/", Atom(name), Number(arity)), clock, before),
        C("forall", conj([negs, C("<", en, before)]),
          conj([C("forall", blocked_lefts, C("retract", lefts)), C("retract", negs)]))]))


def unblocked_goal(g: RuleGenerator, step: Step, name_: str, args: List[Term], negs: Term, check: List[Term],
                   late_end: Term) -> Term:
    """`\\+ Blocked`: no stored blocker passes `check`. The clause `name_(args)` searches the
    live blockers; for a windowed step, `name__late` also the kept ones, for a match that
    ends late (at `late_end`)."""
    known = {v.name for t in args + [negs] for v in variables(t)}
    assert {v.name for t in check for v in variables(t)} <= known, f"{name_}: {check} reads a variable not in {args}"
    blocked = C(name_, *args)
    g.clauses.append(clause(blocked, [negs] + check))
    if step.window is None:
        return C("\\+", blocked)
    blocked_late = C(name_ + "_late", *args)
    g.clauses.append(clause(blocked_late, [C(";", negs, g.kept_lookup(negs))] + check))
    return C("\\+", C(";", C("->", C("rtl_late", late_end), blocked_late), blocked))
