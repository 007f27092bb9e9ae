"""Terms of RobAPL beliefs, queries and events, and the resolution that answers queries on a
belief base (Horn clauses with negation as failure and arithmetic comparison).

Terms are plain Python values: `Atom`, `Var`, `Compound`, `str` (a string) and numbers. Events
arrive as data (JSON Lines parsed by `parse_event_term`); nothing arriving at run time is ever
run as code: a query only unifies and compares terms."""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Dict, Iterator, List, Optional, Tuple, Union


@dataclass(frozen=True)
class Atom:
    name: str

    def __str__(self) -> str:
        return self.name


@dataclass(frozen=True)
class Var:
    name: str

    def __str__(self) -> str:
        return self.name


@dataclass(frozen=True)
class Compound:
    functor: str
    args: Tuple["Term", ...]

    def __str__(self) -> str:
        return f"{self.functor}({','.join(show(a) for a in self.args)})"


Term = Union[Atom, Var, Compound, str, int, float]
Bindings = Dict[str, "Term"]


@dataclass(frozen=True)
class Literal:
    """One literal of a query: `term`, `not term`, or `left OP right` (OP a comparison)."""
    kind: str                  # "positive" | "negative" | "compare"
    term: Term
    operator: str = ""
    right: Term = None

    def __str__(self) -> str:
        if self.kind == "negative":
            return f"not {show(self.term)}"
        if self.kind == "compare":
            return f"{show(self.term)} {self.operator} {show(self.right)}"
        return show(self.term)


Query = Tuple[Literal, ...]


def show(term: Term) -> str:
    if isinstance(term, str):
        return '"' + term.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return str(term)


def show_query(query: Query) -> str:
    return ", ".join(str(literal) for literal in query)


def walk(term: Term, bindings: Bindings) -> Term:
    while isinstance(term, Var) and term.name in bindings:
        term = bindings[term.name]
    return term


def resolve(term: Term, bindings: Bindings) -> Term:
    """`term` with every bound variable replaced by its value."""
    term = walk(term, bindings)
    if isinstance(term, Compound):
        return Compound(term.functor, tuple(resolve(a, bindings) for a in term.args))
    return term


def unify(left: Term, right: Term, bindings: Bindings) -> Optional[Bindings]:
    """The bindings extended so that `left` and `right` are equal, or None."""
    left, right = walk(left, bindings), walk(right, bindings)
    if isinstance(left, Var):
        if isinstance(right, Var) and right.name == left.name:
            return bindings
        return {**bindings, left.name: right}
    if isinstance(right, Var):
        return {**bindings, right.name: left}
    if isinstance(left, Compound) and isinstance(right, Compound):
        if left.functor != right.functor or len(left.args) != len(right.args):
            return None
        for a, b in zip(left.args, right.args):
            bindings = unify(a, b, bindings)
            if bindings is None:
                return None
        return bindings
    if type(left) is not type(right) and not (_is_number(left) and _is_number(right)):
        return None
    return bindings if left == right else None


def _is_number(term: Term) -> bool:
    return isinstance(term, (int, float)) and not isinstance(term, bool)


def compare(operator: str, left: Term, right: Term, bindings: Bindings) -> Optional[Bindings]:
    if operator == "=":
        return unify(left, right, bindings)
    if operator == "\\=":
        return bindings if unify(left, right, bindings) is None else None
    a, b = resolve(left, bindings), resolve(right, bindings)
    if not (_is_number(a) and _is_number(b)):
        return None
    holds = {"<": a < b, ">": a > b, "=<": a <= b, ">=": a >= b}[operator]
    return bindings if holds else None


def rename(term: Term, suffix: str) -> Term:
    if isinstance(term, Var):
        return Var(term.name + suffix)
    if isinstance(term, Compound):
        return Compound(term.functor, tuple(rename(a, suffix) for a in term.args))
    return term


def rename_literal(literal: Literal, suffix: str) -> Literal:
    return Literal(literal.kind, rename(literal.term, suffix), literal.operator,
                   rename(literal.right, suffix) if literal.kind == "compare" else None)


def variables(term: Term) -> List[str]:
    found: List[str] = []
    stack = [term]
    while stack:
        item = stack.pop()
        if isinstance(item, Var) and item.name not in found:
            found.append(item.name)
        elif isinstance(item, Compound):
            stack.extend(reversed(item.args))
    return found


_TOKEN = re.compile(r'\s*(?:(?P<num>-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)|(?P<name>[a-z][A-Za-z0-9_]*)'
                    r'|(?P<str>"(?:[^"\\]|\\.)*")|(?P<qname>\'(?:[^\'\\]|\\.)*\')|(?P<punct>[(),]))')


class EventSyntaxError(ValueError):
    """An event that is not a ground term (the message says where)."""


def parse_event_term(text: str) -> Term:
    """A ground term from an event line: atoms, numbers, strings and compounds only (no
    variables, no operators)."""
    position = 0
    tokens: List[Tuple[str, str, int]] = []
    while position < len(text):
        if text[position:].strip() == "":
            break
        match = _TOKEN.match(text, position)
        if match is None:
            raise EventSyntaxError(f"unexpected character at column {position + 1} of the event term")
        kind = match.lastgroup
        tokens.append((kind, match.group(kind), match.start(kind)))
        position = match.end()
    index = 0

    def term() -> Term:
        nonlocal index
        if index >= len(tokens):
            raise EventSyntaxError("the event term ends early")
        kind, value, column = tokens[index]
        index += 1
        if kind == "num":
            return float(value) if any(c in value for c in ".eE") else int(value)
        if kind == "str":
            return re.sub(r"\\(.)", r"\1", value[1:-1])
        if kind == "qname":                    # a quoted atom ('greet#1/hello')
            kind, value = "name", re.sub(r"\\(.)", r"\1", value[1:-1])
        if kind != "name":
            raise EventSyntaxError(f"unexpected {value!r} at column {column + 1} of the event term")
        if index < len(tokens) and tokens[index][1] == "(":
            index += 1
            args = [term()]
            while index < len(tokens) and tokens[index][1] == ",":
                index += 1
                args.append(term())
            if index >= len(tokens) or tokens[index][1] != ")":
                raise EventSyntaxError(f"missing ')' after the arguments of {value}")
            index += 1
            return Compound(value, tuple(args))
        return Atom(value)

    result = term()
    if index != len(tokens):
        raise EventSyntaxError(f"unexpected {tokens[index][1]!r} at column {tokens[index][2] + 1} of the event term")
    return result


class BeliefBase:
    """Facts and rules (clauses `head :- body`), answered by depth-first resolution. Built-in
    literals (the node attributes, the current event) are answered by `builtins`, a function
    from a goal and bindings to the bindings it yields."""

    MAX_DEPTH = 200

    def __init__(self, clauses=()):
        self.clauses: Dict[Tuple[str, int], List[Tuple[Term, Query]]] = {}
        self._renames = 0
        for head, body in clauses:
            self.add(head, body)

    @staticmethod
    def key(term: Term) -> Tuple[str, int]:
        if isinstance(term, Compound):
            return term.functor, len(term.args)
        return (term.name if isinstance(term, Atom) else repr(term)), 0

    def add(self, head: Term, body: Query = ()) -> None:
        self.clauses.setdefault(self.key(head), []).append((head, tuple(body)))

    def remove(self, pattern: Term) -> int:
        """Removes the facts that unify with the ground or partial `pattern`; how many."""
        kept, removed = [], 0
        for head, body in self.clauses.get(self.key(pattern), []):
            if not body and unify(head, pattern, {}) is not None:
                removed += 1
            else:
                kept.append((head, body))
        if removed:
            self.clauses[self.key(pattern)] = kept
        return removed

    def facts(self) -> List[Term]:
        return [head for entries in self.clauses.values() for head, body in entries if not body]

    def solve(self, query: Query, bindings: Bindings, builtins=None, depth: int = 0) -> Iterator[Bindings]:
        if not query:
            yield bindings
            return
        if depth > self.MAX_DEPTH:
            return
        first, rest = query[0], query[1:]
        if first.kind == "compare":
            found = compare(first.operator, first.term, first.right, bindings)
            if found is not None:
                yield from self.solve(rest, found, builtins, depth)
            return
        if first.kind == "negative":
            positive = (Literal("positive", first.term),)
            if next(self.solve(positive, bindings, builtins, depth + 1), None) is None:
                yield from self.solve(rest, bindings, builtins, depth)
            return
        goal = walk(first.term, bindings)
        if isinstance(goal, Atom) and goal.name == "true":
            yield from self.solve(rest, bindings, builtins, depth)
            return
        if builtins is not None:
            answers = builtins(goal, bindings)
            if answers is not None:
                for found in answers:
                    yield from self.solve(rest, found, builtins, depth)
                return
        for head, body in list(self.clauses.get(self.key(goal), [])):
            if body:
                self._renames += 1
                suffix = f"#{self._renames}"
                head = rename(head, suffix)
                body = tuple(rename_literal(literal, suffix) for literal in body)
            found = unify(goal, head, bindings)
            if found is not None:
                yield from self.solve(body + rest, found, builtins, depth + 1)
