"""The stores of a step's partial matches and records: live, kept for deletions and late
events (`_kept_a`, `_kept_b`, prolog_runtime/rtl_horizon.pl) or rotated in two generations
(`_a`, `_b`), with the goals that add to, search and take from them. Every operator family
keeps its instances through these."""
from __future__ import annotations

from typing import List, Optional

from ...frontend.terms import Atom, Compound, Number, Term, Var
from ..unit import Step
from .clauses import C, conj, list_term, plain_number
from .relations import window_goal


class Stores:
    """The store goals of a rule's generator (mixed into RuleGenerator, whose `stores`,
    `records`, `kept` and `unbound` they fill and read)."""

    def store(self, step: Step, suffix: str, args: List[Term], newest_first: bool = False) -> Term:
        """A store of partial matches (its last two arguments are their interval); a windowed
        step's store has two kept generations for deletions and late events."""
        name_ = f"{step.name}_{suffix}"
        self.roles[name_] = (step.name, suffix)
        self.stores.append((name_, len(args), step.window))
        if step.window is not None:
            self.kept.append((name_, len(args), name_ + "_kept_a", name_ + "_kept_b",
                              "newest_first" if newest_first else "oldest_first"))
        return C(name_, *args)

    def record(self, step: Step, suffix: str, args: List[Term], rotated: bool) -> Term:
        """A store of records kept only for deletions. Rotated records live in two
        generations (`_a`, `_b`) that the runtime empties in turn after the retraction
        horizon; the others (of unwindowed aggregates) are kept as long as the program runs."""
        name_ = f"{step.name}_{suffix}"
        self.roles[name_] = (step.name, suffix)
        if rotated:
            self.records.append((name_, len(args), name_ + "_a", name_ + "_b"))
        else:
            self.stores.append((name_, len(args), None))
        return C(name_, *args)

    def is_rotated(self, record: Term) -> bool:
        return any(name_ == record.name for name_, _, _, _ in self.records)

    @staticmethod
    def generations(record: Term) -> List[Term]:
        return [Compound(record.name + suffix, record.args) for suffix in ("_a", "_b")]

    def record_add(self, record: Term) -> Term:
        """Store a record, in the generation that receives records now."""
        if not self.is_rotated(record):
            return C("assertz", record)
        a, b = self.generations(record)
        return C(";", C("->", C("rtl_kept_generation", Atom("a")), C("assertz", a)), C("assertz", b))

    def record_lookup(self, record: Term) -> Term:
        if not self.is_rotated(record):
            return record
        a, b = self.generations(record)
        return C(";", a, b)

    def record_take(self, record: Term) -> Term:
        """Remove one record (fails if there is none)."""
        if not self.is_rotated(record):
            return C("retract", record)
        a, b = self.generations(record)
        return C(";", C("->", C("retract", a), Atom("true")), C("retract", b))

    @staticmethod
    def kept_of(stored: Term) -> List[Term]:
        """The two kept generations of a store, with the same arguments."""
        return [Compound(stored.name + suffix, stored.args) for suffix in ("_kept_a", "_kept_b")]

    def kept_lookup(self, stored: Term) -> Term:
        a, b = self.kept_of(stored)
        return C(";", a, b)

    def lookup(self, step: Step, stored: Term, end: Term) -> Term:
        """The stored partial matches: the live ones, and the kept ones for an instance that
        ended late (at `end`)."""
        if step.window is None:
            return stored
        return C(";", stored, C(",", C("rtl_late", end), self.kept_lookup(stored)))

    def take(self, step: Step, stored: Term) -> Term:
        """Remove one stored instance, live or kept."""
        if step.window is None:
            return C("retract", stored)
        a, b = self.kept_of(stored)
        return C(";", C("->", C("retract", stored), Atom("true")),
                 C(";", C("->", C("retract", a), Atom("true")), C("retract", b)))

    def drop_all(self, step: Step, stored: Term) -> Term:
        if step.window is None:
            return C("retractall", stored)
        return conj([C("retractall", t) for t in [stored] + self.kept_of(stored)])

    def window_check(self, step: Step, s: Var, e: Var) -> Optional[Term]:
        if step.window is None:
            return None
        return window_goal(s, e, Number(plain_number(step.window)))

    def take_arrival(self, step: Step, stored: Term, own: List[Term], then: Term) -> Term:
        """if_own_stored for a store whose instances carry arrival numbers: a deletion of an
        input event takes one of its arrivals (rtl_policy_take_arrival/2), a result taken back
        the instance it was made from."""
        stores = [stored] + (self.kept_of(stored) if step.window is not None else [])
        own_term = C("own", *own) if self.unbound else Atom("none")
        return C(";", C("->", C("rtl_policy_take_arrival", list_term(stores), own_term), then), Atom("true"))

    def if_own_stored(self, step: Step, stored: Term, own: List[Term], then: Term) -> Term:
        """if_stored for the instance of the events whose variables are `own`: in a rule with
        `or`, partial matches from one branch leave the other branch's variables unbound, so the
        stored instance taken is the one with the same unbound variables (rtl_take_instance/2),
        not any that unifies with it."""
        if not self.unbound:
            return self.if_stored(step, stored, then)
        return C(";", C("->", C("rtl_take_instance", stored, C("own", *own)), then), Atom("true"))

    def if_stored(self, step: Step, stored: Term, then: Term) -> Term:
        """Delete one stored instance and, only if there was one, take back what it made: a
        deletion of an event that was never added (or was already forgotten) changes nothing."""
        return C(";", C("->", self.take(step, stored), then), Atom("true"))
