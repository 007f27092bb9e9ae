"""A brute-force evaluator of ELE patterns over a finite set of events: the declarative
semantics, by enumerating every combination. Slow and obviously right; the tests compare
the compiled EDBC rules against it.

Events are (term, start, end) with ground terms from `retalisc.frontend.terms`. A match is
(bindings, start, end) with bindings a dict from variable names to terms.
"""
from __future__ import annotations

from collections import Counter
from typing import Dict, List, Optional, Tuple

from retalisc.frontend.program import Absence, Binary, EventAtom, Negation, Pattern, Where, Window
from retalisc.frontend.terms import Atom, Compound, Number, Term, Var

Match = Tuple[Dict[str, Term], float, float]

RELATIONS = {
    "seq": lambda s1, e1, s2, e2: e1 < s2,
    "and": lambda s1, e1, s2, e2: True,
    "par": lambda s1, e1, s2, e2: s1 < e2 and s2 < e1,
    "equals": lambda s1, e1, s2, e2: s1 == s2 and e1 == e2,
    "meets": lambda s1, e1, s2, e2: e1 == s2,
    "during": lambda s1, e1, s2, e2: s2 < s1 and e1 < e2,
    "starts": lambda s1, e1, s2, e2: s1 == s2 and e1 < e2,
    "finishes": lambda s1, e1, s2, e2: e1 == e2 and s2 < s1,
}
INTERVALS = {
    "seq": lambda s1, e1, s2, e2: (s1, e2),
    "and": lambda s1, e1, s2, e2: (min(s1, s2), max(e1, e2)),
    "par": lambda s1, e1, s2, e2: (min(s1, s2), max(e1, e2)),
    "equals": lambda s1, e1, s2, e2: (s1, e1),
    "meets": lambda s1, e1, s2, e2: (s1, e2),
    "during": lambda s1, e1, s2, e2: (s2, e2),
    "starts": lambda s1, e1, s2, e2: (s1, e2),
    "finishes": lambda s1, e1, s2, e2: (s2, e1),
}


def unify(pattern: Term, term: Term, bindings: Dict[str, Term]) -> Optional[Dict[str, Term]]:
    if isinstance(pattern, Var):
        if pattern.is_anonymous:
            return bindings
        if pattern.name in bindings:
            return bindings if bindings[pattern.name] == term else None
        result = dict(bindings)
        result[pattern.name] = term
        return result
    if isinstance(pattern, Compound):
        if not (isinstance(term, Compound) and term.name == pattern.name and term.arity == pattern.arity):
            return None
        for p, t in zip(pattern.args, term.args):
            bindings = unify(p, t, bindings)
            if bindings is None:
                return None
        return bindings
    return bindings if pattern == term else None


def merge(a: Dict[str, Term], b: Dict[str, Term]) -> Optional[Dict[str, Term]]:
    result = dict(a)
    for k, v in b.items():
        if k in result and result[k] != v:
            return None
        result[k] = v
    return result


def value(term: Term, bindings: Dict[str, Term]):
    if isinstance(term, Var):
        return value(bindings[term.name], bindings)
    if isinstance(term, Number):
        return term.value
    if isinstance(term, Compound) and term.arity == 2 and term.name in "+-*":
        a, b = value(term.args[0], bindings), value(term.args[1], bindings)
        return {"+": a + b, "-": a - b, "*": a * b}[term.name]
    raise ValueError(term)


def holds(condition: Term, bindings: Dict[str, Term]) -> bool:
    if isinstance(condition, Compound) and condition.name == "," and condition.arity == 2:
        return holds(condition.args[0], bindings) and holds(condition.args[1], bindings)
    ops = {"<": lambda a, b: a < b, ">": lambda a, b: a > b, "=<": lambda a, b: a <= b,
           ">=": lambda a, b: a >= b, "=:=": lambda a, b: a == b, "=\\=": lambda a, b: a != b}
    if isinstance(condition, Compound) and condition.name in ops:
        return ops[condition.name](value(condition.args[0], bindings), value(condition.args[1], bindings))
    if condition == Atom("true"):
        return True
    raise ValueError(condition)


def matches(pattern: Pattern, events: List[tuple], window: float = float("inf")) -> List[Match]:
    """Every match of `pattern`; `window` is the tightest window around it (under a window,
    `A fnot B` only looks back that far for B)."""
    if isinstance(pattern, EventAtom):
        found = []
        for term, start, end in events:
            b = unify(pattern.term, term, {})
            if b is not None:
                found.append((b, start, end))
        return found
    if isinstance(pattern, Where):
        return [m for m in matches(pattern.pattern, events, window) if holds(pattern.condition, m[0])]
    if isinstance(pattern, Window):
        inner = min(window, pattern.length)
        return [m for m in matches(pattern.pattern, events, inner) if m[2] - m[1] <= pattern.length]
    if isinstance(pattern, Binary) and pattern.op == "or":
        return matches(pattern.left, events, window) + matches(pattern.right, events, window)
    if isinstance(pattern, Binary) and pattern.op == "fnot":
        blockers = matches(pattern.right, events, window)
        return [(b, s, e) for b, s, e in matches(pattern.left, events, window)
                if not any(merge(b, nb) is not None and ne < s and e - ns <= window for nb, ns, ne in blockers)]
    if isinstance(pattern, Binary):
        found = []
        for b1, s1, e1 in matches(pattern.left, events, window):
            for b2, s2, e2 in matches(pattern.right, events, window):
                b = merge(b1, b2)
                if b is not None and RELATIONS[pattern.op](s1, e1, s2, e2):
                    found.append((b, *INTERVALS[pattern.op](s1, e1, s2, e2)))
        return found
    if isinstance(pattern, Negation):
        blockers = matches(pattern.negated, events, window)
        found = []
        for b1, s1, e1 in matches(pattern.first, events, window):
            for b2, s2, e2 in matches(pattern.second, events, window):
                b = merge(b1, b2)
                if b is None or not e1 < s2:
                    continue
                if any(merge(b, nb) is not None and e1 < ns and ne < s2 for nb, ns, ne in blockers):
                    continue
                found.append((b, s1, e2))
        return found
    if isinstance(pattern, Absence):
        # no blocker starting after L's end and ending by L's end + D; the result spans
        # [L's start, L's end + D] (every absence decided: the clock passed them all)
        blockers = matches(pattern.negated, events, window)
        found = []
        for b, s, e in matches(pattern.first, events, window):
            close = e + pattern.duration
            if any(merge(b, nb) is not None and e < ns and ne <= close for nb, ns, ne in blockers):
                continue
            found.append((b, s, close))
        return found
    raise TypeError(pattern)


def substitute_ground(term: Term, bindings: Dict[str, Term]) -> Term:
    if isinstance(term, Var):
        return bindings[term.name]
    if isinstance(term, Compound):
        return Compound(term.name, tuple(substitute_ground(a, bindings) for a in term.args))
    return term


def net_output(outputs) -> Counter:
    """The engine's output as a multiset of `event@start-end`: additions minus retractions.
    Negation derives eagerly and takes back, so only the net result is order-independent."""
    result = Counter()
    for o in outputs:
        result[f"{o.event}@{o.start}-{o.end}"] += 1 if o.op == "add" else -1
    return +result if all(v >= 0 for v in result.values()) else result
