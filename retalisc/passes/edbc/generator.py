"""The state of one rule's code generation, shared by the operator families: the rule, its
policy, the names of its time variables, the clauses, triggers, stores and records made so
far, and the goals every family uses (an operand's arrival, a step's result, fresh names)."""
from __future__ import annotations

from typing import Dict, List, Optional, Set, Tuple

from ...frontend.terms import Compound, Term, Var, substitute, variables
from ..binarize import END_MARK, START_MARK
from ..unit import BinaryRule, Operand, Step
from .clauses import C, V, clause, operand_vars
from .stores import Stores


class RuleGenerator(Stores):
    """One rule's generator: operator families (joins, first, negation, ...) add the clauses
    of its steps (see `steps.generate`)."""

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
        self.roles: Dict[str, Tuple[str, str]] = {}     # store -> (step, what it holds)
        self.consumers: Dict[str, Tuple[str, bool]] = {}   # step -> the handler its results go to, with arrivals?
        # policy steps whose join key may be unbound in a partial match (a rule with `or`):
        # step name -> the variables recording each side's key as it was before the join
        self.loose: Dict[str, Tuple[Var, Var]] = {}
        self.branches: Dict[str, Var] = {}      # `or` step name -> its branch variable
        # the variables a partial match may leave unbound: those of one branch of an `or` only
        self.unbound: Set[str] = set()

    def t(self, base: str) -> Var:
        return V(self.time_names[base])

    def expr(self, goals: List[Term]) -> List[Term]:
        """Goals over the time variables (`relations`), renamed to this rule's names."""
        return [self.renamed(g) for g in goals]

    def renamed(self, term: Term) -> Term:
        return substitute(term, {k: V(v) for k, v in self.time_names.items()})

    def interval(self, expression: Term, target: Var) -> Tuple[Var, List[Term]]:
        """The variable holding an interval end: an operand's own, or `target is Expr`."""
        if isinstance(expression, Var):
            return self.renamed(expression), []
        return target, [C("is", target, self.renamed(expression))]

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
