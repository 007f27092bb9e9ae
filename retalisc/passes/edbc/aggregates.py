"""Aggregates `L seq aggregate(F, R, V)`: accumulators started by each L and updated by the
later R's, with the records that let a deletion take back or replay the values it changed."""
from __future__ import annotations

from typing import List

from ...frontend.terms import Atom, Compound, Term
from ..unit import Step
from .clauses import C, V, clause, conj, list_term, operand_vars, split_key
from .generator import RuleGenerator


def aggregate_clauses(g: RuleGenerator, step: Step) -> None:
    """L seq aggregate(F, R, V): each L starts an accumulator; every later R updates the
    accumulators of the L's before it (within the window) and yields their new value V.
    Values follow the order the instances are processed in: each gets a sequence number,
    and the R's are recorded, so that deleting an L takes back its values and deleting an
    R replays the values of the accumulators it counted in (`_redo`). Numbered (a policy
    step takes the values), an R updates the accumulators in the arrival order of their
    L's."""
    function, value = step.aggregate
    s1, e1, s2, e2 = g.t("S1"), g.t("E1"), g.t("S2"), g.t("E2")
    acc0, acc = V(g.fresh("Acc0")), V(g.fresh("Acc"))
    seq, rseq, removed = V(g.fresh("Seq")), V(g.fresh("RSeq")), V(g.fresh("Removed"))
    items, values_, retracts, adds = (V(g.fresh(n)) for n in ("Items", "Values", "Retracts", "Adds"))
    left_vars, right_vars = operand_vars(step.left), operand_vars(step.right)
    key, left_other = split_key(left_vars, right_vars)
    _, right_other = split_key(right_vars, left_vars)
    # under a policy step that takes the values: the numbers of the start event and of the
    # event counted (rtl_policy.pl), so the values given again after a deletion arrive
    # where they were first given, and a deletion takes the latest arrival
    numbered = g.carries(step)
    # sequence number and accumulator before the times: the last two arguments of a store
    # are its interval (and numbered, the one before them its arrival number)
    numbers = (lambda a: [a, seq]) if numbered else (lambda a: [seq, a])
    lefts = g.store(step, "lefts", key + left_other + numbers(acc0) + [s1, e1])
    rights = g.record(step, "rights", key + right_other + [rseq, s2, e2], rotated=step.window is not None)

    def left_with(a: Term, kept: str = "") -> Term:
        return C(lefts.name + kept, *key, *left_other, *numbers(a), s1, e1)

    def take_latest(stores: List[Term]) -> Term:
        return C("rtl_policy_take_arrival", list_term(stores), Atom("none"))

    window = g.window_check(step, s1, e2)
    # the R's an accumulator counted, as rtl_aggregate_values/3 items
    counted = C("findall", C("-", rseq, C("-", C("-", function, s2), e2)),
                conj([g.record_lookup(rights), C(">", rseq, seq), C("<", e1, s2), window]), items)
    handler = f"{step.name}_left"
    g.arrival(step.left, handler, s1, e1)
    # the value over the empty set when the start event opens the aggregate (count, sum);
    # forall/2 leaves V unbound for the values that follow
    initial = C("rtl_aggregate_initial", function, value)
    counted_seq = V(g.fresh("CountedSeq")) if numbered else V("_")
    start_arrival = seq if numbered else None
    value_arrivals = C("-", seq, counted_seq) if numbered else None
    g.clauses.append(clause(C(handler, *left_vars, s1, e1), [
        C("rtl_next_seq", seq), C("assertz", left_with(Atom("none"))),
        C("forall", initial, g.output(step, s1, e1, arrivals=start_arrival))]))
    values = conj([C("forall", initial, g.output(step, s1, e1, retract=True, arrivals=start_arrival)),
                   counted, C("rtl_aggregate_values", items, V("_"), values_),
                   C("forall", C("member", C("-", counted_seq, C("-", value, e2)), values_),
                     g.output(step, s1, e2, retract=True, arrivals=value_arrivals))])
    if numbered:
        stored = left_with(V("_"))
        taken = C(";", C("->", take_latest([stored] + (g.kept_of(stored) if step.window is not None else [])),
                         values), Atom("true"))
    else:
        taken = g.if_stored(step, left_with(V("_")), values)
    g.clauses.append(clause(C(handler + "_retract", *left_vars, s1, e1), [taken]))
    handler = f"{step.name}_right"
    g.arrival(step.right, handler, s2, e2)
    loops = []
    for kept in (["", "_kept_a", "_kept_b"] if step.window is not None else [""]):
        # an accumulator is updated where it is stored (live or kept)
        found = conj([left_with(acc0, kept), C("<", e1, s2), window])
        update = conj([C("rtl_aggregate", function, acc0, acc, value), C("retract", left_with(acc0, kept)),
                       C("assertz", left_with(acc, kept)),
                       g.output(step, s1, e2, arrivals=C("-", seq, rseq) if numbered else None)])
        if numbered:
            # numbered values are made in the arrival order of their start events: an
            # update or a deletion's redo moves an accumulator to the end of its store,
            # and the policy step takes the values in the order they are made
            found_lefts, in_order = V(g.fresh("Lefts")), V(g.fresh("InOrder"))
            loops.append([C("findall", C("-", seq, left_with(acc0, kept)), found, found_lefts),
                          C("keysort", found_lefts, in_order),
                          C("forall", C("member", C("-", V("_"), left_with(acc0, kept)), in_order), update)])
        else:
            loops.append([C("forall", found, update)])
    # (numbered values: the counted event's number comes before the values it gives)
    body = [C("rtl_next_seq", rseq)] if numbered else []
    body += loops[0]
    if len(loops) > 1:
        body.append(C(";", C("->", C("rtl_late", e2), conj([g for loop in loops[1:] for g in loop])), Atom("true")))
    body += ([] if numbered else [C("rtl_next_seq", rseq)]) + [g.record_add(rights)]
    g.clauses.append(clause(C(handler, *right_vars, s2, e2), body))
    redo = C(f"{step.name}_redo", *key, *left_other, seq, s1, e1, removed)
    found = conj([g.lookup(step, left_with(V("_")), e2), C("<", seq, rseq), C("<", e1, s2), window])
    counted_taken = g.record_take(rights)
    if numbered:
        counted_taken = take_latest(g.generations(rights) if g.is_rotated(rights) else [rights])
    g.clauses.append(clause(C(handler + "_retract", *right_vars, s2, e2), [
        C(";", C("->", counted_taken,
                 C("forall", found, Compound(redo.name, redo.args[:-1] + (
                     C("-", rseq, C("-", C("-", function, s2), e2)),)))), Atom("true"))]))
    # one accumulator without the deleted R: take back its values from the R on, give the new ones
    replace: Term = Atom("true")
    for kept in (["_kept_b", "_kept_a", ""] if step.window is not None else [""]):
        replace = C(";", C("->", C("retract", left_with(V("_"), kept)), C("assertz", left_with(acc, kept))),
                    replace)
    replace = [replace]
    if numbered:
        g.clauses.append(clause(redo, [
            counted, C("rtl_aggregate_redo_numbered", items, removed, acc, retracts, adds),
            C("forall", C("member", C("-", counted_seq, C("-", value, e2)), retracts),
              g.output(step, s1, e2, retract=True, arrivals=value_arrivals)),
            g.restoring(C("forall", C("member", C("-", counted_seq, C("-", value, e2)), adds),
                             g.output(step, s1, e2, arrivals=value_arrivals)))] + replace))
        return
    g.clauses.append(clause(redo, [
        counted, C("rtl_aggregate_redo", items, removed, acc, retracts, adds),
        C("forall", C("member", C("-", value, e2), retracts), g.output(step, s1, e2, retract=True)),
        C("forall", C("member", C("-", value, e2), adds), g.output(step, s1, e2))] + replace))
