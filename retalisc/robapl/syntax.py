"""RobAPL agent files (`.apl`): the lark grammar `robapl.lark`, turned into the plain dataclasses
of an agent, with errors located as `file:line:col: message` (retalisc/frontend/errors.py)."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Tuple

from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import VisitError, UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from ..frontend.errors import RetalisSemanticError, RetalisSyntaxError
from ..frontend.terms import Span
from .terms import Atom, Compound, Literal, Query, Term, Var, show, show_query

_LARK = Lark((Path(__file__).with_name("robapl.lark")).read_text(), start="agent", parser="lalr",
             propagate_positions=True, maybe_placeholders=False)

#: Parent kinds: `list` and the wind-down lists, run when their parent pauses, resumes, fails or is
#: pre-empted (thesis 7.2.3).
WIND_DOWN_KINDS = ("on_pause", "on_resume", "on_abort", "on_preempt")
PARENT_KINDS = ("list",) + WIND_DOWN_KINDS
#: Child kinds and whether their `: term` is required (the action, the update, the query, the event).
CHILD_KINDS = {"external": True, "belief_update": False, "goal_update": True, "test": True, "abstract": True}
CONDITIONS = ("start", "end", "invariant", "pre", "post", "preempt", "pause", "resume", "repeat")
#: Conditions checked once, when the node starts or ends an iteration (thesis 7.2.2); the others are
#: monitored while they can make a transition.
CHECKED_ONCE = ("pre", "post", "repeat")


@dataclass(frozen=True)
class ResourceUsage:
    name: str
    usage: str          # blocking | using | adding
    amount: float
    span: Optional[Span] = None

    def __str__(self) -> str:
        return f"<{self.name}, {self.usage}, {self.amount:g}>"


@dataclass
class NodeSpec:
    """A node of a plan as written: its kind, name, term, attributes and children."""
    kind: str
    name: str
    term: Optional[Term] = None
    conditions: Dict[str, Query] = field(default_factory=dict)
    #: the conditions written as event patterns: name -> (derived event, ELE pattern text, span)
    patterns: Dict[str, Tuple[Term, str, Optional[Span]]] = field(default_factory=dict)
    #: the conditions marked `?`: answered by active queries of the agent's IEC (conditions_aq.py)
    active_queries: Tuple[str, ...] = ()
    priority: Optional[int] = None
    resources: Tuple[ResourceUsage, ...] = ()
    result: Optional[str] = None
    children: List["NodeSpec"] = field(default_factory=list)
    span: Optional[Span] = None


@dataclass
class PlanRule:
    """`Event <- BeliefQuery | Plan` (2APL style, thesis 7.3)."""
    event: Term
    guard: Query
    plan: NodeSpec
    span: Optional[Span] = None

    def __str__(self) -> str:
        return f"{show(self.event)} <- {show_query(self.guard) or 'true'} | {self.plan.name}"


@dataclass
class Agent:
    name: str
    beliefs: List[Tuple[Term, Query]] = field(default_factory=list)
    goals: List[Term] = field(default_factory=list)
    pool: Dict[str, float] = field(default_factory=dict)
    rules: List[PlanRule] = field(default_factory=list)
    file: str = "<agent>"


def _span(meta, file: str) -> Optional[Span]:
    if meta is None or getattr(meta, "empty", True):
        return None
    return Span(file, meta.line, meta.column)


class _Build(Transformer):
    def __init__(self, file: str):
        super().__init__()
        self.file = file

    def number(self, items):
        text = str(items[0])
        return float(text) if any(c in text for c in ".eE") else int(text)

    def compound(self, items):
        return Compound(str(items[0]), tuple(items[1:]))

    def atom(self, items):
        return Atom(str(items[0]))

    def variable(self, items):
        return Var(str(items[0]))

    def string(self, items):
        import re
        return re.sub(r"\\(.)", r"\1", str(items[0])[1:-1])

    def term(self, items):
        return items[0]

    def positive(self, items):
        return Literal("positive", items[0])

    def negative(self, items):
        return Literal("negative", items[0])

    def compare(self, items):
        return Literal("compare", items[0], str(items[1]), items[2])

    def query(self, items):
        return tuple(items)

    def fact(self, items):
        return ("clause", items[0], ())

    def belief_rule(self, items):
        return ("clause", items[0], items[1])

    def beliefs(self, items):
        return ("beliefs", items)

    def goal(self, items):
        return items[0]

    def goals(self, items):
        return ("goals", items)

    @v_args(meta=True)
    def pool_item(self, meta, items):
        return (str(items[0]), items[1], _span(meta, self.file))

    def resources(self, items):
        return ("resources", items)

    @v_args(meta=True)
    def usage(self, meta, items):
        return ResourceUsage(str(items[0]), str(items[1]), items[2], _span(meta, self.file))

    @v_args(meta=True)
    def condition(self, meta, items):
        return ("condition", str(items[0]), items[1], _span(meta, self.file))

    @v_args(meta=True)
    def pattern_condition(self, meta, items):
        # `start: visitor(P) <- {PATTERN}`: the condition is the IEC's derived event(visitor(P))
        name, event, pattern = str(items[0]), items[1], str(items[3])[1:-1].strip()
        span = _span(meta, self.file)
        return ("condition", name, (Literal("positive", Compound("event", (event,))),), span, (event, pattern, span))

    @v_args(meta=True)
    def aq_condition(self, meta, items):
        return ("condition", str(items[0]), items[1], _span(meta, self.file), None, "aq")

    def priority(self, items):
        return ("priority", int(items[0]))

    def resource_usages(self, items):
        return ("resources", tuple(items))

    def result(self, items):
        return ("result", str(items[0]))

    def attributes(self, items):
        return ("attributes", items)

    def children(self, items):
        return ("children", items)

    @v_args(meta=True)
    def node(self, meta, items):
        node = NodeSpec(kind=str(items[0]), name=str(items[1]), span=_span(meta, self.file))
        for item in items[2:]:
            if isinstance(item, tuple) and item and item[0] == "attributes":
                for attribute in item[1]:
                    if attribute[0] == "condition":
                        if attribute[1] in node.conditions:
                            raise RetalisSemanticError(f"node {node.name}: the {attribute[1]} condition is given twice",
                                                       attribute[3])
                        node.conditions[attribute[1]] = attribute[2]
                        if len(attribute) > 5:
                            node.active_queries += (attribute[1],)
                        elif len(attribute) > 4:
                            node.patterns[attribute[1]] = attribute[4]
                    elif attribute[0] == "priority":
                        node.priority = attribute[1]
                    elif attribute[0] == "resources":
                        node.resources = node.resources + attribute[1]
                    elif attribute[0] == "result":
                        node.result = attribute[1]
            elif isinstance(item, tuple) and item and item[0] == "children":
                node.children = item[1]
            else:
                node.term = item
        return node

    @v_args(meta=True)
    def rule(self, meta, items):
        items = [item for item in items if not isinstance(item, Token)]
        return ("rule", PlanRule(items[0], items[1], items[2], _span(meta, self.file)))

    def rules(self, items):
        return ("rules", [rule for _, rule in items])

    def agent_name(self, items):
        return ("name", str(items[0]))


def parse_agent(text: str, file: str = "<agent>") -> Agent:
    """The agent of `text`; raises RetalisSyntaxError / RetalisSemanticError with the place."""
    try:
        tree = _LARK.parse(text)
    except UnexpectedInput as exc:
        raise _located(exc, text, file) from None
    try:
        items = _Build(file).transform(tree)
    except VisitError as exc:
        if isinstance(exc.orig_exc, RetalisSemanticError):
            raise exc.orig_exc from None
        raise
    children = items.children if isinstance(items, Tree) else [items]
    agent = Agent(name=Path(file).stem, file=file)
    for kind, value in (c for c in children if isinstance(c, tuple)):
        if kind == "name":
            agent.name = value
        elif kind == "beliefs":
            agent.beliefs.extend((head, body) for _, head, body in value)
        elif kind == "goals":
            agent.goals.extend(value)
        elif kind == "resources":
            for name, amount, span in value:
                if name in agent.pool:
                    raise RetalisSemanticError(f"resource {name} is declared twice", span)
                agent.pool[name] = amount
        elif kind == "rules":
            agent.rules.extend(value)
    for rule in agent.rules:
        _check_plan(rule, agent)
    return agent


def load_agent(path) -> Agent:
    path = Path(path)
    return parse_agent(path.read_text(encoding="utf-8"), str(path))


def _check_plan(rule: PlanRule, agent: Agent) -> None:
    if rule.plan.kind != "list":
        raise RetalisSemanticError(f"the root of a plan is a list node, not {rule.plan.kind}", rule.plan.span)
    stack = [(rule.plan, None)]
    while stack:
        node, parent = stack.pop()
        if node.kind in CHILD_KINDS:
            if node.children:
                raise RetalisSemanticError(f"{node.kind} node {node.name} has no children", node.span)
            if CHILD_KINDS[node.kind] and node.term is None:
                raise RetalisSemanticError(f"{node.kind} node {node.name} needs a term: {node.kind} {node.name}: ...",
                                           node.span)
        if node.kind == "goal_update" and not (isinstance(node.term, Compound) and node.term.functor in ("adopt", "drop")
                                               and len(node.term.args) == 1):
            raise RetalisSemanticError(f"goal_update node {node.name}: the term is adopt(Goal) or drop(Goal)",
                                       node.span)
        if node.kind in WIND_DOWN_KINDS and (parent is None or parent.kind != "list"):
            raise RetalisSemanticError(f"{node.kind} node {node.name} is a child of a list node", node.span)
        if node.kind == "belief_update" and "post" not in node.conditions:
            raise RetalisSemanticError(f"belief_update node {node.name} needs a post condition (what it makes true)",
                                       node.span)
        if node.result is not None and node.kind != "external":
            raise RetalisSemanticError(f"only external nodes have a result (node {node.name})", node.span)
        for usage in node.resources:
            if usage.name not in agent.pool:
                raise RetalisSemanticError(f"node {node.name} uses resource {usage.name}, not in the resources section",
                                           usage.span)
            if usage.usage != "adding" and usage.amount > agent.pool[usage.name]:
                raise RetalisSemanticError(f"node {node.name} needs {usage.amount:g} of {usage.name}; "
                                           f"the pool has {agent.pool[usage.name]:g}", usage.span)
        names = set()
        for child in node.children:
            if child.name in names:
                raise RetalisSemanticError(f"two children of {node.name} are named {child.name}", child.span)
            names.add(child.name)
            stack.append((child, node))


def _located(exc: UnexpectedInput, text: str, file: str) -> RetalisSyntaxError:
    span = Span(file, getattr(exc, "line", 1) or 1, getattr(exc, "column", 1) or 1)
    if isinstance(exc, UnexpectedEOF):
        return RetalisSyntaxError("unexpected end of file", span)
    if isinstance(exc, UnexpectedToken):
        token: Token = exc.token
        expected = sorted(_readable(name) for name in exc.expected)[:6]
        shown = "end of file" if token.type == "$END" else repr(str(token))
        return RetalisSyntaxError(f"unexpected {shown}; expected {', '.join(expected)}", span)
    if isinstance(exc, UnexpectedCharacters):
        return RetalisSyntaxError(f"unexpected character {text[exc.pos_in_stream]!r}", span)
    return RetalisSyntaxError(str(exc).splitlines()[0], span)


_NAMES = {"LPAR": "'('", "RPAR": "')'", "LSQB": "'['", "RSQB": "']'", "LBRACE": "'{'", "RBRACE": "'}'",
          "COMMA": "','", "DOT": "'.'", "COLON": "':'", "SEMICOLON": "';'", "ARROW": "'<-'", "VBAR": "'|'", "LESSTHAN": "'<'",
          "MORETHAN": "'>'", "NAME": "a name", "VAR": "a variable", "KIND": "a node kind", "CONDITION": "a condition",
          "STRING": "a string", "NUMBER": "a number", "SIGNED_INT": "an integer", "USAGE": "blocking|using|adding"}


def _readable(terminal: str) -> str:
    return _NAMES.get(terminal, terminal.lower().replace("__anon_", "").strip("_"))
