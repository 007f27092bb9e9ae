"""How node conditions are answered: the one interface between the executor and what knows
whether a condition holds.

A condition is a query (retalisc/robapl/terms.py). This slice answers every condition on the
agent's belief base, the event of the current macro step and the nodes' attributes
(`BeliefConditions`). The interface is what a Retalis-backed source implements later: the
monitored conditions (start, end, invariant, preempt, pause, resume) compiled to ELE rules or
active queries of an IEC whose knowledge base holds the nodes' status, start and end times
(thesis 7.3.1), answered from the IEC's detections instead of by resolution here."""
from __future__ import annotations

from typing import Callable, Iterator, Optional, Protocol

from .terms import Atom, BeliefBase, Bindings, Compound, Query, Term, unify, walk

#: The built-in literals a condition may use, besides the beliefs (docs/robapl.md, "Conditions").
BUILTINS = ("event/1", "state/2", "outcome/2", "finished/1", "succeeded/1", "failed/1", "start_time/2",
            "end_time/2", "time/1", "done/0", "result/2", "goal/1", "resource_free/2", "timeout/1", "iteration/2")


class NodeView(Protocol):
    """What a condition may read of the plan: the executor's nodes and clock."""

    def find_node(self, asking, name: str): ...

    def now(self) -> float: ...

    def current_event(self) -> Optional[Term]: ...

    def goals(self) -> list: ...

    def resource_free(self, name: str) -> Optional[float]: ...

    def wake_at(self, node, seconds: float) -> None: ...


class ConditionSource(Protocol):
    """What the executor asks of whatever answers conditions (`Executor(conditions=...)`). `node`
    is None for a rule's guard; `name` is the condition (`start`, ..., `guard`, `test`), so a
    source can answer the monitored ones from an IEC and the checked-once ones by resolution."""

    def answers(self, node, name: str, query: Query, bindings: Bindings) -> Iterator[Bindings]:
        """The bindings under which condition `name` (its query `query`) of `node` holds."""

    def first(self, node, name: str, query: Query, bindings: Bindings) -> Optional[Bindings]:
        """The first of `answers`, or None when the condition does not hold."""


def _event_keys(query: Query) -> tuple:
    """The functor/arity of the event each positive `event(P)` literal of `query` needs (P not a variable)."""
    keys = []
    for literal in query:
        term = literal.term
        if literal.kind == "positive" and isinstance(term, Compound) and term.functor == "event" \
                and len(term.args) == 1 and isinstance(term.args[0], (Atom, Compound)):
            keys.append(BeliefBase.key(term.args[0]))
    return tuple(keys)


class BeliefConditions:
    """Conditions answered on the belief base by resolution, with the built-ins of BUILTINS."""

    def __init__(self, beliefs: BeliefBase, view: NodeView):
        self.beliefs = beliefs
        self.view = view
        self._event_keys: dict = {}

    def answers(self, node, name: str, query: Query, bindings: Bindings) -> Iterator[Bindings]:
        # A query with a positive `event(P)` literal can hold only in a macro step whose event has
        # P's functor and arity: checked before any resolution (the event index of the conditions).
        keys = self._event_keys.get(id(query))
        if keys is None:
            keys = self._event_keys[id(query)] = (query, _event_keys(query))
        if keys[1]:
            event = self.view.current_event()
            if event is None or any(BeliefBase.key(event) != key for key in keys[1]):
                return iter(())
        return self.beliefs.solve(query, bindings, self._builtin_for(node))

    def first(self, node, name: str, query: Query, bindings: Bindings) -> Optional[Bindings]:
        return next(iter(self.answers(node, name, query, bindings)), None)

    def _builtin_for(self, node) -> Callable[[Term, Bindings], Optional[Iterator[Bindings]]]:
        view = self.view

        def one(found: Optional[Bindings]) -> Iterator[Bindings]:
            if found is not None:
                yield found

        def node_named(term: Term):
            term = walk(term, {})
            return view.find_node(node, term.name) if isinstance(term, Atom) else None

        def builtin(goal: Term, bindings: Bindings) -> Optional[Iterator[Bindings]]:
            if isinstance(goal, Atom):
                if goal.name == "done":
                    return one(bindings if node.result_ready else None)
                return None
            if not isinstance(goal, Compound):
                return None
            key = (goal.functor, len(goal.args))
            args = [walk(a, bindings) for a in goal.args]
            if key == ("event", 1):
                event = view.current_event()
                return one(unify(args[0], event, bindings) if event is not None else None)
            if key == ("time", 1):
                return one(unify(args[0], view.now(), bindings))
            if key == ("timeout", 1):
                # true once the asking node has executed for that long; until then the executor
                # is asked to wake up at that time (a timer event), as nothing else may happen
                if node is None or node.start_time is None or not isinstance(args[0], (int, float)):
                    return one(None)
                if view.now() - node.start_time >= args[0]:
                    return one(bindings)
                view.wake_at(node, node.start_time + args[0])
                return one(None)
            if key == ("iteration", 2):
                other = node_named(args[0])
                return one(unify(args[1], other.iteration, bindings) if other is not None else None)
            if key == ("goal", 1):
                return (b for b in (unify(args[0], g, bindings) for g in view.goals()) if b is not None)
            if key == ("resource_free", 2):
                free = view.resource_free(args[0].name) if isinstance(args[0], Atom) else None
                return one(unify(args[1], free, bindings) if free is not None else None)
            if key == ("result", 2):
                other = node_named(args[0])
                ready = other is not None and other.result_ready
                return one(unify(args[1], other.result, bindings) if ready else None)
            if key in (("state", 2), ("outcome", 2), ("start_time", 2), ("end_time", 2)):
                other = node_named(args[0])
                if other is None:
                    return one(None)
                value = {"state": other.state, "outcome": other.outcome, "start_time": other.start_time,
                         "end_time": other.end_time}[goal.functor]
                return one(unify(args[1], Atom(value) if isinstance(value, str) else value, bindings)
                           if value is not None else None)
            if key in (("finished", 1), ("succeeded", 1), ("failed", 1)):
                other = node_named(args[0])
                if other is None or other.state != "finished":
                    return one(None)
                wanted = {"finished": None, "succeeded": ("success",), "failed": ("failure", "parent_failure")}
                ok = wanted[goal.functor] is None or other.outcome in wanted[goal.functor]
                return one(bindings if ok else None)
            return None

        return builtin
