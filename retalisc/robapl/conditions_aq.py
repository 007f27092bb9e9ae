"""Monitored conditions as active queries (thesis 7.3.1, docs/robapl.md "Conditions as active
queries"): each start, end, invariant, pause, resume and pre-empt condition of a node is a rule
of a definite program whose knowledge base holds the agent's beliefs and the nodes' status
(`node_state(Plan, Name, State)`, `node_outcome/3`, `node_start/3`, `node_end/3`,
`node_result/3`), the goals, the time and the macro step's event; the condition of a node is
registered as an active query of that program (driver/active_queries.py), and its add/delete
notifications keep the answers the executor reads. The knowledge base is fed the differences
of the plan base as facts asserted and retracted; nothing is re-evaluated by resolution here.
Conditions with a built-in the knowledge base does not hold (`timeout/1`, `iteration/2`,
`resource_free/2`) and the checked-once ones are answered by resolution (`BeliefConditions`)."""
from __future__ import annotations

from typing import Dict, Iterator, List, Optional, Set, Tuple

from .conditions import BeliefConditions
from .iec import atom_text, event_text
from .terms import Atom, Bindings, Compound, Literal, Query, Term, Var, parse_event_term, resolve, unify, variables

MONITORED = ("start", "end", "invariant", "pause", "resume", "preempt")
_NOT_IN_KB = {("timeout", 1), ("iteration", 2), ("resource_free", 2)}
_PRELUDE = """\
:- dynamic node_state/3.
:- dynamic node_outcome/3.
:- dynamic node_start/3.
:- dynamic node_end/3.
:- dynamic node_result/3.
:- dynamic goal/1.
:- dynamic event/1.
:- dynamic now/1.
rq_succeeded(P, N) :- node_state(P, N, finished), node_outcome(P, N, success).
rq_failed(P, N) :- node_state(P, N, finished), node_outcome(P, N, failure).
rq_failed(P, N) :- node_state(P, N, finished), node_outcome(P, N, parent_failure).
"""


def _text(term: Term) -> str:
    if isinstance(term, Var):
        return term.name
    if isinstance(term, Compound):
        return f"{atom_text(term.functor)}({','.join(_text(a) for a in term.args)})"
    return event_text(term)


def _literal_text(literal: Literal, plan: str, me: str) -> Optional[str]:
    if literal.kind == "compare":
        return f"{_text(literal.term)} {literal.operator} {_text(literal.right)}"
    goal = literal.term
    key = (goal.functor, len(goal.args)) if isinstance(goal, Compound) else (getattr(goal, "name", ""), 0)
    if key in _NOT_IN_KB:
        return None
    args = [_text(a) for a in goal.args] if isinstance(goal, Compound) else []
    mapped = {("state", 2): lambda: f"node_state({plan}, {args[0]}, {args[1]})",
              ("outcome", 2): lambda: f"node_outcome({plan}, {args[0]}, {args[1]})",
              ("start_time", 2): lambda: f"node_start({plan}, {args[0]}, {args[1]})",
              ("end_time", 2): lambda: f"node_end({plan}, {args[0]}, {args[1]})",
              ("result", 2): lambda: f"node_result({plan}, {args[0]}, {args[1]})",
              ("finished", 1): lambda: f"node_state({plan}, {args[0]}, finished)",
              ("succeeded", 1): lambda: f"rq_succeeded({plan}, {args[0]})",
              ("failed", 1): lambda: f"rq_failed({plan}, {args[0]})",
              ("time", 1): lambda: f"now({args[0]})",
              ("done", 0): lambda: f"node_result({plan}, {me}, _)"}
    text = mapped[key]() if key in mapped else _text(goal)
    return f"\\+ {text}" if literal.kind == "negative" else text


class ActiveQueryConditions:
    """A `conditions.ConditionSource`: the monitored conditions of `agent` answered by active queries."""

    def __init__(self, agent, executor, mode: str = "tabled", only_marked: bool = False):
        from ..driver.active_queries import ActiveQueries

        self.view = executor
        self.resolver = BeliefConditions(executor.beliefs, executor)
        self.rules: Dict[Tuple[str, str], Tuple[str, List[str]]] = {}
        lines = [_PRELUDE]
        facts = {h for h, b in agent.beliefs if not b}
        for head, body in agent.beliefs:
            if body and any(_literal_text(lit, "P", "N") != (_text(lit.term) if lit.kind == "positive" else None)
                            for lit in body if lit.kind == "positive"):
                continue          # a rule with built-ins: its conditions go to the resolver
            if body:
                lines.append(f"{_text(head)} :- {', '.join(_literal_text(lit, 'P', 'N') for lit in body)}.")
        keys = {(h.functor, len(h.args)) if isinstance(h, Compound) else (h.name, 0) for h in facts}
        keys |= self._updated_keys(agent)
        lines += [f":- dynamic {atom_text(name)}/{arity}." for name, arity in sorted(keys)]
        for number, (spec, name, query) in enumerate(self._monitored(agent)):
            if only_marked and name not in spec.active_queries:
                continue
            body = [_literal_text(lit, "Plan", "Me") for lit in query]
            if None in body:
                continue
            head_vars = variables(Compound("v", tuple(t for lit in query for t in (lit.term, lit.right) if t is not None)))
            head_vars = [v for v in head_vars if v not in ("Plan", "Me")]
            predicate = f"rq_c{number}"
            lines.append(f"{predicate}({', '.join(['Plan', 'Me'] + head_vars)}) :- {', '.join(body)}.")
            self.rules[(id(spec), name)] = (predicate, head_vars)
        self.program = "\n".join(lines) + "\n"
        self.aq = ActiveQueries.from_source(self.program, f"{agent.file}.conditions.pl", mode)
        self.held: Dict[str, Set[str]] = {}
        self.aq.on_add(lambda qid, answer: self.held.setdefault(qid, set()).add(answer))
        self.aq.on_delete(lambda qid, answer: self.held.get(qid, set()).discard(answer))
        self._facts: Set[str] = set()
        self._version = None
        self._queries: Dict[Tuple, str] = {}

    @staticmethod
    def _monitored(agent):
        def specs(spec):
            yield spec
            for child in spec.children:
                yield from specs(child)
        for rule in agent.rules:
            for spec in specs(rule.plan):
                for name in MONITORED:
                    if name in spec.conditions:
                        yield spec, name, spec.conditions[name]

    @staticmethod
    def _updated_keys(agent) -> set:
        keys = set()
        for rule in agent.rules:
            stack = [rule.plan]
            while stack:
                spec = stack.pop()
                stack.extend(spec.children)
                if spec.kind == "belief_update":
                    for literal in spec.conditions.get("post", ()):
                        t = literal.term
                        keys.add((t.functor, len(t.args)) if isinstance(t, Compound) else (t.name, 0))
        return keys

    # ----- the knowledge base, fed the differences of the plan base
    def _kb_facts(self) -> Set[str]:
        view = self.view
        facts = {_text(f) for f in view.beliefs.facts()}
        facts |= {f"goal({_text(g)})" for g in view.goals()}
        facts.add(f"now({_text(view.now())})")
        if view.current_event() is not None:
            facts.add(f"event({_text(view.current_event())})")
        for plan in view.plans:
            seen = set()
            for node in plan.root.walk():
                if node.spec.name in seen:
                    continue           # a name means the first node of that name (find_node)
                seen.add(node.spec.name)
                p, n = atom_text(plan.name), atom_text(node.spec.name)
                facts.add(f"node_state({p}, {n}, {node.state})")
                for pred, value in (("node_outcome", node.outcome and Atom(node.outcome)),
                                    ("node_start", node.start_time), ("node_end", node.end_time)):
                    if value is not None:
                        facts.add(f"{pred}({p}, {n}, {_text(value)})")
                if node.result_ready and node.result is not None:
                    facts.add(f"node_result({p}, {n}, {_text(node.result)})")
        return facts

    def _sync(self) -> None:
        view = self.view
        version = (len(view.trace), id(view.current_event()), view.now())
        if version == self._version:
            return
        self._version = version
        facts = self._kb_facts()
        gone, new = sorted(self._facts - facts), sorted(facts - self._facts)
        if gone:
            self.aq.retract_facts(gone)
        if new:
            self.aq.assert_facts(new)
        self._facts = facts

    # ----- the ConditionSource interface
    def answers(self, node, name: str, query: Query, bindings: Bindings) -> Iterator[Bindings]:
        rule = self.rules.get((id(node.spec), name)) if node is not None else None
        if rule is None:
            yield from self.resolver.answers(node, name, query, bindings)
            return
        self._sync()
        predicate, head_vars = rule
        args = [Atom(node.plan.name), Atom(node.spec.name)] + [resolve(Var(v), bindings) for v in head_vars]
        goal = f"{predicate}({', '.join(_text(a) for a in args)})"
        qid = self._queries.get(goal)
        if qid is None:
            qid = self._queries[goal] = f"c{len(self._queries)}"
            self.held[qid] = set(self.aq.register(qid, goal))
        for answer in sorted(self.held.get(qid, ())):
            term = parse_event_term(answer)
            found = bindings
            for var, value in zip(head_vars, term.args[2:]):
                found = unify(Var(var), value, found) if found is not None else None
            if found is not None:
                yield found

    def first(self, node, name: str, query: Query, bindings: Bindings) -> Optional[Bindings]:
        return next(iter(self.answers(node, name, query, bindings)), None)
