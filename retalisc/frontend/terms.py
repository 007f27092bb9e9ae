"""Prolog terms as plain dataclasses.

Every node may carry a `Span` (where it came from in the source). Spans never take part
in equality or hashing, so two terms read from different places compare equal when they
are the same term.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Iterator, Optional, Union


@dataclass(frozen=True)
class Span:
    file: str
    line: int
    column: int
    end_line: int = 0
    end_column: int = 0

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


@dataclass(frozen=True)
class Var:
    name: str
    span: Optional[Span] = field(default=None, compare=False, repr=False)

    @property
    def is_anonymous(self) -> bool:
        return self.name == "_"


@dataclass(frozen=True)
class Atom:
    name: str
    span: Optional[Span] = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class Number:
    value: Union[int, float]
    span: Optional[Span] = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class String:
    """A double-quoted string (SWI-Prolog 7 reads it as a string object)."""

    text: str
    span: Optional[Span] = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class Compound:
    name: str
    args: tuple
    span: Optional[Span] = field(default=None, compare=False, repr=False)

    @property
    def arity(self) -> int:
        return len(self.args)


Term = Union[Var, Atom, Number, String, Compound]

NIL = Atom("[]")


def compound(name: str, *args: Term, span: Optional[Span] = None) -> Compound:
    return Compound(name, tuple(args), span)


def make_list(items, tail: Term = NIL) -> Term:
    result = tail
    for item in reversed(list(items)):
        result = Compound("[|]", (item, result))
    return result


def list_items(term: Term) -> Optional[list]:
    """The elements of a proper list, or None when `term` is not one."""
    items = []
    while isinstance(term, Compound) and term.name == "[|]" and term.arity == 2:
        items.append(term.args[0])
        term = term.args[1]
    if term == NIL:
        return items
    return None


def indicator(term: Term) -> Optional[tuple]:
    """(name, arity) of a callable term, None for variables and numbers."""
    if isinstance(term, Atom):
        return (term.name, 0)
    if isinstance(term, Compound):
        return (term.name, term.arity)
    return None


def span_of(term: Term) -> Optional[Span]:
    return getattr(term, "span", None)


def walk(term: Term) -> Iterator[Term]:
    """Every sub-term, depth first, the term itself first."""
    stack = [term]
    while stack:
        t = stack.pop()
        yield t
        if isinstance(t, Compound):
            stack.extend(reversed(t.args))


def variables(term: Term) -> list:
    """Named variables of `term` in order of first occurrence (anonymous `_` excluded)."""
    seen: dict = {}
    for t in walk(term):
        if isinstance(t, Var) and not t.is_anonymous and t.name not in seen:
            seen[t.name] = t
    return list(seen.values())


def distinct_variables(found) -> list:
    """The named variables among `found`, each once, in order, without spans."""
    seen, result = set(), []
    for v in found:
        if isinstance(v, Var) and not v.is_anonymous and v.name not in seen:
            seen.add(v.name)
            result.append(Var(v.name))
    return result


def is_ground(term: Term) -> bool:
    return not any(isinstance(t, Var) for t in walk(term))


def conjuncts(goal: Term) -> list:
    """The goals of a conjunction `(A, B, ...)`, in order."""
    goals = []
    while isinstance(goal, Compound) and goal.name == "," and goal.arity == 2:
        goals.append(goal.args[0])
        goal = goal.args[1]
    goals.append(goal)
    return goals


def conjunction(goals: list) -> Term:
    """`(G1, G2, ...)` from a non-empty list of goals."""
    result = goals[-1]
    for g in reversed(goals[:-1]):
        result = Compound(",", (g, result))
    return result


def substitute(term: Term, mapping: dict) -> Term:
    """Replace variables by name according to `mapping` (name -> term)."""
    if isinstance(term, Var):
        return mapping.get(term.name, term)
    if isinstance(term, Compound):
        return Compound(term.name, tuple(substitute(a, mapping) for a in term.args), term.span)
    return term


# ---------------------------------------------------------------------------------------
# Writing terms back as Prolog text (canonical enough to be read back by SWI-Prolog).

_SOLO_ATOMS = {"[]", "!", ";", "{}", ","}
_LETTER_ATOM = re.compile(r"^[a-z][A-Za-z0-9_]*$")
_SYMBOL_ATOM = re.compile(r"^[+\-*/\\^<>=~:.?@#&$]+$")


def quote_atom(name: str) -> str:
    if _LETTER_ATOM.match(name) or name in ("[]", "!", ";", "{}"):
        return name
    if _SYMBOL_ATOM.match(name) and name != "." and "/*" not in name:
        return name
    return "'" + _escape(name, "'") + "'"


_CONTROL_ESCAPES = {"\\": "\\\\", "\n": "\\n", "\t": "\\t"}


def _escape(text: str, quote: str) -> str:
    """`text` between `quote`s as SWI-Prolog reads it back: backslash, the quote and control
    characters escaped."""
    out = []
    for c in text:
        if c == quote:
            out.append("\\" + c)
        elif c in _CONTROL_ESCAPES:
            out.append(_CONTROL_ESCAPES[c])
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\x{ord(c):x}\\")
        else:
            out.append(c)
    return "".join(out)


def _quote_string(text: str) -> str:
    return '"' + _escape(text, '"') + '"'


def format_number(value) -> str:
    if isinstance(value, float):
        if value != value:
            return "1.5NaN"                 # SWI-Prolog's syntax for floats that are not finite
        if value in (float("inf"), float("-inf")):
            return "1.0Inf" if value > 0 else "-1.0Inf"
        text = repr(value)
        if "e" in text and "." not in text.split("e")[0]:
            mantissa, exponent = text.split("e")
            text = f"{mantissa}.0e{exponent}"
        return text
    return str(value)


def to_prolog(term: Term) -> str:
    """Write a term in canonical functional notation (operators written as functors, except
    lists and the few operators that keep generated code readable)."""
    if isinstance(term, Var):
        return term.name
    if isinstance(term, Atom):
        return quote_atom(term.name)
    if isinstance(term, Number):
        text = format_number(term.value)
        return f"({text})" if text.startswith("-") else text
    if isinstance(term, String):
        return _quote_string(term.text)
    items = []
    t: Term = term
    while isinstance(t, Compound) and t.name == "[|]" and t.arity == 2:
        items.append(t.args[0])
        t = t.args[1]
    if items:
        inner = ", ".join(to_prolog(i) for i in items)
        return f"[{inner}]" if t == NIL else f"[{inner}|{to_prolog(t)}]"
    if term.name == "{}" and term.arity == 1:
        return "{" + to_prolog(term.args[0]) + "}"
    args = ", ".join(to_prolog(a) for a in term.args)
    return f"{quote_atom(term.name)}({args})"
