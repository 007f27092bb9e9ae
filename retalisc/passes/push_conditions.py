"""push_conditions: check a where-condition as early as its variables allow.

ETALIS evaluates a rule's `where` after the whole pattern has matched, so a selective
condition on one event (`a(I, X) seq b(I, Y) where Y < K`) still stores and joins every `b`
(thesis 3.5). Here each conjunct of a `where` whose variables all occur in one event atom of
the pattern is moved onto that atom, and checked when the event arrives. A conjunct that needs
several atoms is moved onto the smallest part of the pattern that binds all its variables
(`Y < X` onto `a(X) seq b(Y)` in `a(X) seq b(Y) seq c(Z) where Y < X`), and checked when that
part matches. Besides saving work, this gives conditions one meaning under the consumption
policies: a candidate that fails a condition is not chosen and consumes nothing, wherever the
condition stands and whatever form it has (`Y < 3` and `Y < 3 + 0*X` mean the same).

Only conjuncts whose answer cannot depend on when they run are moved: arithmetic
comparisons, unification and type tests, and calls of static predicates of the program.
Atoms inside `or` branches and negated patterns are left alone.
"""
from __future__ import annotations

from dataclasses import replace
from typing import List, Optional, Set

from ..frontend.program import Binary, EventAtom, Pattern, Where, Window, walk_pattern
from ..frontend.terms import Term, conjunction, conjuncts, indicator, variables
from .unit import Unit

name = "push_conditions"

_PURE_BUILTINS = {
    ("<", 2), (">", 2), ("=<", 2), (">=", 2), ("=:=", 2), ("=\\=", 2), ("==", 2), ("\\==", 2),
    ("=", 2), ("\\=", 2), ("@<", 2), ("@>", 2), ("@=<", 2), ("@>=", 2), ("is", 2),
    ("atom", 1), ("number", 1), ("integer", 1), ("float", 1), ("atomic", 1), ("compound", 1),
    ("is_list", 1), ("string", 1), ("ground", 1), ("between", 3), ("member", 2), ("memberchk", 2),
}


def run(unit: Unit) -> Unit:
    static = {indicator(c.head) for c in unit.program.static_clauses}
    clauses = []
    for clause in unit.program.clauses:
        if hasattr(clause, "pattern"):
            clause = replace(clause, pattern=_push(clause.pattern, static))
        clauses.append(clause)
    unit.program = replace(unit.program, clauses=clauses)
    return unit


def _push(pattern: Pattern, static: Set) -> Pattern:
    if isinstance(pattern, Where):
        inner = _push(pattern.pattern, static)
        kept: List[Term] = []
        for conjunct in conjuncts(pattern.condition):
            target = _single_atom_for(conjunct, inner, static) or _smallest_part_for(conjunct, inner, static)
            if target is None:
                kept.append(conjunct)
            else:
                inner = _attach(inner, target, conjunct)
        if not kept:
            return inner
        return Where(inner, conjunction(kept), pattern.span)
    if isinstance(pattern, Binary) and pattern.op != "or":
        return replace(pattern, left=_push(pattern.left, static), right=_push(pattern.right, static))
    if isinstance(pattern, Window):
        return replace(pattern, pattern=_push(pattern.pattern, static))
    return pattern


def _movable_variables(conjunct: Term, static: Set) -> Set[str]:
    """The variables of `conjunct` if it may be checked early (empty when it may not)."""
    key = indicator(conjunct)
    if key is None or not (key in _PURE_BUILTINS or key in static):
        return set()
    return {v.name for v in variables(conjunct)}


def _single_atom_for(conjunct: Term, pattern: Pattern, static: Set) -> Optional[EventAtom]:
    needed = _movable_variables(conjunct, static)
    if not needed:
        return None
    for atom in _reachable_atoms(pattern):
        if needed <= _atom_variables(atom):
            return atom
    return None


def _smallest_part_for(conjunct: Term, pattern: Pattern, static: Set) -> Optional[Binary]:
    """The smallest binary part of `pattern` (not `pattern` itself, not inside or / negation)
    whose every match binds all the variables of `conjunct`."""
    needed = _movable_variables(conjunct, static)
    if not needed:
        return None

    def into(p: Pattern) -> bool:
        return (isinstance(p, Binary) and p.op not in ("or", "fnot")) or isinstance(p, (Where, Window))

    best, best_size = None, None
    for part in walk_pattern(pattern, into):
        if part is pattern or not isinstance(part, Binary) or part.op in ("or", "fnot"):
            continue
        atoms = list(_reachable_atoms(part))
        bound = set().union(*(_atom_variables(a) for a in atoms)) if atoms else set()
        if needed <= bound and (best_size is None or len(atoms) < best_size):
            best, best_size = part, len(atoms)
    return best


def _reachable_atoms(pattern: Pattern):
    """Event atoms every match of `pattern` contains (not inside or / negation)."""
    def into(p: Pattern) -> bool:
        return (isinstance(p, Binary) and p.op not in ("or", "fnot")) or isinstance(p, (Where, Window))

    for p in walk_pattern(pattern, into):
        if isinstance(p, EventAtom):
            yield p


def _atom_variables(atom: EventAtom) -> Set[str]:
    names = {v.name for v in variables(atom.term)}
    for t in (atom.start, atom.end):
        if t is not None:
            names.update(v.name for v in variables(t))
    return names


def _attach(pattern: Pattern, target: Pattern, conjunct: Term) -> Pattern:
    if pattern is target:
        return Where(target, conjunct, target.span)
    if isinstance(pattern, Where) and pattern.pattern is target:
        return Where(target, conjunction(list(conjuncts(pattern.condition)) + [conjunct]), pattern.span)
    if isinstance(pattern, Binary):
        return replace(pattern, left=_attach(pattern.left, target, conjunct),
                       right=_attach(pattern.right, target, conjunct))
    if isinstance(pattern, (Where, Window)):
        return replace(pattern, pattern=_attach(pattern.pattern, target, conjunct))
    return pattern
