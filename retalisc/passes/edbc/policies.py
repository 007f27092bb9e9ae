"""The `recent` and `chronological` consumption policies (ETALIS): a join with one waiting
partner that consumes both, the record of each match, the positions (arrival numbers) of the
instances and the `<step>_policy/1` facts with which the runtime rewinds a step and replays
its later arrivals after a deletion (prolog_runtime/rtl_policy.pl)."""
from __future__ import annotations

from typing import List, Optional, Tuple

from ...frontend.terms import Atom, Compound, Term, Var, substitute
from ..unit import Step
from .clauses import C, V, conj, list_term, operand_vars, split_key
from .generator import RuleGenerator


def positions(g: RuleGenerator) -> Tuple[List[Var], List[Var]]:
    """Under a consumption policy, the position arguments of the left and right stores
    (prolog_runtime/rtl_policy.pl): the arrival number of each instance."""
    if g.policy == "unrestricted":
        return [], []
    return [V(g.fresh("LPos"))], [V(g.fresh("RPos"))]


def positioned(g: RuleGenerator, step: Step, key: Optional[List[Var]], position: Var, at: Term, body: Term) -> Term:
    """Process an instance at its position (`body`, also the clause of `at`): now, or,
    when it comes from a replay (its position is in the past), rewinding the step first
    (rtl_policy_insert/4)."""
    mode = V(g.fresh("Mode"))
    insert = C("rtl_policy_insert", Atom(step.name), V("_") if key is None else list_term(key), position, at)
    return conj([C("rtl_position", position, mode),
                 C(";", C("->", C("==", mode, Atom("now")), body), insert)])


def policy_facts(g: RuleGenerator, step: Step, key: List[Var], lefts: Term, rights: Term, matched: Optional[Term],
                 s: Term, e: Term, negs: Optional[Term] = None) -> None:
    """`<step>_policy/1`: what the runtime needs to rewind the step (rtl_policy.pl)."""
    if matched is None:
        return
    info = f"{step.name}_policy"
    g.clauses.append(C(info, C("order", Atom(g.policy))))
    for side, stored in (("left", lefts), ("right", rights)):
        own = operand_vars(step.left if side == "left" else step.right)
        kept = g.kept_of(stored) if step.window is not None else []
        at = C(f"{step.name}_{side}_at", stored.args[-3], *own, stored.args[-2], stored.args[-1])
        g.clauses.append(C(info, C("entry", Atom(side), list_term(key), stored.args[-3], stored,
                                      list_term(kept), at)))
    left_form, right_form, record = lefts, rights, matched
    if step.name in g.loose:
        names = {}
        for var, form in zip(g.loose[step.name], (lefts, rights)):
            kept_key = [V(g.fresh("K")) for _ in key]
            names[var.name] = list_term(kept_key)
            if form is lefts:
                left_form = C(form.name, *kept_key, *form.args[len(key):])
            else:
                right_form = C(form.name, *kept_key, *form.args[len(key):])
        record = substitute(matched, names)
    g.clauses.append(C(info, C("match", list_term(key), list_term(g.generations(record)),
                                  lefts.args[-3], rights.args[-3], g.output(step, s, e, retract=True),
                                  left_form, right_form)))
    if g.policy == "recent":
        for stored in (lefts, rights):
            dropped = dropped_record(g, step, stored)
            g.clauses.append(C(info, C("dropped", list_term(g.generations(dropped)), dropped.args[0],
                                          dropped.args[1])))
    if negs is not None:
        kept = g.kept_of(negs) if step.window is not None else []
        g.clauses.append(C(info, C("blocker", negs.args[-3], negs, list_term(kept))))


def dropped_record(g: RuleGenerator, step: Step, stored: Term) -> Term:
    """Under `recent`, the record of a waiting twin replaced by a new arrival (its stored
    form, and the position of the arrival)."""
    by = V(g.fresh("ByPos"))
    name_ = f"{step.name}_dropped"
    if not any(r[0] == name_ for r in g.records):
        g.record(step, "dropped", [V("_"), V("_")], rotated=True)
    return C(name_, stored, by)


def matched_record(g: RuleGenerator, step: Step, lefts: Term, rights: Term, s: Term, e: Term) -> Optional[Term]:
    """Under a consumption policy, the record of a match made: both instances and the
    interval of the result (kept for the retraction horizon, by the end of the result)."""
    if g.policy == "unrestricted":
        return None
    args = list(lefts.args) + partner_only_args(lefts, rights) + [s, e]
    if any(v.name in g.unbound for v in key_of(g, step)):
        # a partial match from one branch of an `or` may leave a key variable unbound: it
        # pairs with every key, and the join binds it; the record keeps each side's key as
        # it was stored, to restore it (rtl_policy.pl)
        g.loose[step.name] = (V(g.fresh("LKey")), V(g.fresh("RKey")))
        args += list(g.loose[step.name])
    return g.record(step, "matched", args, rotated=True)


def key_of(g: RuleGenerator, step: Step) -> List[Var]:
    key, _ = split_key(operand_vars(step.left), operand_vars(step.right))
    return key


def partner_only_args(lefts: Term, rights: Term) -> List[Term]:
    """The arguments of `rights` that `lefts` does not have already (the join key)."""
    seen = {a.name for a in lefts.args if isinstance(a, Var)}
    return [a for a in rights.args if not (isinstance(a, Var) and a.name in seen)]


def consuming_join(g: RuleGenerator, step: Step, found: Term, partner: Term, own: Term, matched: Term,
                   output: Term) -> Term:
    """recent/chronological: join with one waiting partner, the newest (recent: stores
    are filled with asserta, so it comes first) or the oldest, and consume both, recording
    the match; with no partner, wait. Under `recent` a waiting twin of the same event is
    replaced."""
    store = "asserta" if g.policy == "recent" else "assertz"
    wait = C(store, own)
    if g.policy == "recent":
        # a twin is the same events (a variant: a partial match from one branch of an `or`
        # leaves the other branch's variables unbound, and must not unify with another);
        # a replaced twin is recorded, for deletions (rtl_policy.pl)
        times = [V(g.fresh(n)) for n in ("TwinPos", "TwinStart", "TwinEnd")]
        twin = Compound(own.name, tuple(own.args[:-3]) + tuple(times))
        dropped = dropped_record(g, step, twin)
        dropped = Compound(dropped.name, (twin, own.args[-3]))
        stores = [twin] + (g.kept_of(twin) if step.window is not None else [])
        # (one at most: every instance that waits replaces its twins)
        drop_all = conj([C(";", C("->", C("retract", t), g.record_add(dropped)), Atom("true")) for t in stores])
        drop = C(";", C("->", C("ground", own), drop_all), C("rtl_policy_drop_twins", Atom(step.name), own))
        wait = C(",", drop, wait)
    if step.name in g.loose:
        key = key_of(g, step)
        own_key, partner_key = g.loose[step.name]
        if own.name.endswith("_rights"):
            partner_key, own_key = own_key, partner_key
        consume = conj([C("rtl_policy_take", Atom(step.name), partner, partner_key), g.record_add(matched),
                        output])
        return conj([C("copy_term", list_term(key), own_key), C(";", C("->", C("once", found), consume), wait)])
    consume = conj([g.take(step, partner), g.record_add(matched), output])
    return C(";", C("->", C("once", found), consume), wait)
