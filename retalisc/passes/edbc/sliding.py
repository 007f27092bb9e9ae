"""Sliding-window aggregates `sliding(F, P, Group, D, V)`: the matches of P stored by group,
the changes of the value refreshed on arrivals, deletions and timers (rtl_sliding.pl); the
numbered form for changes that a policy step takes."""
from __future__ import annotations

from dataclasses import replace

from ...frontend.terms import Atom, Compound, Number, distinct_variables, variables
from ..unit import Step
from .clauses import C, V, clause, conj, list_term, operand_vars, plain_number
from .generator import RuleGenerator


def sliding_parts(g: RuleGenerator, step: Step):
    """What both forms of a sliding step are built from: the function, the value, the
    duration, the match's times, the operand's and the group's variables, the aggregated
    term (1 for count) and the step as its stores see it (windowed by the duration)."""
    function, group, value = step.sliding
    duration = plain_number(step.duration)
    s1, e1 = g.t("S1"), g.t("E1")
    inner_vars = operand_vars(step.left)
    group_vars = distinct_variables(variables(group))
    x = function.args[0] if isinstance(function, Compound) else Number(1)
    return function, value, duration, s1, e1, inner_vars, group_vars, x, replace(step, window=float(step.duration))


def sliding_clauses(g: RuleGenerator, step: Step) -> None:
    """sliding(F, P, Group, D, V): the matches of P are stored by group (with the value F
    aggregates, and their end twice: the interval the sweep reads), and so are the changes
    output; an arrival or a deletion refreshes the changes of its group in [E, E + D] up to
    the clock, and a timer at E + D refreshes that moment when the clock reaches it
    (rtl_sliding.pl)."""
    function, value, duration, s1, e1, inner_vars, group_vars, x, stores = sliding_parts(g, step)
    matched = g.store(stores, "slid", group_vars + [V(g.fresh("X")), s1, e1, e1])
    t = V(g.fresh("T"))
    shown = g.store(stores, "changes", group_vars + [value, t, t])
    base = step.name
    x_, e_, v_, t_ = (V(g.fresh(n)) for n in ("Xs", "Es", "Vs", "Ts"))
    # the group's matches and changes, live and kept
    stored_match = C(matched.name, *group_vars, x_, V("_"), e_, V("_"))
    g.clauses.append(clause(C(f"{base}_matches", *group_vars, x_, e_),
                               [C(";", stored_match, g.kept_lookup(stored_match))]))
    stored_shown = C(shown.name, *group_vars, v_, t_, V("_"))
    g.clauses.append(clause(C(f"{base}_shown", *group_vars, v_, t_),
                               [C(";", stored_shown, g.kept_lookup(stored_shown))]))
    g.clauses.append(clause(C(f"{base}_show", *group_vars, value, t), [
        C("assertz", shown), g.output(step, t, t)]))
    g.clauses.append(clause(C(f"{base}_unshow", *group_vars, value, t), [
        g.if_stored(stores, shown, g.output(step, t, t, retract=True))]))
    frm, to = V(g.fresh("From")), V(g.fresh("To"))
    g.clauses.append(clause(C(f"{base}_refresh", *group_vars, frm, to), [
        C("rtl_sliding_refresh", function, Number(duration), frm, to,
          *(C(f"{base}_{n}", *group_vars) for n in ("matches", "shown", "show", "unshow")))]))
    # arrivals and deletions of P
    leave, clock, upto = V(g.fresh("Leave")), V(g.fresh("Clock")), V(g.fresh("UpTo"))
    refresh = [C("is", leave, C("+", e1, Number(duration))), C("rtl_clock", clock),
               C("is", upto, C("min", leave, clock)), C(f"{base}_refresh", *group_vars, e1, upto)]
    stored = C(matched.name, *group_vars, x, s1, e1, e1)
    handler = f"{step.name}_left"
    g.arrival(step.left, handler, s1, e1)
    g.clauses.append(clause(C(handler, *inner_vars, s1, e1), [
        C("assertz", stored)] + refresh + [
        C("rtl_timer_add", leave, Atom("at"), C(f"{base}_refresh", *group_vars, leave, leave))]))
    g.clauses.append(clause(C(handler + "_retract", *inner_vars, s1, e1), [
        g.if_stored(stores, stored, conj(refresh))]))


def numbered_sliding_clauses(g: RuleGenerator, step: Step) -> None:
    """sliding_clauses for a sliding aggregate whose changes a policy step takes: a match
    is stored with its arrival number, a change with its position, and a timer that
    reaches a leave time records its arrival number; a deletion gives each change the
    position the run without the deleted match gives it (rtl_sliding_refresh_numbered/10)."""
    function, value, duration, s1, e1, inner_vars, group_vars, x, stores = sliding_parts(g, step)
    arrival, t, at = V(g.fresh("Arrival")), V(g.fresh("T")), V(g.fresh("At"))
    # the arrival number third from the end, where rtl_policy_take_arrival/2 reads it
    matched = g.store(stores, "slid", group_vars + [V(g.fresh("X")), s1, arrival, e1, e1])
    shown = g.store(stores, "changes", group_vars + [value, at, t, t])
    reached = g.store(stores, "reached", group_vars + [at, t, t])
    base = step.name
    x_, e_, v_, t_, p_ = (V(g.fresh(n)) for n in ("Xs", "Es", "Vs", "Ts", "Ps"))
    stored_match = C(matched.name, *group_vars, x_, V("_"), p_, e_, V("_"))
    stored_shown = C(shown.name, *group_vars, v_, p_, t_, V("_"))
    stored_reached = C(reached.name, *group_vars, p_, t_, V("_"))
    for name_, params, stored in (("matches", [x_, e_, p_], stored_match), ("shown", [v_, t_, p_], stored_shown),
                                  ("reached_at", [t_, p_], stored_reached)):
        g.clauses.append(clause(C(f"{base}_{name_}", *group_vars, *params),
                                   [C(";", stored, g.kept_lookup(stored))]))
    g.clauses.append(clause(C(f"{base}_show", *group_vars, value, t, at), [
        C("assertz", shown), C("rtl_policy_at", at, g.output(step, t, t))]))
    g.clauses.append(clause(C(f"{base}_unshow", *group_vars, value, t), [
        g.if_stored(stores, C(shown.name, *group_vars, value, V("_"), t, t),
                       g.output(step, t, t, retract=True))]))
    frm, to, op = V(g.fresh("From")), V(g.fresh("To")), V(g.fresh("Op"))
    g.clauses.append(clause(C(f"{base}_refresh", *group_vars, frm, to, op), [
        C("rtl_sliding_refresh_numbered", function, Number(duration), frm, to, op,
          *(C(f"{base}_{n}", *group_vars) for n in ("matches", "shown", "reached_at", "show", "unshow")))]))
    # a timer reaching a leave time: the first records its arrival number
    g.clauses.append(clause(C(f"{base}_reach", *group_vars, t), [
        C("rtl_policy_arrival", at),
        C(";", C("->", C(";", C(reached.name, *group_vars, V("_"), t, V("_")),
                         g.kept_lookup(C(reached.name, *group_vars, V("_"), t, V("_")))),
                 Atom("true")),
          C("assertz", reached)),
        C(f"{base}_refresh", *group_vars, t, t, C("at", at))]))
    # arrivals and deletions of P; a leave time the clock has reached already was refreshed
    # by the arrival (a timer then would record a later arrival as the time's)
    leave, clock, upto = V(g.fresh("Leave")), V(g.fresh("Clock")), V(g.fresh("UpTo"))
    upto_goals = [C("is", leave, C("+", e1, Number(duration))), C("rtl_clock", clock),
                  C("is", upto, C("min", leave, clock))]
    handler = f"{step.name}_left"
    g.arrival(step.left, handler, s1, e1)
    g.clauses.append(clause(C(handler, *inner_vars, s1, e1), [
        C("rtl_policy_arrival", arrival), C("assertz", C(matched.name, *group_vars, x, s1, arrival, e1, e1))]
        + upto_goals + [
        C(f"{base}_refresh", *group_vars, e1, upto, C("at", arrival)),
        C(";", C("->", C(">", leave, clock),
                 C("rtl_timer_add", leave, Atom("at"), C(f"{base}_reach", *group_vars, leave))),
          Atom("true"))]))
    stored = C(matched.name, *group_vars, x, s1, V("_"), e1, e1)
    g.clauses.append(clause(C(handler + "_retract", *inner_vars, s1, e1), [
        C(";", C("->", C("rtl_policy_take_arrival", list_term([stored] + g.kept_of(stored)), Atom("none")),
                 conj(upto_goals + [C(f"{base}_refresh", *group_vars, e1, upto, Atom("deleted"))])),
          Atom("true"))]))
