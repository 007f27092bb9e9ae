"""Timer heads: `alarm(Event, D)` (ETALIS `exceptionAlarm(Event, D)`) raises Event when the
clock reaches the end of the match + D."""
from __future__ import annotations

from ...frontend.terms import Atom, Compound, Number, Term, Var
from ..unit import Step
from .clauses import C, V, clause, conj
from .generator import RuleGenerator


def alarm(g: RuleGenerator, step: Step, head: Compound, s: Var, e: Var, retract: bool) -> Term:
    """`alarm(Event, D)` (ETALIS `exceptionAlarm(Event, D)`): raise Event over [the match's
    start, its end + D] when the clock reaches the end + D (a timer: the clock does not
    move). A deleted match cancels its timer, or takes back the Event it raised (recorded
    in `_alarms`, kept for the retraction horizon when the rule has a window, else as long
    as the program runs, like the records of an unwindowed aggregate)."""
    event, delay = head.args
    due = V(g.time_names.setdefault("Due", g.fresh("Due")))
    fire = C(f"{step.name}_alarm", event, s, due)
    fired = g.record(step, "alarms", [event, s, due], rotated=step.window is not None)
    if not retract:
        raised, since, when = (V(g.fresh(n)) for n in ("Raised", "Since", "When"))
        g.clauses.append(clause(C(fire.name, raised, since, when), [
            g.record_add(C(fired.name, raised, since, when)), C("rtl_derived", raised, since, when)]))
    at = C("is", due, C("+", e, delay))
    if not retract:
        return conj([at, C("rtl_timer_add", due, Atom("at"), fire)])
    return conj([at, C(";", C("->", C("rtl_timer_cancel", fire), Atom("true")),
                       C(";", C("->", g.record_take(fired), C("rtl_underived", event, s, due)),
                         Atom("true")))])
def alarm_head(head: Term) -> bool:
    """`alarm(Event, D)` with D a number or an arithmetic expression (`30`, `T * 2`), or
    ETALIS's `exceptionAlarm(Event, D)`: a timer head. `alarm(Sensor, Level)`, with a plain
    variable or atom as second argument, stays an ordinary event named alarm/2."""
    if not (isinstance(head, Compound) and head.arity == 2):
        return False
    if head.name == "exceptionAlarm":
        return True
    delay = head.args[1]
    return head.name == "alarm" and (isinstance(delay, Number) or (
        isinstance(delay, Compound) and delay.arity in (1, 2) and delay.name in _ARITHMETIC))


_ARITHMETIC = {"+", "-", "*", "/", "//", "min", "max", "abs"}


