"""The `first` selection in a join: each left instance pairs with its first matching right
instance only, whatever the arrival order."""
from __future__ import annotations

from typing import List

from ...frontend.terms import Atom, Term, Var, substitute
from ..unit import Step
from . import relations
from .clauses import C, V, clause, conj, operand_vars, split_key
from .generator import RuleGenerator


def first_join_clauses(g: RuleGenerator, step: Step) -> None:
    """The `first` selection: each left instance L pairs with its first matching right
    instance only (the smallest by start, end, then the term: by time, whatever the
    arrival order), and a right instance may serve several L's. `_first` records the
    pairing of each L: a right instance that arrives (late) before an L's partner takes its
    place, and deleting the partner pairs the L with the next one; so the output is always
    that of the events present."""
    relation, start_expr, end_expr = relations.relation(step.op)
    s1, e1, s2, e2 = g.t("S1"), g.t("E1"), g.t("S2"), g.t("E2")
    left_vars, right_vars = operand_vars(step.left), operand_vars(step.right)
    key, left_other = split_key(left_vars, right_vars)
    _, right_other = split_key(right_vars, left_vars)
    # each stored L is numbered (identical L's pair each on their own): by its arrival
    # numbers when it has them
    al, ar = g.arrivals(step, "left"), g.arrivals(step, "right")
    lid = al[0] if al else V(g.fresh("LId"))
    lefts = g.store(step, "lefts", key + left_other + [lid, s1, e1])
    rights = g.store(step, "rights", key + right_other + ar + [s2, e2])
    paired = g.record(step, "first", key + left_other + [lid, s1, e1] + right_other + ar + [s2, e2],
                         rotated=step.window is not None)

    # In a rule with `or`, a partial match may leave a key variable unbound: an L that pairs
    # with every key. Its partners are then ranked with their key too, its pairing record
    # is found by its number (whatever key the pairing bound), and it pairs again in the
    # form it was stored in.
    loose = any(v.name in g.unbound for v in key)

    def with_right(r_key: List[Term], r_other: List[Term], rs: Term, re_: Term):
        """The goals and interval of a match of the L with right instance (r_other, rs, re_)."""
        names = {"S1": s1, "E1": e1, "S2": rs, "E2": re_}
        goals = [substitute(g, names) for g in relation]
        start = substitute(start_expr, names)
        end = substitute(end_expr, names)
        s_, e_ = V(g.fresh("S")), V(g.fresh("E"))
        bounds = [C("is", s_, start), C("is", e_, end)]
        window = g.window_check(step, s_, e_)
        rank = C("-", C("-", rs, re_), C("r", *(r_key + r_other)))
        return goals, bounds + ([window] if window is not None else []), s_, e_, rank

    def variant(tag: str):
        """The right instance's terms with its variables renamed apart (`tag` "" keeps them)."""
        renamed = right_other + ar + [s2, e2] + (key if tag == "P" and loose else [])
        if tag:
            names = {v.name: V(g.fresh(v.name + tag)) for v in renamed}
            r_other = [names[v.name] for v in right_other]
            rs, re_ = names[s2.name], names[e2.name]
        else:
            names, r_other, rs, re_ = {}, right_other, s2, e2
        r_key = [names.get(v.name, v) for v in key] if loose else []
        # (of identical right instances, the one that arrived first)
        r_arrivals = [names.get(v.name, v) for v in ar]
        goals_, bounds_, s_, e_, rank_ = with_right(r_key, r_other + r_arrivals, rs, re_)
        store = substitute(rights, names)
        pairing = substitute(paired, names)
        out = [a if not isinstance(a, Var) else names.get(a.name, a) for a in step.output.args]
        inner = [C("-", lid, names.get(ar[0].name, ar[0]))] if ar else []
        return {"goals": goals_, "bounds": bounds_, "rank": rank_, "rights": store, "paired": pairing,
                "add": C(step.name, *out, s_, e_, *inner), "retract": C(step.name + "_retract", *out, s_, e_, *inner)}

    def pair_best(late_end: Term) -> Term:
        """Pair the L with its first right instance, if any (variables of its own)."""
        q = variant("Q")
        best = V(g.fresh("Ranks"))
        found = conj([g.lookup(step, q["rights"], late_end)] + q["goals"] + q["bounds"])
        return C(";", C("->", conj([C("findall", q["rank"], found, best), C("min_member", q["rank"], best)]),
                         conj(q["bounds"] + [g.record_add(q["paired"]), q["add"]])), Atom("true"))

    own = variant("")
    handler = f"{step.name}_left"
    g.arrival(step.left, handler, s1, e1, *al)
    take = g.take_arrival if al else g.if_own_stored
    g.clauses.append(clause(C(handler, *left_vars, *al, s1, e1), [
        *([] if al else [C("rtl_next_seq", lid)]), C("assertz", lefts), pair_best(e1)]))
    g.clauses.append(clause(C(handler + "_retract", *left_vars, *al, s1, e1), [
        take(step, lefts, left_vars + [s1, e1],
             C(";", C("->", g.record_take(paired), conj(own["bounds"] + [own["retract"]])), Atom("true")))]))
    # a right instance: the L's it matches take it if it comes before their partner
    p_ = variant("P")
    take_over = conj([C("@<", own["rank"], p_["rank"]), g.record_take(p_["paired"])] + p_["bounds"]
                     + [p_["retract"], g.record_add(paired), own["add"]])
    handler = f"{step.name}_right"
    g.arrival(step.right, handler, s2, e2, *ar)
    g.clauses.append(clause(C(handler, *right_vars, *ar, s2, e2), [
        C("assertz", rights),
        C("forall", conj([g.lookup(step, lefts, e2)] + own["goals"] + own["bounds"]),
          C(";", C("->", g.record_lookup(p_["paired"]), C(";", C("->", take_over, Atom("true")), Atom("true"))),
            conj([g.record_add(paired), own["add"]])))]))
    # deleting a right instance: the L's paired with it take their next one
    again = pair_best(e1)
    if loose:
        # (the L as it is stored, numbered LId: the pairing bound its key)
        again = C(f"{step.name}_left_again", lid)
        stored_left = lefts if step.window is None else C(";", lefts, g.kept_lookup(lefts))
        g.clauses.append(clause(again, [stored_left, pair_best(e1)]))
    g.clauses.append(clause(C(handler + "_retract", *right_vars, *ar, s2, e2), [
        take(step, rights, right_vars + [s2, e2], C("forall", g.record_lookup(paired), conj(
            [g.record_take(paired)] + own["bounds"] + [own["retract"], g.restoring(again)])))]))
