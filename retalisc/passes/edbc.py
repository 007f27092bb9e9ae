"""edbc: generate the event-driven backward-chaining rules of every step (thesis 6.3.1,
Algorithms 1 and 2) as Prolog clause terms.

For a step `e <- L op R` the add rules are, per side (shown for the left side):

    e_left(LVars, LStart, LEnd) :-                  % an instance of L has occurred
        forall(( e_rights(Key, ROther, RStart, REnd),  % every R seen so far with the same key
                 <temporal relation of op>, <window> ),
               e(Vars, Start, End)),                 % ... completes e
        assertz(e_lefts(Key, LOther, LStart, LEnd)). % remember L for R's still to come

and the delete rules (`e_left_retract`, ...) remove the stored instance and retract every
result it took part in (`e_retract`). Stores are symmetric, so a match is found whichever
of its events arrives last: the result does not depend on arrival order (thesis 3.3.2).
The join variables come first in a stored partial match, so SWI-Prolog's just-in-time index
finds the partners by key instead of scanning every pending match.

Negation (`cnot`: no N between L and R; `fnot`: no N before L) derives eagerly and takes a
result back when a blocking event arrives late; deleting the blocker derives it again.

Under the `recent` and `chronological` consumption policies (ETALIS), an arriving event
joins with the newest (or oldest) waiting partner only, and both are consumed; the match is
recorded (`e_matched`), and every instance carries its position (its arrival number), so that
deleting an event rewinds the step and replays its later arrivals
(prolog_runtime/rtl_policy.pl): the output is that of a run without the deleted event.

Deletions and late events (prolog_runtime/rtl_horizon.pl): the runtime moves the partial
matches a windowed step no longer needs for events within the delay bound to the store's kept
generations (`_kept_a`, `_kept_b`), and keeps them there for the retraction horizon. Only an
instance that is late (`rtl_late(End)`) searches them: an instance within the bound cannot
match them. An aggregate numbers its instances in processing order and records its P's, so
that deleting an A or a P replays the values it changed.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Dict, List, Optional, Set, Tuple

from ..frontend.terms import Atom, Compound, Number, Term, Var, distinct_variables, make_list, substitute, variables
from .binarize import END_MARK, START_MARK
from ..frontend.errors import RetalisSemanticError
from .unit import BinaryRule, GeneratedRule, Operand, Step, Unit

name = "edbc"

# Temporal relation and result interval of each binary operator, on the intervals
# [S1, E1] (left) and [S2, E2] (right), as terms over these variable names (renamed per rule).
# docs/language.md has the same table.
_S1, _E1, _S2, _E2 = Var("S1"), Var("E1"), Var("S2"), Var("E2")


def _lt(a: Term, b: Term) -> Term:
    return Compound("<", (a, b))


def _eq(a: Term, b: Term) -> Term:
    return Compound("=:=", (a, b))


_MIN, _MAX = Compound("min", (_S1, _S2)), Compound("max", (_E1, _E2))

RELATIONS: Dict[str, Tuple[List[Term], Term, Term]] = {
    "seq": ([_lt(_E1, _S2)], _S1, _E2),
    "and": ([], _MIN, _MAX),
    "par": ([_lt(_S1, _E2), _lt(_S2, _E1)], _MIN, _MAX),
    "equals": ([_eq(_S1, _S2), _eq(_E1, _E2)], _S1, _E1),
    "meets": ([_eq(_E1, _S2)], _S1, _E2),
    "during": ([_lt(_S2, _S1), _lt(_E1, _E2)], _S2, _E2),
    "starts": ([_eq(_S1, _S2), _lt(_E1, _E2)], _S1, _E2),
    "finishes": ([_eq(_E1, _E2), _lt(_S2, _S1)], _S2, _E1),
    "cnot": ([_lt(_E1, _S2)], _S1, _E2),
}


#: The selections a rule may ask for with the property `consumption_policy`: the program's
#: policies, and `first` (each left instance pairs with its first matching right instance).
RULE_POLICIES = ("unrestricted", "recent", "chronological", "first")


def run(unit: Unit) -> Unit:
    policies = [rule_policy(unit, rule) for rule in unit.rules]
    consumed = policy_inputs(unit.rules, policies)
    unit.generated = [_RuleGenerator(rule, policy, provenance=policy not in ("recent", "chronological")
                                     and signature(rule.rule.head) in consumed).generate()
                      for rule, policy in zip(unit.rules, policies)]
    return unit


def signature(term: Term) -> Optional[Tuple[str, int]]:
    if isinstance(term, Compound):
        return term.name, term.arity
    if isinstance(term, Atom):
        return term.name, 0
    return None


def policy_inputs(rules: List[BinaryRule], policies: List[str]) -> Set[Tuple[str, int]]:
    """The events that a step under `recent` or `chronological` takes as input: a rule
    without such a policy deriving one of them numbers the arrivals of its input events and
    records when it made each result (`_made`), so that the policy step deletes the very
    arrival a deletion takes back, and receives a result made late where it would have been
    made (rtl_policy.pl)."""
    consumed: Set[Tuple[str, int]] = set()
    for rule, policy in zip(rules, policies):
        if policy not in ("recent", "chronological"):
            continue
        for step in rule.steps:
            for operand in (step.left, step.right, step.negated):
                if operand is not None and operand.is_event and signature(operand.term) is not None:
                    consumed.add(signature(operand.term))
    return consumed


def rule_policy(unit: Unit, rule: BinaryRule) -> str:
    """The rule's own consumption policy (label property or `event_rule_property/3` fact
    `consumption_policy`, or ETALIS's name `event_consumption_policy`), else the program's."""
    properties = dict(rule.rule.properties or {})
    if rule.rule.label is not None:
        properties.update(unit.settings.rule_properties.get(rule.rule.label, {}))
    value = properties.get("consumption_policy", properties.get("event_consumption_policy"))
    if value is None:
        return unit.settings.consumption_policy
    if not (isinstance(value, Atom) and value.name in RULE_POLICIES):
        raise RetalisSemanticError(f"the consumption_policy of a rule must be one of {', '.join(RULE_POLICIES)}",
                                   rule.rule.span)
    return value.name


def list_term(items: List[Term]) -> Term:
    return make_list(items)


def V(name_: str) -> Var:
    return Var(name_)


def C(name_: str, *args: Term) -> Compound:
    return Compound(name_, tuple(args))


def conj(goals: List[Optional[Term]]) -> Term:
    goals = [g for g in goals if g is not None]
    if not goals:
        return Atom("true")
    result = goals[-1]
    for g in reversed(goals[:-1]):
        result = C(",", g, result)
    return result


def clause(head: Term, body: List[Optional[Term]]) -> Term:
    goals = [g for g in body if g is not None]
    return C(":-", head, conj(goals)) if goals else head



def operand_vars(operand: Operand) -> List[Var]:
    if operand.step is not None:
        return list(operand.step.output.args)
    times = [x for x in (operand.start, operand.end) if isinstance(x, Var)]
    return distinct_variables(v for t in [operand.term, *times, *operand.filters] for v in variables(t))


def _split(own: List[Var], other: List[Var]) -> Tuple[List[Var], List[Var]]:
    """(key, rest): the variables of `own` shared with `other` (the join key), then the others."""
    other_names = {v.name for v in other}
    key = [v for v in own if v.name in other_names]
    return key, [v for v in own if v.name not in other_names]


class _RuleGenerator:
    def __init__(self, rule: BinaryRule, policy: str, provenance: bool = False):
        self.rule = rule
        # the head is an input of a policy step: number the input arrivals, record when each
        # result was made
        self.provenance = provenance
        # `first` selects in the joins; every other step is unrestricted
        self.first = policy == "first"
        self.policy = "unrestricted" if self.first else policy
        used: Set[str] = set()
        source = rule.rule
        for t in [source.head] + ([source.action] if source.action is not None else []):
            used.update(v.name for v in variables(t))
        for step in rule.steps:
            for operand in (step.left, step.right, step.negated):
                if operand is not None:
                    used.update(v.name for v in operand_vars(operand))
            used.update(v.name for c in step.conditions for v in variables(c))
        self.time_names: Dict[str, str] = {}
        readable = {"S": "Start", "E": "End", "S1": "LStart", "E1": "LEnd", "S2": "RStart", "E2": "REnd",
                    "SN": "NStart", "EN": "NEnd"}
        self.used = used
        for base, name_ in readable.items():
            self.time_names[base] = self.fresh(name_)
        self.clauses: List[Term] = []
        self.triggers: List[Term] = []
        self.stores: List[tuple] = []
        self.records: List[tuple] = []
        self.kept: List[tuple] = []
        self.consumers: Dict[str, Tuple[str, bool]] = {}   # step -> the handler its results go to, with arrivals?
        # policy steps whose join key may be unbound in a partial match (a rule with `or`):
        # step name -> the variables recording each side's key as it was before the join
        self.loose: Dict[str, Tuple[Var, Var]] = {}
        self.branches: Dict[str, Var] = {}      # `or` step name -> its branch variable

    def t(self, base: str) -> Var:
        return V(self.time_names[base])

    def expr(self, goals: List[Term]) -> List[Term]:
        """Goals over the time variables (`RELATIONS`), renamed to this rule's names."""
        return [self.renamed(g) for g in goals]

    def renamed(self, term: Term) -> Term:
        return substitute(term, {k: V(v) for k, v in self.time_names.items()})

    def interval(self, expression: Term, target: Var) -> Tuple[Var, List[Term]]:
        """The variable holding an interval end: an operand's own, or `target is Expr`."""
        if isinstance(expression, Var):
            return self.renamed(expression), []
        return target, [C("is", target, self.renamed(expression))]

    def generate(self) -> GeneratedRule:
        # the variables a partial match may leave unbound: those of one branch of an `or` only
        self.unbound: Set[str] = set()
        for step in self.rule.steps:
            if step.op == "or":
                left_names = {v.name for v in operand_vars(step.left)}
                right_names = {v.name for v in operand_vars(step.right)}
                self.unbound |= left_names ^ right_names
        if self.policy in ("recent", "chronological"):
            # Under a consumption policy a partial match carries the branch of each `or` it
            # came through: `a(X) or b(X)` makes different partial matches of a(1) and b(1)
            # (no twins of each other under `recent`, and a deletion takes the right one).
            for step in self.rule.steps:
                if step.op == "or" and not step.derives_head:
                    self.branches[step.name] = V(self.fresh("Branch"))
                    step.output = Compound(step.output.name, step.output.args + (self.branches[step.name],))
        for step in self.rule.steps:
            for side, operand in (("left", step.left), ("right", step.right), ("negated", step.negated)):
                if operand is not None and operand.step is not None:
                    self.consumers[operand.step.name] = (f"{step.name}_{side}", self.takes_arrivals(step, side))
        for step in self.rule.steps:
            if step.op == "cnot":
                self.negation_clauses(step)
            elif step.op == "fnot":
                self.fnot_clauses(step)
            elif step.op == "aggregate":
                self.aggregate_clauses(step)
            elif step.op == "absence":
                self.absence_clauses(step)
            elif step.op == "sliding" and (self.provenance or self.policy in ("recent", "chronological")):
                # its changes reach a policy step (of this rule or of a rule it feeds)
                self.numbered_sliding_clauses(step)
            elif step.op == "sliding":
                self.sliding_clauses(step)
            elif step.right is None or step.op == "or":
                self.forward_clauses(step)
            else:
                self.join_clauses(step)
            self.output_clauses(step)
        source = self.rule.rule
        comment = f"{source.span}: {source.source.strip()}"
        return GeneratedRule(self.rule.rule_id, comment, self.clauses, self.triggers, self.stores,
                             self.records, self.kept)

    # ---- arrivals ---------------------------------------------------------------------

    def arrival(self, operand: Operand, handler: str, s: Var, e: Var, arrivals: Optional[Var] = None) -> None:
        """For an event atom: `ele_trigger/3` and `ele_untrigger/3` clauses that run
        `handler(Vars, S, E)` / `handler_retract(...)` when the event occurs or is deleted.
        With `arrivals` (a rule whose results a policy step takes), the handler also receives
        the event's arrival number (rtl_policy_arrival/1); a deletion leaves it unbound."""
        if not operand.is_event:
            return
        if isinstance(operand.end, Var) and operand.start == operand.end:
            start, end = s, operand.end                      # E^T: T is the end time
        else:
            start = operand.start if isinstance(operand.start, Var) else s
            end = operand.end if isinstance(operand.end, Var) else e
        filters = [self.times(f, start, end) for f in operand.filters]
        params = operand_vars(operand)
        numbered = [C("rtl_policy_arrival", arrivals)] if arrivals is not None else []
        self.triggers.append(clause(C("ele_trigger", operand.term, start, end),
                                    filters + numbered + [C(handler, *params, *([arrivals] if numbered else []),
                                                            start, end)]))
        self.triggers.append(clause(C("ele_untrigger", operand.term, start, end),
                                    filters + [C(handler + "_retract", *params, *([V("_")] if numbered else []),
                                                 start, end)]))

    def times(self, goal: Term, start: Var, end: Var) -> Term:
        """Replace the `check` placeholders for the start and end time."""
        if goal == START_MARK:
            return start
        if goal == END_MARK:
            return end
        if isinstance(goal, Compound):
            return Compound(goal.name, tuple(self.times(a, start, end) for a in goal.args))
        return goal

    def store(self, step: Step, suffix: str, args: List[Term], newest_first: bool = False) -> Term:
        """A store of partial matches (its last two arguments are their interval); a windowed
        step's store has two kept generations for deletions and late events."""
        name_ = f"{step.name}_{suffix}"
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
        return C("=<", C("-", e, s), Number(_number(step.window)))

    def output(self, step: Step, s: Var, e: Var, retract: bool = False, arrivals: Optional[Term] = None) -> Term:
        # in a rule whose results a policy step takes, a result carries the arrival numbers of
        # the input events it was made from (`LArrivals-RArrivals`): identical results are
        # told apart, and one made late knows when its last input event arrived
        assert (arrivals is not None) == self.carries(step), step.name
        return C(step.name + ("_retract" if retract else ""), *step.output.args, s, e,
                 *([arrivals] if arrivals is not None else []))

    def carries(self, step: Step) -> bool:
        """The step's instances carry the arrival numbers of their input events (a rule whose
        results a policy step takes, rtl_policy.pl); a sliding aggregate's values take an
        arrival number when they are made (output_clauses)."""
        return self.provenance and step.op != "sliding"

    def takes_arrivals(self, step: Step, side: str) -> bool:
        """The handler of `side` receives the instance's arrival numbers (an absence's result
        takes its own when it is decided, an aggregate's value the numbers of its start event
        and of the event counted)."""
        return self.carries(step) and side != "negated" and step.op not in ("absence", "aggregate")

    def arrivals(self, step: Step, side: str) -> List[Var]:
        """The variable holding the arrival numbers of an instance of `side`, if it has one."""
        if not self.takes_arrivals(step, side):
            return []
        return [V(self.fresh({"left": "LArrivals", "right": "RArrivals"}[side]))]

    def take_arrival(self, step: Step, stored: Term, own: List[Term], then: Term) -> Term:
        """if_own_stored for a store whose instances carry arrival numbers: a deletion of an
        input event takes one of its arrivals (rtl_policy_take_arrival/2), a result taken back
        the instance it was made from."""
        stores = [stored] + (self.kept_of(stored) if step.window is not None else [])
        own_term = C("own", *own) if self.unbound else Atom("none")
        return C(";", C("->", C("rtl_policy_take_arrival", list_term(stores), own_term), then), Atom("true"))

    # ---- steps ------------------------------------------------------------------------

    def forward_clauses(self, step: Step) -> None:
        """`or` and single-operand steps: every operand instance is a result."""
        s1, e1 = self.t("S1"), self.t("E1")
        for side, operand in (("left", step.left), ("right", step.right)):
            if operand is None:
                continue
            handler = f"{step.name}_{side}"
            arrivals = self.arrivals(step, "left")
            self.arrival(operand, handler, s1, e1, *arrivals)
            params = operand_vars(operand)
            window = self.window_check(step, s1, e1)
            for suffix, retract in (("", False), ("_retract", True)):
                output = self.output(step, s1, e1, retract, *arrivals)
                if step.name in self.branches:
                    output = substitute(output, {self.branches[step.name].name: Atom(side)})
                self.clauses.append(clause(C(handler + suffix, *params, *arrivals, s1, e1), [window, output]))

    def join_clauses(self, step: Step) -> None:
        if self.first:
            self.first_join_clauses(step)
            return
        relation, start_expr, end_expr = RELATIONS[step.op]
        s1, e1, s2, e2 = self.t("S1"), self.t("E1"), self.t("S2"), self.t("E2")
        left_vars, right_vars = operand_vars(step.left), operand_vars(step.right)
        key, left_other = _split(left_vars, right_vars)
        _, right_other = _split(right_vars, left_vars)
        recent = self.policy == "recent"
        pl, pr = self.positions()
        al, ar = self.arrivals(step, "left"), self.arrivals(step, "right")
        lefts = self.store(step, "lefts", key + left_other + pl + al + [s1, e1], newest_first=recent)
        rights = self.store(step, "rights", key + right_other + pr + ar + [s2, e2], newest_first=recent)
        s, start_goals = self.interval(start_expr, self.t("S"))
        e, end_goals = self.interval(end_expr, self.t("E"))
        match = self.expr(relation) + start_goals + end_goals + [self.window_check(step, s, e)]
        matched = self.matched_record(step, lefts, rights, s, e)
        sides = (("left", step.left, left_vars, al, lefts, rights),
                 ("right", step.right, right_vars, ar, rights, lefts))
        for side, operand, own_vars, own_arrivals, own_store, partner_store in sides:
            handler = f"{step.name}_{side}"
            os_, oe = (s1, e1) if side == "left" else (s2, e2)
            self.arrival(operand, handler, os_, oe, *own_arrivals)
            # A left instance of `seq` ending no earlier than every start seen so far has no
            # right partner stored (rtl_started_after/1): in time order, the common case.
            skip = C("rtl_started_after", oe) if step.op == "seq" and side == "left" else None
            found = conj([skip, self.lookup(step, partner_store, oe)] + match)
            self.join_handlers(step, handler, own_vars, own_arrivals, os_, oe, own_store, partner_store, found,
                               matched, s, e, key, side, self.pair_arrivals(al, ar))
        self.policy_facts(step, key, lefts, rights, matched, s, e)

    def first_join_clauses(self, step: Step) -> None:
        """The `first` selection: each left instance L pairs with its first matching right
        instance only (the smallest by start, end, then the term: by time, whatever the
        arrival order), and a right instance may serve several L's. `_first` records the
        pairing of each L: a right instance that arrives (late) before an L's partner takes its
        place, and deleting the partner pairs the L with the next one; so the output is always
        that of the events present."""
        relation, start_expr, end_expr = RELATIONS[step.op]
        s1, e1, s2, e2 = self.t("S1"), self.t("E1"), self.t("S2"), self.t("E2")
        left_vars, right_vars = operand_vars(step.left), operand_vars(step.right)
        key, left_other = _split(left_vars, right_vars)
        _, right_other = _split(right_vars, left_vars)
        # each stored L is numbered (identical L's pair each on their own): by its arrival
        # numbers when it has them
        al, ar = self.arrivals(step, "left"), self.arrivals(step, "right")
        lid = al[0] if al else V(self.fresh("LId"))
        lefts = self.store(step, "lefts", key + left_other + [lid, s1, e1])
        rights = self.store(step, "rights", key + right_other + ar + [s2, e2])
        paired = self.record(step, "first", key + left_other + [lid, s1, e1] + right_other + ar + [s2, e2],
                             rotated=step.window is not None)

        # In a rule with `or`, a partial match may leave a key variable unbound: an L that pairs
        # with every key. Its partners are then ranked with their key too, its pairing record
        # is found by its number (whatever key the pairing bound), and it pairs again in the
        # form it was stored in.
        loose = any(v.name in self.unbound for v in key)

        def with_right(r_key: List[Term], r_other: List[Term], rs: Term, re_: Term):
            """The goals and interval of a match of the L with right instance (r_other, rs, re_)."""
            names = {"S1": s1, "E1": e1, "S2": rs, "E2": re_}
            goals = [substitute(g, names) for g in relation]
            start = substitute(start_expr, names)
            end = substitute(end_expr, names)
            s_, e_ = V(self.fresh("S")), V(self.fresh("E"))
            bounds = [C("is", s_, start), C("is", e_, end)]
            window = self.window_check(step, s_, e_)
            rank = C("-", C("-", rs, re_), C("r", *(r_key + r_other)))
            return goals, bounds + ([window] if window is not None else []), s_, e_, rank

        def variant(tag: str):
            """The right instance's terms with its variables renamed apart (`tag` "" keeps them)."""
            renamed = right_other + ar + [s2, e2] + (key if tag == "P" and loose else [])
            if tag:
                names = {v.name: V(self.fresh(v.name + tag)) for v in renamed}
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
            best = V(self.fresh("Ranks"))
            found = conj([self.lookup(step, q["rights"], late_end)] + q["goals"] + q["bounds"])
            return C(";", C("->", conj([C("findall", q["rank"], found, best), C("min_member", q["rank"], best)]),
                             conj(q["bounds"] + [self.record_add(q["paired"]), q["add"]])), Atom("true"))

        own = variant("")
        handler = f"{step.name}_left"
        self.arrival(step.left, handler, s1, e1, *al)
        take = self.take_arrival if al else self.if_own_stored
        self.clauses.append(clause(C(handler, *left_vars, *al, s1, e1), [
            *([] if al else [C("rtl_next_seq", lid)]), C("assertz", lefts), pair_best(e1)]))
        self.clauses.append(clause(C(handler + "_retract", *left_vars, *al, s1, e1), [
            take(step, lefts, left_vars + [s1, e1],
                 C(";", C("->", self.record_take(paired), conj(own["bounds"] + [own["retract"]])), Atom("true")))]))
        # a right instance: the L's it matches take it if it comes before their partner
        p_ = variant("P")
        take_over = conj([C("@<", own["rank"], p_["rank"]), self.record_take(p_["paired"])] + p_["bounds"]
                         + [p_["retract"], self.record_add(paired), own["add"]])
        handler = f"{step.name}_right"
        self.arrival(step.right, handler, s2, e2, *ar)
        self.clauses.append(clause(C(handler, *right_vars, *ar, s2, e2), [
            C("assertz", rights),
            C("forall", conj([self.lookup(step, lefts, e2)] + own["goals"] + own["bounds"]),
              C(";", C("->", self.record_lookup(p_["paired"]), C(";", C("->", take_over, Atom("true")), Atom("true"))),
                conj([self.record_add(paired), own["add"]])))]))
        # deleting a right instance: the L's paired with it take their next one
        again = pair_best(e1)
        if loose:
            # (the L as it is stored, numbered LId: the pairing bound its key)
            again = C(f"{step.name}_left_again", lid)
            stored_left = lefts if step.window is None else C(";", lefts, self.kept_lookup(lefts))
            self.clauses.append(clause(again, [stored_left, pair_best(e1)]))
        self.clauses.append(clause(C(handler + "_retract", *right_vars, *ar, s2, e2), [
            take(step, rights, right_vars + [s2, e2], C("forall", self.record_lookup(paired), conj(
                [self.record_take(paired)] + own["bounds"] + [own["retract"], self.restoring(again)])))]))

    def positions(self) -> Tuple[List[Var], List[Var]]:
        """Under a consumption policy, the position arguments of the left and right stores
        (prolog_runtime/rtl_policy.pl): the arrival number of each instance."""
        if self.policy == "unrestricted":
            return [], []
        return [V(self.fresh("LPos"))], [V(self.fresh("RPos"))]

    @staticmethod
    def pair_arrivals(al: List[Var], ar: List[Var]) -> Optional[Term]:
        """The arrival numbers of a pair's result: `LArrivals-RArrivals`."""
        return C("-", al[0], ar[0]) if al else None

    def join_handlers(self, step: Step, handler: str, own_vars: List[Var], own_arrivals: List[Var], os_: Var,
                      oe: Var, own_store: Term, partner_store: Term, found: Term, matched: Optional[Term], s: Term,
                      e: Term, key: List[Var], side: str, arrivals: Optional[Term]) -> None:
        """The add and delete rules of one side of a join (also of `cnot`): unrestricted, every
        partner found makes a result, and deleting takes back what the instance made with the
        partners still stored; under a policy, see consuming_join/consumed_retract."""
        head = C(handler, *own_vars, *own_arrivals, os_, oe)
        retract_head = C(handler + "_retract", *own_vars, *own_arrivals, os_, oe)
        if matched is None:
            self.clauses.append(clause(head, [C("forall", found, self.output(step, s, e, arrivals=arrivals)),
                                              C("assertz", own_store)]))
            take = self.take_arrival if own_arrivals else self.if_own_stored
            self.clauses.append(clause(retract_head, [
                take(step, own_store, own_vars + [os_, oe],
                     C("forall", found, self.output(step, s, e, retract=True, arrivals=arrivals)))]))
            return
        # A partner that fails the step's conditions is not a match: it is neither chosen nor
        # consumed, as when the condition is pushed onto an event (the output checks them again).
        selected = conj([found] + [self.times(c, s, e) for c in step.conditions])
        position = own_store.args[-3]
        at = C(handler + "_at", position, *own_vars, os_, oe)
        body = self.consuming_join(step, selected, partner_store, own_store, matched, self.output(step, s, e))
        runtime_key = None if step.name in self.loose else key
        self.clauses.append(clause(head, [self.positioned(step, runtime_key, position, at, body)]))
        self.clauses.append(clause(at, [body]))
        self.clauses.append(clause(retract_head, [
            C("rtl_policy_delete", Atom(step.name), Atom(side),
              V("_") if runtime_key is None else list_term(key), own_store)]))

    def positioned(self, step: Step, key: Optional[List[Var]], position: Var, at: Term, body: Term) -> Term:
        """Process an instance at its position (`body`, also the clause of `at`): now, or,
        when it comes from a replay (its position is in the past), rewinding the step first
        (rtl_policy_insert/4)."""
        mode = V(self.fresh("Mode"))
        insert = C("rtl_policy_insert", Atom(step.name), V("_") if key is None else list_term(key), position, at)
        return conj([C("rtl_position", position, mode),
                     C(";", C("->", C("==", mode, Atom("now")), body), insert)])

    def policy_facts(self, step: Step, key: List[Var], lefts: Term, rights: Term, matched: Optional[Term],
                     s: Term, e: Term, negs: Optional[Term] = None) -> None:
        """`<step>_policy/1`: what the runtime needs to rewind the step (rtl_policy.pl)."""
        if matched is None:
            return
        info = f"{step.name}_policy"
        self.clauses.append(C(info, C("order", Atom(self.policy))))
        for side, stored in (("left", lefts), ("right", rights)):
            own = operand_vars(step.left if side == "left" else step.right)
            kept = self.kept_of(stored) if step.window is not None else []
            at = C(f"{step.name}_{side}_at", stored.args[-3], *own, stored.args[-2], stored.args[-1])
            self.clauses.append(C(info, C("entry", Atom(side), list_term(key), stored.args[-3], stored,
                                          list_term(kept), at)))
        left_form, right_form, record = lefts, rights, matched
        if step.name in self.loose:
            names = {}
            for var, form in zip(self.loose[step.name], (lefts, rights)):
                kept_key = [V(self.fresh("K")) for _ in key]
                names[var.name] = list_term(kept_key)
                if form is lefts:
                    left_form = C(form.name, *kept_key, *form.args[len(key):])
                else:
                    right_form = C(form.name, *kept_key, *form.args[len(key):])
            record = substitute(matched, names)
        self.clauses.append(C(info, C("match", list_term(key), list_term(self.generations(record)),
                                      lefts.args[-3], rights.args[-3], self.output(step, s, e, retract=True),
                                      left_form, right_form)))
        if self.policy == "recent":
            for stored in (lefts, rights):
                dropped = self.dropped_record(step, stored)
                self.clauses.append(C(info, C("dropped", list_term(self.generations(dropped)), dropped.args[0],
                                              dropped.args[1])))
        if negs is not None:
            kept = self.kept_of(negs) if step.window is not None else []
            self.clauses.append(C(info, C("blocker", negs.args[-3], negs, list_term(kept))))

    def dropped_record(self, step: Step, stored: Term) -> Term:
        """Under `recent`, the record of a waiting twin replaced by a new arrival (its stored
        form, and the position of the arrival)."""
        by = V(self.fresh("ByPos"))
        name_ = f"{step.name}_dropped"
        if not any(r[0] == name_ for r in self.records):
            self.record(step, "dropped", [V("_"), V("_")], rotated=True)
        return C(name_, stored, by)

    def matched_record(self, step: Step, lefts: Term, rights: Term, s: Term, e: Term) -> Optional[Term]:
        """Under a consumption policy, the record of a match made: both instances and the
        interval of the result (kept for the retraction horizon, by the end of the result)."""
        if self.policy == "unrestricted":
            return None
        args = list(lefts.args) + self.partner_only_args(lefts, rights) + [s, e]
        if any(v.name in self.unbound for v in self.key_of(step)):
            # a partial match from one branch of an `or` may leave a key variable unbound: it
            # pairs with every key, and the join binds it; the record keeps each side's key as
            # it was stored, to restore it (rtl_policy.pl)
            self.loose[step.name] = (V(self.fresh("LKey")), V(self.fresh("RKey")))
            args += list(self.loose[step.name])
        return self.record(step, "matched", args, rotated=True)

    def key_of(self, step: Step) -> List[Var]:
        key, _ = _split(operand_vars(step.left), operand_vars(step.right))
        return key

    @staticmethod
    def partner_only_args(lefts: Term, rights: Term) -> List[Term]:
        """The arguments of `rights` that `lefts` does not have already (the join key)."""
        seen = {a.name for a in lefts.args if isinstance(a, Var)}
        return [a for a in rights.args if not (isinstance(a, Var) and a.name in seen)]

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

    def consuming_join(self, step: Step, found: Term, partner: Term, own: Term, matched: Term,
                       output: Term) -> Term:
        """recent/chronological: join with one waiting partner, the newest (recent: stores
        are filled with asserta, so it comes first) or the oldest, and consume both, recording
        the match; with no partner, wait. Under `recent` a waiting twin of the same event is
        replaced."""
        store = "asserta" if self.policy == "recent" else "assertz"
        wait = C(store, own)
        if self.policy == "recent":
            # a twin is the same events (a variant: a partial match from one branch of an `or`
            # leaves the other branch's variables unbound, and must not unify with another);
            # a replaced twin is recorded, for deletions (rtl_policy.pl)
            times = [V(self.fresh(n)) for n in ("TwinPos", "TwinStart", "TwinEnd")]
            twin = Compound(own.name, tuple(own.args[:-3]) + tuple(times))
            dropped = self.dropped_record(step, twin)
            dropped = Compound(dropped.name, (twin, own.args[-3]))
            stores = [twin] + (self.kept_of(twin) if step.window is not None else [])
            # (one at most: every instance that waits replaces its twins)
            drop_all = conj([C(";", C("->", C("retract", t), self.record_add(dropped)), Atom("true")) for t in stores])
            drop = C(";", C("->", C("ground", own), drop_all), C("rtl_policy_drop_twins", Atom(step.name), own))
            wait = C(",", drop, wait)
        if step.name in self.loose:
            key = self.key_of(step)
            own_key, partner_key = self.loose[step.name]
            if own.name.endswith("_rights"):
                partner_key, own_key = own_key, partner_key
            consume = conj([C("rtl_policy_take", Atom(step.name), partner, partner_key), self.record_add(matched),
                            output])
            return conj([C("copy_term", list_term(key), own_key), C(";", C("->", C("once", found), consume), wait)])
        consume = conj([self.take(step, partner), self.record_add(matched), output])
        return C(";", C("->", C("once", found), consume), wait)

    def negation_clauses(self, step: Step) -> None:
        """not(N).[L, R]: L seq R with no N strictly between L's end and R's start. Under a
        consumption policy, L and R pair up as in a join and a later N takes nothing back."""
        s1, e1, s2, e2, sn, en = (self.t(n) for n in ("S1", "E1", "S2", "E2", "SN", "EN"))
        left_vars, right_vars = operand_vars(step.left), operand_vars(step.right)
        negated_vars = operand_vars(step.negated)
        key, left_other = _split(left_vars, right_vars)
        _, right_other = _split(right_vars, left_vars)
        pair_vars = distinct_variables(left_vars + right_vars)
        negated_key, negated_other = _split(negated_vars, pair_vars)
        recent = self.policy == "recent"
        pl, pr = self.positions()
        pn = [V(self.fresh("NPos"))] if pl else []
        al, ar = self.arrivals(step, "left"), self.arrivals(step, "right")
        arrivals = self.pair_arrivals(al, ar)
        lefts = self.store(step, "lefts", key + left_other + pl + al + [s1, e1], newest_first=recent)
        rights = self.store(step, "rights", key + right_other + pr + ar + [s2, e2], newest_first=recent)
        negs = self.store(step, "negs", negated_key + negated_other + pn + [sn, en])
        between = [C("<", e1, sn), C("<", en, s2), Atom("!")]
        if pn:
            # under a policy a blocker blocks the pairs made after it arrived (rtl_policy.pl)
            between.insert(0, C("<", pn[0], C("max", pl[0], pr[0])))
        unblocked = self.unblocked(step, f"{step.name}_blocked", negated_key + [e1, s2] + pl + pr, negs, between, e2)
        window = self.window_check(step, s1, e2)
        pair = [C("<", e1, s2), window, unblocked]
        matched = self.matched_record(step, lefts, rights, s1, e2)
        self.forget_blockers(step, lefts, negs, s1, e1, sn, en)
        for side, operand, own_vars, own_arrivals, own_store, partner_store in (
                ("left", step.left, left_vars, al, lefts, rights),
                ("right", step.right, right_vars, ar, rights, lefts)):
            handler = f"{step.name}_{side}"
            os_, oe = (s1, e1) if side == "left" else (s2, e2)
            self.arrival(operand, handler, os_, oe, *own_arrivals)
            skip = C("rtl_started_after", oe) if side == "left" else None     # as for `seq` (join_clauses)
            found = conj([skip, self.lookup(step, partner_store, oe)] + pair)
            self.join_handlers(step, handler, own_vars, own_arrivals, os_, oe, own_store, partner_store, found,
                               matched, s1, e2, key, side, arrivals)
        self.policy_facts(step, key, lefts, rights, matched, s1, e2, negs if pn else None)
        # a blocker takes back the results it falls inside of; deleting it restores them
        handler = f"{step.name}_negated"
        self.arrival(step.negated, handler, sn, en)
        inside = conj([self.lookup(step, lefts, en), C("<", e1, sn), self.lookup(step, rights, en), C("<", en, s2),
                       window, unblocked])
        if self.policy != "unrestricted":
            # the pairs made after the blocker arrived are made again without it, or with it
            # when it comes from a replay (rtl_policy.pl)
            at = C(handler + "_at", pn[0], *negated_vars, sn, en)
            self.clauses.append(clause(C(handler, *negated_vars, sn, en), [
                self.positioned(step, None, pn[0], at, C("assertz", negs))]))
            self.clauses.append(clause(at, [C("assertz", negs)]))
            self.clauses.append(clause(C(handler + "_retract", *negated_vars, sn, en), [
                C("rtl_policy_delete", Atom(step.name), Atom("negated"), V("_"), negs)]))
            return
        self.clauses.append(clause(C(handler, *negated_vars, sn, en), [
            C("forall", inside, self.output(step, s1, e2, retract=True, arrivals=arrivals)), C("assertz", negs)]))
        self.clauses.append(clause(C(handler + "_retract", *negated_vars, sn, en), [
            self.if_stored(step, negs,
                           self.restoring(C("forall", inside, self.output(step, s1, e2, arrivals=arrivals))))]))

    def forget_blockers(self, step: Step, lefts: Term, negs: Term, s1: Var, e1: Var, sn: Var, en: Var) -> None:
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
        clock, before = V(self.fresh("Clock")), V(self.fresh("Before"))
        name, arity = signature(step.right.term)
        blocked_lefts = conj([lefts, C("<", e1, sn)])
        self.clauses.append(clause(C("ele_forget_blockers", clock), [
            C("rtl_blockers_due", Atom(step.name), C("/", Atom(name), Number(arity)), clock, before),
            C("forall", conj([negs, C("<", en, before)]),
              conj([C("forall", blocked_lefts, C("retract", lefts)), C("retract", negs)]))]))

    def unblocked(self, step: Step, name_: str, args: List[Term], negs: Term, check: List[Term],
                  late_end: Term) -> Term:
        """`\\+ Blocked`: no stored blocker passes `check`. The clause `name_(args)` searches the
        live blockers; for a windowed step, `name__late` also the kept ones, for a match that
        ends late (at `late_end`)."""
        blocked = C(name_, *args)
        self.clauses.append(clause(blocked, [negs] + check))
        if step.window is None:
            return C("\\+", blocked)
        blocked_late = C(name_ + "_late", *args)
        self.clauses.append(clause(blocked_late, [C(";", negs, self.kept_lookup(negs))] + check))
        return C("\\+", C(";", C("->", C("rtl_late", late_end), blocked_late), blocked))

    def fnot_clauses(self, step: Step) -> None:
        """L fnot N: L, unless an N ended before L started (within the window, if any)."""
        s1, e1, sn, en = (self.t(n) for n in ("S1", "E1", "SN", "EN"))
        left_vars, negated_vars = operand_vars(step.left), operand_vars(step.negated)
        negated_key, negated_other = _split(negated_vars, left_vars)
        left_key, left_other = _split(left_vars, negated_vars)
        al = self.arrivals(step, "left")
        arrivals = al[0] if al else None
        lefts = self.store(step, "lefts", left_key + left_other + al + [s1, e1])
        negs = self.store(step, "negs", negated_key + negated_other + [sn, en])
        before = [C("<", en, s1), self.window_check(step, sn, e1), Atom("!")]
        unblocked = self.unblocked(step, f"{step.name}_blocked", negated_key + [s1, e1], negs,
                                   [g for g in before if g is not None], e1)
        handler = f"{step.name}_left"
        self.arrival(step.left, handler, s1, e1, *al)
        derivable = conj([unblocked, self.window_check(step, s1, e1)])
        self.clauses.append(clause(C(handler, *left_vars, *al, s1, e1), [
            C(";", C("->", derivable, self.output(step, s1, e1, arrivals=arrivals)), Atom("true")),
            C("assertz", lefts)]))
        undo = C(";", C("->", derivable, self.output(step, s1, e1, retract=True, arrivals=arrivals)), Atom("true"))
        taken = (self.take_arrival(step, lefts, left_vars + [s1, e1], undo) if al
                 else self.if_stored(step, lefts, undo))
        self.clauses.append(clause(C(handler + "_retract", *left_vars, *al, s1, e1), [taken]))
        handler = f"{step.name}_negated"
        self.arrival(step.negated, handler, sn, en)
        after = conj([self.lookup(step, lefts, en), C("<", en, s1), self.window_check(step, sn, e1), unblocked])
        self.clauses.append(clause(C(handler, *negated_vars, sn, en), [
            C("forall", after, self.output(step, s1, e1, retract=True, arrivals=arrivals)), C("assertz", negs)]))
        self.clauses.append(clause(C(handler + "_retract", *negated_vars, sn, en), [
            self.if_stored(step, negs,
                           self.restoring(C("forall", after, self.output(step, s1, e1, arrivals=arrivals))))]))

    def absence_clauses(self, step: Step) -> None:
        """not(N).[L, D]: no N in the D seconds after L ends (N starts after L's end and ends by
        L's end + D). Each L waits on a timer until the clock has passed its end + D + max_delay
        (rtl_absence_wait/2): then no blocker within the delay bound can come any more, and the
        result [L's start, L's end + D] is derived unless a stored N blocks it. The decided L's
        are kept (window D) so that a late blocker takes the result back and deleting the
        blocker derives it again; deleting L takes back its result or cancels its timer."""
        duration = _number(step.duration)
        s1, e1, sn, en = (self.t(n) for n in ("S1", "E1", "SN", "EN"))
        close = V(self.fresh("Close"))
        left_vars, negated_vars = operand_vars(step.left), operand_vars(step.negated)
        negated_key, negated_other = _split(negated_vars, left_vars)
        left_key, left_other = _split(left_vars, negated_vars)
        # both stores count as windowed by 2D: a decided L is stored by [L's end, L's end + D],
        # a blocker by its own interval; an L within the delay bound needs neither once it is
        # older than D, and a result (decided D + max_delay after L) stays exact for deletions
        # for another D (the retraction horizon is max_delay plus the largest window)
        stores = replace(step, window=2 * float(step.duration))
        # (a result a policy step takes arrives when it is decided)
        decided_at = [V(self.fresh("DecidedAt"))] if self.carries(step) else []
        arrivals = decided_at[0] if decided_at else None
        decided = self.store(stores, "decided", left_key + left_other + decided_at + [s1, e1, close])
        negs = self.store(stores, "negs", negated_key + negated_other + [sn, en])
        inside = [C("<", e1, sn), C("=<", en, close), Atom("!")]
        unblocked = self.unblocked(stores, f"{step.name}_blocked", negated_key + [e1, close], negs, inside, e1)
        closing = C("is", close, C("+", e1, Number(duration)))
        decide = C(f"{step.name}_decide", *left_vars, s1, e1)
        window = self.window_check(step, s1, close)
        derivable = conj([window, unblocked])
        # L arrives: wait for the clock; L is deleted: cancel the wait, or take back the result
        handler = f"{step.name}_left"
        self.arrival(step.left, handler, s1, e1)
        self.clauses.append(clause(C(handler, *left_vars, s1, e1), [closing, C("rtl_absence_wait", close, decide)]))
        self.clauses.append(clause(C(handler + "_retract", *left_vars, s1, e1), [
            closing,
            C(";", C("->", C("rtl_timer_cancel", decide), Atom("true")),
              self.if_stored(stores, decided, C(";", C("->", derivable, self.output(step, s1, close, retract=True,
                                                                                    arrivals=arrivals)),
                                                    Atom("true"))))]))
        self.clauses.append(clause(decide, [
            closing] + [C("rtl_policy_arrival", a) for a in decided_at] + [C("assertz", decided),
            C(";", C("->", derivable, self.output(step, s1, close, arrivals=arrivals)), Atom("true"))]))
        # a blocker takes back the decided results it falls inside of; deleting it restores them
        handler = f"{step.name}_negated"
        self.arrival(step.negated, handler, sn, en)
        found = conj([self.lookup(stores, decided, en), C("<", e1, sn), C("=<", en, close), derivable])
        self.clauses.append(clause(C(handler, *negated_vars, sn, en), [
            C("forall", found, self.output(step, s1, close, retract=True, arrivals=arrivals)), C("assertz", negs)]))
        self.clauses.append(clause(C(handler + "_retract", *negated_vars, sn, en), [
            self.if_stored(stores, negs, self.restoring(C("forall", found, self.output(step, s1, close,
                                                                                      arrivals=arrivals))))]))

    def sliding_parts(self, step: Step):
        """What both forms of a sliding step are built from: the function, the value, the
        duration, the match's times, the operand's and the group's variables, the aggregated
        term (1 for count) and the step as its stores see it (windowed by the duration)."""
        function, group, value = step.sliding
        duration = _number(step.duration)
        s1, e1 = self.t("S1"), self.t("E1")
        inner_vars = operand_vars(step.left)
        group_vars = distinct_variables(variables(group))
        x = function.args[0] if isinstance(function, Compound) else Number(1)
        return function, value, duration, s1, e1, inner_vars, group_vars, x, replace(step, window=float(step.duration))

    def sliding_clauses(self, step: Step) -> None:
        """sliding(F, P, Group, D, V): the matches of P are stored by group (with the value F
        aggregates, and their end twice: the interval the sweep reads), and so are the changes
        output; an arrival or a deletion refreshes the changes of its group in [E, E + D] up to
        the clock, and a timer at E + D refreshes that moment when the clock reaches it
        (rtl_sliding.pl)."""
        function, value, duration, s1, e1, inner_vars, group_vars, x, stores = self.sliding_parts(step)
        matched = self.store(stores, "slid", group_vars + [V(self.fresh("X")), s1, e1, e1])
        t = V(self.fresh("T"))
        shown = self.store(stores, "changes", group_vars + [value, t, t])
        base = step.name
        x_, e_, v_, t_ = (V(self.fresh(n)) for n in ("Xs", "Es", "Vs", "Ts"))
        # the group's matches and changes, live and kept
        stored_match = C(matched.name, *group_vars, x_, V("_"), e_, V("_"))
        self.clauses.append(clause(C(f"{base}_matches", *group_vars, x_, e_),
                                   [C(";", stored_match, self.kept_lookup(stored_match))]))
        stored_shown = C(shown.name, *group_vars, v_, t_, V("_"))
        self.clauses.append(clause(C(f"{base}_shown", *group_vars, v_, t_),
                                   [C(";", stored_shown, self.kept_lookup(stored_shown))]))
        self.clauses.append(clause(C(f"{base}_show", *group_vars, value, t), [
            C("assertz", shown), self.output(step, t, t)]))
        self.clauses.append(clause(C(f"{base}_unshow", *group_vars, value, t), [
            self.if_stored(stores, shown, self.output(step, t, t, retract=True))]))
        frm, to = V(self.fresh("From")), V(self.fresh("To"))
        self.clauses.append(clause(C(f"{base}_refresh", *group_vars, frm, to), [
            C("rtl_sliding_refresh", function, Number(duration), frm, to,
              *(C(f"{base}_{n}", *group_vars) for n in ("matches", "shown", "show", "unshow")))]))
        # arrivals and deletions of P
        leave, clock, upto = V(self.fresh("Leave")), V(self.fresh("Clock")), V(self.fresh("UpTo"))
        refresh = [C("is", leave, C("+", e1, Number(duration))), C("rtl_clock", clock),
                   C("is", upto, C("min", leave, clock)), C(f"{base}_refresh", *group_vars, e1, upto)]
        stored = C(matched.name, *group_vars, x, s1, e1, e1)
        handler = f"{step.name}_left"
        self.arrival(step.left, handler, s1, e1)
        self.clauses.append(clause(C(handler, *inner_vars, s1, e1), [
            C("assertz", stored)] + refresh + [
            C("rtl_timer_add", leave, Atom("at"), C(f"{base}_refresh", *group_vars, leave, leave))]))
        self.clauses.append(clause(C(handler + "_retract", *inner_vars, s1, e1), [
            self.if_stored(stores, stored, conj(refresh))]))

    def numbered_sliding_clauses(self, step: Step) -> None:
        """sliding_clauses for a sliding aggregate whose changes a policy step takes: a match
        is stored with its arrival number, a change with its position, and a timer that
        reaches a leave time records its arrival number; a deletion gives each change the
        position the run without the deleted match gives it (rtl_sliding_refresh_numbered/10)."""
        function, value, duration, s1, e1, inner_vars, group_vars, x, stores = self.sliding_parts(step)
        arrival, t, at = V(self.fresh("Arrival")), V(self.fresh("T")), V(self.fresh("At"))
        # the arrival number third from the end, where rtl_policy_take_arrival/2 reads it
        matched = self.store(stores, "slid", group_vars + [V(self.fresh("X")), s1, arrival, e1, e1])
        shown = self.store(stores, "changes", group_vars + [value, at, t, t])
        reached = self.store(stores, "reached", group_vars + [at, t, t])
        base = step.name
        x_, e_, v_, t_, p_ = (V(self.fresh(n)) for n in ("Xs", "Es", "Vs", "Ts", "Ps"))
        stored_match = C(matched.name, *group_vars, x_, V("_"), p_, e_, V("_"))
        stored_shown = C(shown.name, *group_vars, v_, p_, t_, V("_"))
        stored_reached = C(reached.name, *group_vars, p_, t_, V("_"))
        for name_, params, stored in (("matches", [x_, e_, p_], stored_match), ("shown", [v_, t_, p_], stored_shown),
                                      ("reached_at", [t_, p_], stored_reached)):
            self.clauses.append(clause(C(f"{base}_{name_}", *group_vars, *params),
                                       [C(";", stored, self.kept_lookup(stored))]))
        self.clauses.append(clause(C(f"{base}_show", *group_vars, value, t, at), [
            C("assertz", shown), C("rtl_policy_at", at, self.output(step, t, t))]))
        self.clauses.append(clause(C(f"{base}_unshow", *group_vars, value, t), [
            self.if_stored(stores, C(shown.name, *group_vars, value, V("_"), t, t),
                           self.output(step, t, t, retract=True))]))
        frm, to, op = V(self.fresh("From")), V(self.fresh("To")), V(self.fresh("Op"))
        self.clauses.append(clause(C(f"{base}_refresh", *group_vars, frm, to, op), [
            C("rtl_sliding_refresh_numbered", function, Number(duration), frm, to, op,
              *(C(f"{base}_{n}", *group_vars) for n in ("matches", "shown", "reached_at", "show", "unshow")))]))
        # a timer reaching a leave time: the first records its arrival number
        self.clauses.append(clause(C(f"{base}_reach", *group_vars, t), [
            C("rtl_policy_arrival", at),
            C(";", C("->", C(";", C(reached.name, *group_vars, V("_"), t, V("_")),
                             self.kept_lookup(C(reached.name, *group_vars, V("_"), t, V("_")))),
                     Atom("true")),
              C("assertz", reached)),
            C(f"{base}_refresh", *group_vars, t, t, C("at", at))]))
        # arrivals and deletions of P; a leave time the clock has reached already was refreshed
        # by the arrival (a timer then would record a later arrival as the time's)
        leave, clock, upto = V(self.fresh("Leave")), V(self.fresh("Clock")), V(self.fresh("UpTo"))
        upto_goals = [C("is", leave, C("+", e1, Number(duration))), C("rtl_clock", clock),
                      C("is", upto, C("min", leave, clock))]
        handler = f"{step.name}_left"
        self.arrival(step.left, handler, s1, e1)
        self.clauses.append(clause(C(handler, *inner_vars, s1, e1), [
            C("rtl_policy_arrival", arrival), C("assertz", C(matched.name, *group_vars, x, s1, arrival, e1, e1))]
            + upto_goals + [
            C(f"{base}_refresh", *group_vars, e1, upto, C("at", arrival)),
            C(";", C("->", C(">", leave, clock), C("rtl_timer_add", leave, Atom("at"), C(f"{base}_reach", *group_vars, leave))),
              Atom("true"))]))
        stored = C(matched.name, *group_vars, x, s1, V("_"), e1, e1)
        self.clauses.append(clause(C(handler + "_retract", *inner_vars, s1, e1), [
            C(";", C("->", C("rtl_policy_take_arrival", list_term([stored] + self.kept_of(stored)), Atom("none")),
                     conj(upto_goals + [C(f"{base}_refresh", *group_vars, e1, upto, Atom("deleted"))])),
              Atom("true"))]))

    def aggregate_clauses(self, step: Step) -> None:
        """L seq aggregate(F, R, V): each L starts an accumulator; every later R updates the
        accumulators of the L's before it (within the window) and yields their new value V.
        Values follow the order the instances are processed in: each gets a sequence number,
        and the R's are recorded, so that deleting an L takes back its values and deleting an
        R replays the values of the accumulators it counted in (`_redo`). Numbered (a policy
        step takes the values), an R updates the accumulators in the arrival order of their
        L's."""
        function, value = step.aggregate
        s1, e1, s2, e2 = self.t("S1"), self.t("E1"), self.t("S2"), self.t("E2")
        acc0, acc = V(self.fresh("Acc0")), V(self.fresh("Acc"))
        seq, rseq, removed = V(self.fresh("Seq")), V(self.fresh("RSeq")), V(self.fresh("Removed"))
        items, values_, retracts, adds = (V(self.fresh(n)) for n in ("Items", "Values", "Retracts", "Adds"))
        left_vars, right_vars = operand_vars(step.left), operand_vars(step.right)
        key, left_other = _split(left_vars, right_vars)
        _, right_other = _split(right_vars, left_vars)
        # under a policy step that takes the values: the numbers of the start event and of the
        # event counted (rtl_policy.pl), so the values given again after a deletion arrive
        # where they were first given, and a deletion takes the latest arrival
        numbered = self.carries(step)
        # sequence number and accumulator before the times: the last two arguments of a store
        # are its interval (and numbered, the one before them its arrival number)
        numbers = (lambda a: [a, seq]) if numbered else (lambda a: [seq, a])
        lefts = self.store(step, "lefts", key + left_other + numbers(acc0) + [s1, e1])
        rights = self.record(step, "rights", key + right_other + [rseq, s2, e2], rotated=step.window is not None)

        def left_with(a: Term, kept: str = "") -> Term:
            return C(lefts.name + kept, *key, *left_other, *numbers(a), s1, e1)

        def take_latest(stores: List[Term]) -> Term:
            return C("rtl_policy_take_arrival", list_term(stores), Atom("none"))

        window = self.window_check(step, s1, e2)
        # the R's an accumulator counted, as rtl_aggregate_values/3 items
        counted = C("findall", C("-", rseq, C("-", C("-", function, s2), e2)),
                    conj([self.record_lookup(rights), C(">", rseq, seq), C("<", e1, s2), window]), items)
        handler = f"{step.name}_left"
        self.arrival(step.left, handler, s1, e1)
        # the value over the empty set when the start event opens the aggregate (count, sum);
        # forall/2 leaves V unbound for the values that follow
        initial = C("rtl_aggregate_initial", function, value)
        counted_seq = V(self.fresh("CountedSeq")) if numbered else V("_")
        start_arrival = seq if numbered else None
        value_arrivals = C("-", seq, counted_seq) if numbered else None
        self.clauses.append(clause(C(handler, *left_vars, s1, e1), [
            C("rtl_next_seq", seq), C("assertz", left_with(Atom("none"))),
            C("forall", initial, self.output(step, s1, e1, arrivals=start_arrival))]))
        values = conj([C("forall", initial, self.output(step, s1, e1, retract=True, arrivals=start_arrival)),
                       counted, C("rtl_aggregate_values", items, V("_"), values_),
                       C("forall", C("member", C("-", counted_seq, C("-", value, e2)), values_),
                         self.output(step, s1, e2, retract=True, arrivals=value_arrivals))])
        if numbered:
            stored = left_with(V("_"))
            taken = C(";", C("->", take_latest([stored] + (self.kept_of(stored) if step.window is not None else [])),
                             values), Atom("true"))
        else:
            taken = self.if_stored(step, left_with(V("_")), values)
        self.clauses.append(clause(C(handler + "_retract", *left_vars, s1, e1), [taken]))
        handler = f"{step.name}_right"
        self.arrival(step.right, handler, s2, e2)
        loops = []
        for kept in (["", "_kept_a", "_kept_b"] if step.window is not None else [""]):
            # an accumulator is updated where it is stored (live or kept)
            found = conj([left_with(acc0, kept), C("<", e1, s2), window])
            update = conj([C("rtl_aggregate", function, acc0, acc, value), C("retract", left_with(acc0, kept)),
                           C("assertz", left_with(acc, kept)),
                           self.output(step, s1, e2, arrivals=C("-", seq, rseq) if numbered else None)])
            if numbered:
                # numbered values are made in the arrival order of their start events: an
                # update or a deletion's redo moves an accumulator to the end of its store,
                # and the policy step takes the values in the order they are made
                found_lefts, in_order = V(self.fresh("Lefts")), V(self.fresh("InOrder"))
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
        body += ([] if numbered else [C("rtl_next_seq", rseq)]) + [self.record_add(rights)]
        self.clauses.append(clause(C(handler, *right_vars, s2, e2), body))
        redo = C(f"{step.name}_redo", *key, *left_other, seq, s1, e1, removed)
        found = conj([self.lookup(step, left_with(V("_")), e2), C("<", seq, rseq), C("<", e1, s2), window])
        counted_taken = self.record_take(rights)
        if numbered:
            counted_taken = take_latest(self.generations(rights) if self.is_rotated(rights) else [rights])
        self.clauses.append(clause(C(handler + "_retract", *right_vars, s2, e2), [
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
            self.clauses.append(clause(redo, [
                counted, C("rtl_aggregate_redo_numbered", items, removed, acc, retracts, adds),
                C("forall", C("member", C("-", counted_seq, C("-", value, e2)), retracts),
                  self.output(step, s1, e2, retract=True, arrivals=value_arrivals)),
                self.restoring(C("forall", C("member", C("-", counted_seq, C("-", value, e2)), adds),
                                 self.output(step, s1, e2, arrivals=value_arrivals)))] + replace))
            return
        self.clauses.append(clause(redo, [
            counted, C("rtl_aggregate_redo", items, removed, acc, retracts, adds),
            C("forall", C("member", C("-", value, e2), retracts), self.output(step, s1, e2, retract=True)),
            C("forall", C("member", C("-", value, e2), adds), self.output(step, s1, e2))] + replace))

    def alarm(self, step: Step, head: Compound, s: Var, e: Var, retract: bool) -> Term:
        """`alarm(Event, D)` (ETALIS `exceptionAlarm(Event, D)`): raise Event over [the match's
        start, its end + D] when the clock reaches the end + D (a timer: the clock does not
        move). A deleted match cancels its timer, or takes back the Event it raised (recorded
        in `_alarms`, kept for the retraction horizon when the rule has a window, else as long
        as the program runs, like the records of an unwindowed aggregate)."""
        event, delay = head.args
        due = V(self.time_names.setdefault("Due", self.fresh("Due")))
        fire = C(f"{step.name}_alarm", event, s, due)
        fired = self.record(step, "alarms", [event, s, due], rotated=step.window is not None)
        if not retract:
            raised, since, when = (V(self.fresh(n)) for n in ("Raised", "Since", "When"))
            self.clauses.append(clause(C(fire.name, raised, since, when), [
                self.record_add(C(fired.name, raised, since, when)), C("rtl_derived", raised, since, when)]))
        at = C("is", due, C("+", e, delay))
        if not retract:
            return conj([at, C("rtl_timer_add", due, Atom("at"), fire)])
        return conj([at, C(";", C("->", C("rtl_timer_cancel", fire), Atom("true")),
                           C(";", C("->", self.record_take(fired), C("rtl_underived", event, s, due)),
                             Atom("true")))])

    def made(self, step: Step, result: Term, retract: bool, arrivals: Term) -> Term:
        """A result that a policy step takes as input, with the record of when it was made
        (`_made`, kept for the retraction horizon, with the arrival numbers it was made from):
        taking it back tells the policy step which of several identical arrivals to delete
        (rtl_policy_made/5, rtl_policy_unmade/5)."""
        s, e = self.t("S"), self.t("E")
        position = V(self.time_names.setdefault("Made", self.fresh("Made")))
        made = C(f"{step.name}_made", *step.output.args, s, e, arrivals, position)
        if not self.is_rotated(made):
            self.record(step, "made", list(made.args), rotated=True)
        return C("rtl_policy_unmade" if retract else "rtl_policy_made", *self.generations(made), arrivals, position,
                 result)

    def restoring(self, goal: Term) -> Term:
        """Results made again because a blocker (or a `first` partner) is deleted: under a
        policy step that takes them as input, they arrive where their last input event arrived
        (rtl_policy_restoring/1)."""
        if not self.provenance:
            return goal
        return C("rtl_policy_restoring", goal)

    def fresh(self, base: str) -> str:
        """A variable name no source variable of the rule uses (and reserve it)."""
        name_ = base
        while name_ in self.used:
            name_ += "_"
        self.used.add(name_)
        return name_

    def output_clauses(self, step: Step) -> None:
        """`e(Vars, S, E)`: check the step's conditions, then pass the result on (or derive
        the head); `e_retract(Vars, S, E)` takes it back the same way."""
        s, e = self.t("S"), self.t("E")
        conditions = [self.times(c, s, e) for c in step.conditions]
        arrivals = V(self.fresh("Arrivals")) if self.provenance else None
        for retract in (False, True):
            head = self.output(step, s, e, retract, arrivals if self.carries(step) else None)
            numbered = []
            if self.provenance and not self.carries(step):
                # (a sliding aggregate's value arrives when it is made; its deletion takes the
                # latest)
                numbered = [] if retract else [C("rtl_policy_arrival", arrivals)]
                arrivals = V("_") if retract else arrivals
            if step.derives_head:
                rule = self.rule.rule
                derive = "rtl_underived" if retract else "rtl_derived"
                action = C("rtl_action", rule.action) if rule.action is not None and not retract else None
                if rule.synchronized is not None:
                    sync = "rtl_synchronized_retract" if retract else "rtl_synchronized"
                    result = C(sync, *rule.synchronized.args, s, e)
                elif alarm_head(rule.head):
                    result = self.alarm(step, rule.head, s, e, retract)
                else:
                    result = None if rule.head == Atom("null") else C(derive, rule.head, s, e)
                detected = None if retract else C("rtl_detected", Atom(self.rule.rule_id))
                if self.provenance and result is not None and result.name in ("rtl_derived", "rtl_underived"):
                    result = self.made(step, result, retract, arrivals)
                then = conj(numbered + [detected, action, result]) if (detected or action or result) else Atom("true")
            else:
                consumer, takes_arrivals = self.consumers[step.name]
                then = conj(numbered + [C(consumer + ("_retract" if retract else ""), *step.output.args,
                                          *([arrivals] if takes_arrivals else []), s, e)])
            body = [C("forall", conj(conditions), then)] if conditions else [then]
            self.clauses.append(clause(head, body))



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


def _number(value: float):
    return int(value) if float(value).is_integer() else value
