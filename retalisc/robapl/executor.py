"""The RobAPL executor: the deliberation cycle of thesis 7.2.3 over plans that are node trees.

Each macro step takes the next event of the event base (first come, first served: by time, then
by arrival), runs the planning step (the first plan-generating rule whose head matches the event
and whose belief query holds adds its plan, root Waiting), then micro steps until quiescence: in
a micro step every node's transition is computed from the same snapshot of the plan base and all
of them are applied together (synchronous). Nodes whose transitions conflict (a resource, a
shared variable) are taken in priority order. docs/robapl.md gives every transition and where it
comes from (the thesis, or PLEXIL's node state transition semantics where the thesis is silent).
"""
from __future__ import annotations

import heapq
import itertools
import re
from dataclasses import dataclass, field
from typing import Callable, Dict, Iterable, List, Optional, Tuple

from .conditions import BeliefConditions
from .syntax import CHILD_KINDS, WIND_DOWN_KINDS, Agent, NodeSpec, ResourceUsage
from .terms import Atom, BeliefBase, Bindings, Compound, Literal, Term, Var, resolve, show, unify

INACTIVE, WAITING, WAITING_RESOURCE, EXECUTING = "inactive", "waiting", "waiting_resource", "executing"
FINISHING, FAILING, PAUSING, PAUSED, RESUMING = "finishing", "failing", "pausing", "paused", "resuming"
ITERATION_ENDED, FINISHED, DEACTIVATING = "iteration_ended", "finished", "deactivating"
STATES = (INACTIVE, WAITING, WAITING_RESOURCE, EXECUTING, FINISHING, FAILING, PAUSING, PAUSED, RESUMING,
          ITERATION_ENDED, FINISHED, DEACTIVATING)
OUTCOMES = ("success", "failure", "skipped", "parent_failure", "preempted", "parent_preempted")

#: The wind-down list a node runs in each phase, before it changes state (thesis 7.2.3).
_WIND_DOWN_OF = {"failure": "on_abort", "parent_failure": "on_abort", "preempted": "on_preempt",
                 "parent_preempted": "on_preempt", "pause": "on_pause", "resume": "on_resume"}
#: The outcome of the children of a node that fails, is pre-empted or pauses.
_CHILD_OUTCOME = {"failure": "parent_failure", "parent_failure": "parent_failure", "preempted": "parent_preempted",
                  "parent_preempted": "parent_preempted", "pause": "parent_failure"}
MAX_MICRO_STEPS = 10_000

#: Every transition the executor makes: (from, to, why), the `why` of its trace records. The
#: golden cases of tests/golden_robapl/ make each of them at least once; docs/robapl.md gives
#: each one's source (thesis 7.2.3 or PLEXIL's node state transition semantics).
TRANSITIONS = (
    (INACTIVE, WAITING, "parent executing"),
    (INACTIVE, WAITING, "parent failing"),
    (INACTIVE, WAITING, "parent pausing"),
    (INACTIVE, WAITING, "parent resuming"),
    (INACTIVE, FINISHED, "parent finished"),
    (WAITING, FINISHED, "ancestor aborting"),
    (WAITING, FINISHED, "parent finishing"),
    (WAITING, ITERATION_ENDED, "pre condition false"),
    (WAITING, WAITING_RESOURCE, "resources unavailable"),
    (WAITING, EXECUTING, "start"),
    (WAITING_RESOURCE, FINISHED, "ancestor aborting"),
    (WAITING_RESOURCE, WAITING, "resources available"),
    (EXECUTING, FAILING, "ancestor aborting"),
    (EXECUTING, FAILING, "pre-empted"),
    (EXECUTING, PAUSING, "pause"),
    (EXECUTING, FAILING, "invariant false"),
    (EXECUTING, ITERATION_ENDED, "action failed"),
    (EXECUTING, FINISHING, "end"),
    (EXECUTING, ITERATION_ENDED, "end"),
    (FINISHING, FAILING, "ancestor aborting"),
    (FINISHING, FAILING, "pre-empted"),
    (FINISHING, FAILING, "invariant false"),
    (FINISHING, ITERATION_ENDED, "children finished"),
    (FAILING, ITERATION_ENDED, "aborted"),
    (FAILING, FINISHED, "aborted"),
    (PAUSING, PAUSED, "children and on_pause finished"),
    (PAUSED, FINISHED, "ancestor aborting"),
    (PAUSED, RESUMING, "resume"),
    (RESUMING, FAILING, "ancestor aborting"),
    (RESUMING, WAITING, "on_resume finished"),
    (ITERATION_ENDED, FINISHED, "ancestor aborting"),
    (ITERATION_ENDED, WAITING, "repeat"),
    (ITERATION_ENDED, FINISHED, "iteration ended"),
    (FINISHED, DEACTIVATING, "plan finished"),
)
_IDENTIFIER = re.compile(r"[a-z][A-Za-z0-9_]*")


class ExecutionError(Exception):
    """A run that cannot go on (no quiescence, an unknown action)."""


class Pending:
    """Returned by an action that answers later: its result arrives as the event
    `action_result(Handle, Value)` (or `action_failed(Handle, Reason)`)."""


PENDING = Pending()


class ActionFailed(Exception):
    """Raised by an action that failed at once: the node ends its iteration with failure."""


@dataclass
class ActionContext:
    """What an action is given besides its arguments: its handle, the clock, a way to emit events."""
    handle: str
    time: float
    emit: Callable[[Term, float], None]


class Actions:
    """External actions: Python callables registered by name (the functor of the node's term)."""

    def __init__(self):
        self._actions: Dict[str, Callable] = {}
        self._aborts: Dict[str, Callable] = {}
        # results that arrive from outside the run (ros2_actions.ResultInbox): before each
        # macro step `collect(next_time)` gives them as (time, event), waiting while calls are out
        self.results = None

    def register(self, name: str, action: Callable, abort: Optional[Callable] = None) -> None:
        self._actions[name] = action
        if abort is not None:
            self._aborts[name] = abort

    def names(self) -> List[str]:
        return sorted(self._actions)

    def call(self, term: Term, context: ActionContext):
        name = term.functor if isinstance(term, Compound) else getattr(term, "name", str(term))
        if name not in self._actions:
            raise ExecutionError(f"no external action named {name} is registered")
        args = tuple(python_value(a) for a in term.args) if isinstance(term, Compound) else ()
        return self._actions[name](*args, context=context)

    def abort(self, term: Term, handle: str) -> None:
        name = term.functor if isinstance(term, Compound) else getattr(term, "name", str(term))
        if name in self._aborts:
            self._aborts[name](handle)


def python_value(term: Term):
    if isinstance(term, Atom):
        return term.name
    if isinstance(term, Compound):
        return {term.functor: [python_value(a) for a in term.args]}
    return term


def term_value(value) -> Term:
    if isinstance(value, bool):
        return Atom("true" if value else "false")
    if isinstance(value, (int, float, Atom, Compound)):
        return value
    if isinstance(value, str):
        # an identifier is an atom (`"alice"` answers `friend(alice)`); other text is a string
        return Atom(value) if _IDENTIFIER.fullmatch(value) else value
    return str(value)


@dataclass(eq=False)
class Node:
    spec: NodeSpec
    plan: "Plan"
    parent: Optional["Node"]
    path: str
    children: List["Node"] = field(default_factory=list)          # the normal children
    wind_down: Dict[str, "Node"] = field(default_factory=dict)     # on_pause/on_resume/on_abort/on_preempt
    state: str = INACTIVE
    outcome: Optional[str] = None
    phase: Optional[str] = None          # why the node is Failing/Pausing: an outcome, or "pause"
    start_time: Optional[float] = None
    end_time: Optional[float] = None
    result: Term = None
    result_ready: bool = False
    action_failed: bool = False
    handle: Optional[str] = None
    preempt_requested: bool = False
    held: Dict[str, float] = field(default_factory=dict)
    order: int = 0
    iteration: int = 1

    @property
    def kind(self) -> str:
        return self.spec.kind

    @property
    def is_wind_down(self) -> bool:
        return self.spec.kind in WIND_DOWN_KINDS

    @property
    def is_parent(self) -> bool:
        return self.spec.kind not in CHILD_KINDS or self.spec.kind == "abstract"

    @property
    def priority(self) -> int:
        node = self
        while node is not None:
            if node.spec.priority is not None:
                return node.spec.priority
            node = node.parent
        return 0

    def all_children(self) -> List["Node"]:
        return self.children + list(self.wind_down.values())

    def walk(self) -> Iterable["Node"]:
        yield self
        for child in self.all_children():
            yield from child.walk()


@dataclass(eq=False)
class Plan:
    name: str
    bindings: Bindings
    root: Optional[Node] = None
    seq: int = 0

    def nodes(self) -> List[Node]:
        return list(self.root.walk())


@dataclass(frozen=True)
class Transition:
    node: Node
    to: str
    outcome: Optional[str] = None
    why: str = ""


class ResourcePool:
    """The agent's resources: capacities and what each node holds. `using` takes the amount,
    `blocking` takes the whole resource (needs it all free), `adding` gives the amount back
    to the pool when the node succeeds (capped at the capacity)."""

    def __init__(self, capacity: Dict[str, float]):
        self.capacity = dict(capacity)
        self.free = dict(capacity)

    def need(self, usage: ResourceUsage) -> float:
        return self.capacity[usage.name] if usage.usage == "blocking" else usage.amount

    def available_to(self, node: Node, lent: Dict[str, float]) -> bool:
        for usage in node.spec.resources:
            if usage.usage == "adding":
                continue
            if self.free[usage.name] + lent.get(usage.name, 0) < self.need(usage):
                return False
        return True


class Executor:
    """One agent: its belief base, goal base, event base, plan base, resource pool and actions."""

    def __init__(self, agent: Agent, actions: Optional[Actions] = None, conditions=None, iec=None):
        self.agent = agent
        self.actions = actions or Actions()
        self.beliefs = BeliefBase(agent.beliefs)
        self.goal_base: List[Term] = []
        self.pool = ResourcePool(agent.pool)
        self.plans: List[Plan] = []
        self.trace: List[dict] = []
        self.time = 0.0
        self.macro = 0
        self.micro = 0
        self.event: Optional[Term] = None
        self._queue: List[Tuple[float, int, Term]] = []
        self._arrivals = itertools.count()
        self._plan_numbers: Dict[str, int] = {}
        self._handles = itertools.count(1)
        self._pending: Dict[str, Node] = {}
        self._plan_seq = itertools.count()
        self._timers: set = set()
        # the nodes that paused or resumed in this macro step: they do neither again before the
        # next one, so one event cannot pause and resume a node for ever (no quiescence)
        self._toggled: set = set()
        self._free_now: Dict[str, float] = dict(self.pool.free)   # the pool as a micro step takes from it
        self.conditions = conditions or BeliefConditions(self.beliefs, self)
        # an IEC driven in step (iec.SteppedIEC): each macro step's event and node status
        # changes go to it, its derived events join the event base (not sent back to it)
        self.iec = iec
        self._from_iec: set = set()
        self._status_changes: List[Tuple[str, str]] = []
        for goal in agent.goals:
            self.adopt(goal, 0.0)

    # ----- the view the conditions read (conditions.NodeView)
    def now(self) -> float:
        return self.time

    def current_event(self) -> Optional[Term]:
        return self.event

    def goals(self) -> list:
        return list(self.goal_base)

    def resource_free(self, name: str) -> Optional[float]:
        return self.pool.free.get(name)

    def wake_at(self, node: Node, time: float) -> None:
        """A timer event `timer(NodeId, Time)` at `time` (once per node and time): a `timeout(S)`
        condition must be evaluated again then, even if no other event comes."""
        key = (node.path, node.start_time, time)
        if key not in self._timers:
            self._timers.add(key)
            self.post(Compound("timer", (node.path, time)), time)

    def find_node(self, asking: Node, name: str) -> Optional[Node]:
        for node in asking.plan.root.walk():
            if node.spec.name == name:
                return node
        return None

    # ----- the event base
    def post(self, event: Term, time: float, from_iec: bool = False) -> None:
        arrival = next(self._arrivals)
        if from_iec:
            self._from_iec.add(arrival)
        heapq.heappush(self._queue, (time, arrival, event))

    def adopt(self, goal: Term, time: float) -> None:
        if goal not in self.goal_base:
            self.goal_base.append(goal)
            self.post(goal, time)

    def run(self, events: Iterable[Tuple[float, Term]] = ()) -> List[dict]:
        for time, event in events:
            self.post(event, time)
        while True:
            results = getattr(self.actions, "results", None)
            if results is not None:
                for time, event in results.collect(self._queue[0][0] if self._queue else None):
                    self.post(event, max(time, self.time))
            if not self._queue:
                return self.trace
            self.macro_step()

    def macro_step(self) -> None:
        time, arrival, event = heapq.heappop(self._queue)
        self.time = max(self.time, time)
        self.event = event
        self.macro += 1
        self.micro = 0
        self._toggled.clear()
        self._record({"event": show(event)})
        self._result_event(event)
        self._plan_for(event)
        self.quiesce()
        self.event = None
        if self.iec is not None:
            fed = [] if arrival in self._from_iec else [event]
            self._from_iec.discard(arrival)
            changes, self._status_changes = self._status_changes, []
            for at, derived in self.iec.step(self.time, fed, changes):
                self.post(derived, max(at, self.time), from_iec=True)

    def _result_event(self, event: Term) -> None:
        if isinstance(event, Compound) and event.functor in ("action_result", "action_failed") and \
                len(event.args) == 2 and isinstance(event.args[0], str):
            node = self._pending.pop(event.args[0], None)
            if node is not None and node.state in (EXECUTING, FAILING, PAUSING):
                node.result, node.result_ready = event.args[1], True
                node.action_failed = event.functor == "action_failed"
                self._bind_result(node)

    def _plan_for(self, event: Term) -> None:
        for rule in self.agent.rules:
            bindings = unify(rule.event, event, {})
            if bindings is None:
                continue
            found = self.conditions.first(None, "guard", rule.guard, bindings)
            if found is not None:
                plan = self.instantiate(rule.plan, found)
                plan.root.state = WAITING
                self._record({"plan": plan.name, "rule": str(rule)})
                return

    def instantiate(self, spec: NodeSpec, bindings: Bindings, parent: Optional[Node] = None,
                    plan: Optional[Plan] = None) -> Plan:
        if plan is None:
            number = self._plan_numbers[spec.name] = self._plan_numbers.get(spec.name, 0) + 1
            plan = Plan(f"{spec.name}#{number}", dict(bindings), seq=next(self._plan_seq))
            self.plans.append(plan)
        counter = itertools.count(sum(1 for _ in plan.root.walk()) if plan.root else 0)

        def build(spec: NodeSpec, parent: Optional[Node], path: str) -> Node:
            node = Node(spec, plan, parent, path, order=next(counter))
            for child_spec in spec.children:
                child = build(child_spec, node, f"{path}/{child_spec.name}")
                if child.is_wind_down:
                    node.wind_down[child_spec.kind] = child
                else:
                    node.children.append(child)
            return node

        if parent is None:
            plan.root = build(spec, None, plan.name)
        else:
            child = build(spec, parent, f"{parent.path}/{spec.name}")
            parent.children.append(child)
        return plan

    # ----- micro steps
    def quiesce(self) -> None:
        while True:
            transitions = self.micro_step_transitions()
            if not transitions:
                break
            self.micro += 1
            if self.micro > MAX_MICRO_STEPS:
                raise ExecutionError(f"no quiescence after {MAX_MICRO_STEPS} micro steps (a repeat that always holds?)")
            self.apply(transitions)
        self.plans = [plan for plan in self.plans if plan.root.state != DEACTIVATING]

    def _ordered_nodes(self) -> List[Node]:
        nodes = [node for plan in self.plans for node in plan.root.walk()]
        return sorted(nodes, key=lambda n: (-n.priority, n.plan.seq, n.order))

    def micro_step_transitions(self) -> List[Transition]:
        """The transitions of this micro step, all computed from the same snapshot; resources and
        shared variables are taken in priority order (the order of `_ordered_nodes`)."""
        self._free_now = dict(self.pool.free)
        transitions = []
        for node in self._ordered_nodes():
            transition = self.transition_of(node)
            if transition is not None:
                transitions.append(transition)
        return transitions

    def _holds(self, node: Node, name: str, default: bool, bindings_out: bool = False):
        query = node.spec.conditions.get(name)
        if query is None:
            return default
        found = self.conditions.first(node, name, query, node.plan.bindings)
        if bindings_out and found is not None:
            return found
        return found is not None

    def _aborted_from_above(self, node: Node) -> Optional[str]:
        """The outcome for `node` when an ancestor is failing, pre-empted or pausing through
        the node's branch (a wind-down branch of that ancestor is protected), else None."""
        child, above = node, node.parent
        while above is not None:
            if above.state in (FAILING, PAUSING):
                # the wind-down of this phase runs; the node's other branches are aborted
                protected = child.is_wind_down and child.kind == _WIND_DOWN_OF[above.phase]
                return None if protected else _CHILD_OUTCOME[above.phase]
            if above.state in (PAUSED, RESUMING) and not child.is_wind_down:
                return "parent_failure"
            child, above = above, above.parent
        return None

    def _lent(self, node: Node) -> Dict[str, float]:
        """Resources held by the node's failing or pausing ancestors, which its wind-down may use."""
        lent: Dict[str, float] = {}
        above = node.parent
        while above is not None:
            if above.state in (FAILING, PAUSING, RESUMING):
                for name, amount in above.held.items():
                    lent[name] = lent.get(name, 0) + amount
            above = above.parent
        return lent

    def _settled(self, node: Node) -> bool:
        """The normal children and the wind-downs of other phases are Inactive or Finished."""
        running = _WIND_DOWN_OF.get(node.phase) if node.state in (FAILING, PAUSING) else None
        return all(child.state in (INACTIVE, FINISHED) for child in node.all_children() if child.kind != running)

    def _wind_down_done(self, node: Node, phase: str) -> bool:
        winding = node.wind_down.get(_WIND_DOWN_OF[phase])
        return winding is None or winding.state == FINISHED

    def _end_holds(self, node: Node) -> bool:
        if "end" in node.spec.conditions:
            return self._holds(node, "end", True)
        if node.kind == "external":
            return node.result_ready
        if node.is_parent:
            return bool(node.children) and all(c.state == FINISHED for c in node.children) or not node.children
        return True

    def transition_of(self, node: Node) -> Optional[Transition]:
        state, parent = node.state, node.parent
        from_above = self._aborted_from_above(node)
        if state == INACTIVE:
            if parent is None:
                return None
            if node.is_wind_down:
                phase = parent.phase if parent.state in (FAILING, PAUSING) else (
                    "resume" if parent.state == RESUMING else None)
                if phase is not None and _WIND_DOWN_OF[phase] == node.kind and self._settled(parent) \
                        and from_above is None:
                    return Transition(node, WAITING, why=f"parent {parent.state}")
                return None
            if parent.state == EXECUTING and from_above is None:
                return Transition(node, WAITING, why="parent executing")
            if parent.state == FINISHED:
                return Transition(node, FINISHED, "skipped", "parent finished")
            return None
        if state in (WAITING, WAITING_RESOURCE):
            if from_above is not None:
                return Transition(node, FINISHED, "skipped", "ancestor aborting")
            if parent is not None and parent.state == FINISHING and not node.is_wind_down:
                return Transition(node, FINISHED, "skipped", "parent finishing")
            if state == WAITING_RESOURCE:
                if self.pool.available_to(node, self._lent(node)):
                    return Transition(node, WAITING, why="resources available")
                self._request_preemption(node)
                return None
            if not self._holds(node, "start", True):
                return None
            if not self._holds(node, "pre", True):
                return Transition(node, ITERATION_ENDED, "failure", "pre condition false")
            if not self._take(node):
                return Transition(node, WAITING_RESOURCE, why="resources unavailable")
            self._bind_condition(node, "start")
            return Transition(node, EXECUTING, why="start")
        if state == EXECUTING:
            if from_above is not None:
                return Transition(node, FAILING, from_above, "ancestor aborting")
            if node.preempt_requested or self._holds(node, "preempt", False):
                return Transition(node, FAILING, "preempted", "pre-empted")
            if id(node) not in self._toggled and self._holds(node, "pause", False):
                return Transition(node, PAUSING, why="pause")
            if not self._holds(node, "invariant", True):
                return Transition(node, FAILING, "failure", "invariant false")
            if node.action_failed:
                return Transition(node, ITERATION_ENDED, "failure", "action failed")
            if self._end_holds(node):
                self._bind_condition(node, "end")
                if node.is_parent:
                    return Transition(node, FINISHING, why="end")
                return Transition(node, ITERATION_ENDED, self._post_outcome(node), "end")
            return None
        if state == FINISHING:
            if from_above is not None:
                return Transition(node, FAILING, from_above, "ancestor aborting")
            if node.preempt_requested or self._holds(node, "preempt", False):
                return Transition(node, FAILING, "preempted", "pre-empted")
            if not self._holds(node, "invariant", True):
                return Transition(node, FAILING, "failure", "invariant false")
            if all(c.state == FINISHED for c in node.children):
                return Transition(node, ITERATION_ENDED, self._post_outcome(node), "children finished")
            return None
        if state in (FAILING, PAUSING):
            if node.is_parent:
                if not self._settled(node) or not self._wind_down_done(node, node.phase):
                    return None
            elif node.handle in self._pending:
                return None        # waits for the aborted action to answer (aborts answer at once here)
            if state == PAUSING:
                return Transition(node, PAUSED, why="children and on_pause finished")
            if node.outcome == "failure":
                return Transition(node, ITERATION_ENDED, "failure", "aborted")
            return Transition(node, FINISHED, node.outcome, "aborted")
        if state == PAUSED:
            if from_above is not None:
                return Transition(node, FINISHED, from_above, "ancestor aborting")
            if id(node) not in self._toggled and self._holds(node, "resume", False):
                return Transition(node, RESUMING, why="resume")
            return None
        if state == RESUMING:
            if from_above is not None:
                return Transition(node, FAILING, from_above, "ancestor aborting")
            if self._wind_down_done(node, "resume"):
                return Transition(node, WAITING, why="on_resume finished")
            return None
        if state == ITERATION_ENDED:
            if from_above is not None:
                return Transition(node, FINISHED, node.outcome, "ancestor aborting")
            if self._holds(node, "repeat", False):
                return Transition(node, WAITING, why="repeat")
            return Transition(node, FINISHED, node.outcome, "iteration ended")
        if state == FINISHED:
            if parent is None:
                return Transition(node, DEACTIVATING, node.outcome, "plan finished")
            return None
        return None

    def _post_outcome(self, node: Node) -> str:
        return "success" if self._holds(node, "post", True) else "failure"

    def _bind_condition(self, node: Node, name: str) -> None:
        found = self._holds(node, name, True, bindings_out=True)
        if isinstance(found, dict):
            node.plan.bindings.update(found)

    def _take(self, node: Node) -> bool:
        """Takes the node's resources in this micro step's priority order, or False."""
        lent = self._lent(node)
        for usage in node.spec.resources:
            if usage.usage != "adding" and self._free_now[usage.name] + lent.get(usage.name, 0) < self.pool.need(usage):
                self._request_preemption(node)
                return False
        for usage in node.spec.resources:
            if usage.usage != "adding":
                self._free_now[usage.name] -= self.pool.need(usage)
        return True

    def _request_preemption(self, node: Node) -> None:
        """A node waiting for a resource held by plans of a lower priority pre-empts those plans
        (thesis 7.1.3): their roots go Failing with the outcome pre-empted."""
        needed = {u.name for u in node.spec.resources if u.usage != "adding"}
        for plan in self.plans:
            if plan is node.plan or plan.root.priority >= node.priority:
                continue
            if any(n.held.get(name) for n in plan.root.walk() for name in needed):
                if plan.root.state in (EXECUTING, FINISHING) and not plan.root.preempt_requested:
                    plan.root.preempt_requested = True
                    self._record({"preempt": plan.name, "by": node.path})

    # ----- applying a micro step
    def apply(self, transitions: List[Transition]) -> None:
        for transition in transitions:
            node = transition.node
            self._record({"node": node.path, "from": node.state, "to": transition.to,
                          "outcome": transition.outcome, "why": transition.why})
            previous, node.state = node.state, transition.to
            if transition.to in (PAUSING, RESUMING):
                self._toggled.add(id(node))
            if self.iec is not None:
                self._status_changes.append((node.path, node.state))
            if transition.outcome is not None:
                node.outcome = transition.outcome
            self._entered(node, previous, transition)
        for transition in transitions:
            if transition.to == EXECUTING and transition.node.kind in CHILD_KINDS:
                self._perform(transition.node)

    def _entered(self, node: Node, previous: str, transition: Transition) -> None:
        state = node.state
        if state == WAITING:
            if previous == ITERATION_ENDED:
                node.iteration += 1
            node.outcome, node.result, node.result_ready, node.action_failed = None, None, False, False
            node.preempt_requested = False
            # after a pause the finished children stay finished (thesis 7.2.3); a repeat resets them all
            for child in (node.wind_down.values() if previous == RESUMING else node.all_children()):
                self._reset(child)
        elif state == EXECUTING:
            node.start_time, node.end_time = self.time, None
            for usage in node.spec.resources:
                if usage.usage != "adding":
                    self._acquire(node, usage.name, self.pool.need(usage))
        elif state in (FAILING, PAUSING):
            node.phase = "pause" if state == PAUSING else node.outcome
            if node.kind == "external" and node.handle in self._pending:
                self.actions.abort(resolve(node.spec.term, node.plan.bindings), node.handle)
                self._pending.pop(node.handle, None)
                self._record({"abort": node.path})
        elif state == PAUSED:
            self._release(node)
            for child in node.children:
                if child.outcome in ("skipped", "parent_failure") or \
                        (child.state == FINISHED and self._holds(child, "repeat", False)):
                    self._reset(child)
            self._reset(node.wind_down.get("on_pause"))
        elif state == RESUMING:
            pass
        elif state in (ITERATION_ENDED, FINISHED, DEACTIVATING):
            if node.end_time is None or previous != state:
                node.end_time = self.time
            if node.outcome == "success":
                for usage in node.spec.resources:
                    if usage.usage == "adding":
                        self.pool.free[usage.name] = min(self.pool.capacity[usage.name],
                                                         self.pool.free[usage.name] + usage.amount)
            self._release(node)

    def _reset(self, node: Optional[Node]) -> None:
        if node is None:
            return
        for each in node.walk():
            if each.state != INACTIVE:
                self._record({"node": each.path, "from": each.state, "to": INACTIVE, "outcome": None, "why": "reset"})
                if self.iec is not None:
                    self._status_changes.append((each.path, INACTIVE))
            each.state, each.outcome, each.phase, each.iteration = INACTIVE, None, None, 1
            each.result, each.result_ready, each.action_failed, each.preempt_requested = None, False, False, False
        if node.kind == "abstract":
            node.children.clear()

    def _acquire(self, node: Node, name: str, amount: float) -> None:
        """Takes `amount` of `name` for `node`: first from what its winding-down ancestors hold."""
        above = node.parent
        while above is not None and amount > 0:
            if above.state in (FAILING, PAUSING, RESUMING) and above.held.get(name):
                taken = min(above.held[name], amount)
                above.held[name] -= taken
                amount -= taken
                node.held[name] = node.held.get(name, 0) + taken
            above = above.parent
        if amount > 0:
            self.pool.free[name] -= amount
            node.held[name] = node.held.get(name, 0) + amount

    def _release(self, node: Node) -> None:
        """Gives back what the node holds: to the nearest ancestor that is failing or pausing
        (its wind-down nodes may need it; it is released when that ancestor ends), else to the pool."""
        for name, amount in list(node.held.items()):
            if amount <= 0:
                continue
            above = node.parent
            while above is not None and above.state not in (FAILING, PAUSING):
                above = above.parent
            if above is not None:
                above.held[name] = above.held.get(name, 0) + amount
            else:
                self.pool.free[name] += amount
        node.held.clear()

    def _perform(self, node: Node) -> None:
        """The action of a child node that has just started executing (synchronous, thesis 7.2.3)."""
        bindings = node.plan.bindings
        if node.kind == "belief_update":
            for literal in node.spec.conditions["post"]:
                term = resolve(literal.term, bindings)
                if literal.kind == "negative":
                    self.beliefs.remove(term)
                elif literal.kind == "positive" and not self.conditions.first(node, "post", (literal,), bindings):
                    self.beliefs.add(term)
            self._record({"belief_update": node.path, "post": ", ".join(
                str(Literal(lit.kind, resolve(lit.term, bindings), lit.operator, lit.right))
                for lit in node.spec.conditions["post"])})
        elif node.kind == "goal_update":
            goal = resolve(node.spec.term.args[0], bindings)
            if node.spec.term.functor == "adopt":
                self.adopt(goal, self.time)
            elif goal in self.goal_base:
                self.goal_base.remove(goal)
            self._record({"goal_update": node.path, "goal": show(resolve(node.spec.term, bindings))})
        elif node.kind == "test":
            found = self.conditions.first(node, "test", (Literal("positive", node.spec.term),), bindings)
            if found is None:
                node.action_failed = True
            else:
                bindings.update(found)
        elif node.kind == "external":
            term = resolve(node.spec.term, bindings)
            node.handle = f"{node.path}@{next(self._handles)}"
            self._record({"action": show(term), "node": node.path})
            try:
                value = self.actions.call(term, ActionContext(node.handle, self.time, self._emit))
            except ActionFailed as error:
                node.action_failed, node.result, node.result_ready = True, str(error), True
                return
            if isinstance(value, Pending):
                self._pending[node.handle] = node
            else:
                node.result, node.result_ready = term_value(value), True
                self._bind_result(node)
        elif node.kind == "abstract":
            event = resolve(node.spec.term, bindings)
            for rule in self.agent.rules:
                found = unify(rule.event, event, dict(bindings))
                if found is not None:
                    found = self.conditions.first(node, "guard", rule.guard, found)
                if found is not None:
                    bindings.update(found)
                    self.instantiate(rule.plan, found, parent=node, plan=node.plan)
                    self._record({"abstract": node.path, "rule": str(rule)})
                    return
            node.action_failed = True

    def _bind_result(self, node: Node) -> None:
        if node.spec.result is not None:
            bound = unify(Var(node.spec.result), node.result, node.plan.bindings)
            if bound is None:
                node.action_failed = True
            else:
                node.plan.bindings.update(bound)

    def _emit(self, event: Term, delay: float = 0.0) -> None:
        self.post(event, self.time + delay)

    def _record(self, entry: dict) -> None:
        record = {"t": round(self.time, 6), "macro": self.macro, "micro": self.micro}
        record.update({k: v for k, v in entry.items() if v is not None})
        self.trace.append(record)

    def states(self) -> Dict[str, str]:
        return {node.path: node.state for plan in self.plans for node in plan.root.walk()}

