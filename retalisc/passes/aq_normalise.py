"""aq_normalise: rewrite disjunction, if-then-else and negation of compound goals in rule bodies
into plain clauses, before the active-query transformation (XSB-style tabled programs).

- `(A ; B)` becomes one clause per alternative (the bodies are multiplied out, in order);
- `(C -> T ; E)` and `(C *-> T ; E)` become `C, T` and `\\+ C, E`; `(C -> T)` becomes `C, T`.
  The condition is read declaratively: every solution of C is used, where Prolog's `->`
  commits to the first one (the two agree when C has at most one solution, as a test usually
  has);
- `not(G)` and `tnot(G)` become `\\+ G`;
- `\\+ G` with G a conjunction, a disjunction or an if-then-else becomes `\\+ '$not_k_n'(Vs)`
  with a new rule `'$not_k_n'(Vs) :- G` (normalised in turn), Vs being the variables of G that
  also occur elsewhere in the clause;
- `true` is dropped.

What is left is a list of literals per clause, each a goal or `\\+ Goal`; the `aq_program` pass
then checks them (and the stratification of the negations).
"""
from __future__ import annotations

from typing import List

from ..frontend.definite import Literal, Program, Rule, program_error
from ..frontend.terms import Atom, Compound, Term, Var, variables
from .unit import AqUnit

name = "aq_normalise"

#: A body whose alternatives multiply out to more clauses than this is refused.
MAX_ALTERNATIVES = 256

_CONTROL = {(",", 2), (";", 2), ("->", 2), ("*->", 2)}


def _is(term: Term, name_: str, arity: int) -> bool:
    return isinstance(term, Compound) and term.name == name_ and term.arity == arity


def _negated_goal(term: Term):
    """G for `\\+ G`, `not(G)` and `tnot(G)`; None otherwise."""
    if isinstance(term, Compound) and term.arity == 1 and term.name in ("\\+", "not", "tnot"):
        return term.args[0]
    return None


class _Normaliser:
    def __init__(self, program: Program):
        self.program = program
        self.aux_count = 0
        self.pending: List[Rule] = []   # auxiliary rules still to normalise

    def alternatives(self, goal: Term, rule: Rule, outside: set) -> List[List[Term]]:
        """The disjunctive normal form of `goal`: a list of alternative conjunctions."""
        if _is(goal, ",", 2):
            a, b = goal.args
            left = self.alternatives(a, rule, outside | {v.name for v in variables(b)})
            right = self.alternatives(b, rule, outside | {v.name for v in variables(a)})
            return self._product(left, right, goal, rule)
        if _is(goal, ";", 2):
            first, second = goal.args
            if _is(first, "->", 2) or _is(first, "*->", 2):
                cond, then = first.args
                yes = self.alternatives(Compound(",", (cond, then)), rule, outside)
                negated = Compound("\\+", (cond,), getattr(cond, "span", None))
                no = self.alternatives(Compound(",", (negated, second)), rule, outside)
                return self._limit(yes + no, goal, rule)
            return self._limit(self.alternatives(first, rule, outside) + self.alternatives(second, rule, outside),
                               goal, rule)
        if _is(goal, "->", 2) or _is(goal, "*->", 2):
            return self.alternatives(Compound(",", goal.args), rule, outside)
        if isinstance(goal, Atom) and goal.name == "true":
            return [[]]
        inner = _negated_goal(goal)
        if inner is not None:
            if isinstance(inner, Compound) and (inner.name, inner.arity) in _CONTROL or _negated_goal(inner) is not None:
                inner = self.auxiliary(inner, rule, outside)
            return [[Compound("\\+", (inner,), getattr(goal, "span", None))]]
        return [[goal]]

    def _product(self, left, right, goal, rule):
        if len(left) * len(right) > MAX_ALTERNATIVES:
            raise program_error(f"this body has more than {MAX_ALTERNATIVES} alternatives once its "
                                f"disjunctions are multiplied out: name parts of it with rules", goal, rule.span)
        return [a + b for a in left for b in right]

    def _limit(self, alts, goal, rule):
        if len(alts) > MAX_ALTERNATIVES:
            raise program_error(f"this body has more than {MAX_ALTERNATIVES} alternatives: name parts of it "
                                f"with rules", goal, rule.span)
        return alts

    def auxiliary(self, goal: Term, rule: Rule, outside: set) -> Term:
        """A new predicate for a negated compound goal: `'$not_k_n'(Vs) :- goal`."""
        self.aux_count += 1
        shared = []
        for v in variables(goal):
            if not v.is_anonymous and v.name in outside and v.name not in shared:
                shared.append(v.name)
        head_name = f"$not_{rule.indicator[0]}_{self.aux_count}"
        head: Term = Compound(head_name, tuple(Var(n) for n in shared)) if shared else Atom(head_name)
        self.pending.append(Rule(0, head, [Literal(goal)], rule.span, rule.text))
        return head

    def clauses(self, rule: Rule) -> List[Rule]:
        """The clauses of `rule` once its body is in disjunctive normal form."""
        goals = [lit.term for lit in rule.body]
        out: List[List[Term]] = [[]]
        for i, goal in enumerate(goals):
            others = [rule.head] + goals[:i] + goals[i + 1:]
            outside = {v.name for t in others for v in variables(t)}
            out = self._product(out, self.alternatives(goal, rule, outside), goal, rule)
        return [Rule(0, rule.head, [Literal(g) for g in alt] or [Literal(Atom("true"))], rule.span, rule.text,
                     rule.synthetic)
                for alt in out]


def normalise(program: Program) -> Program:
    norm = _Normaliser(program)
    rules: List[Rule] = []
    for rule in program.rules:
        rules.extend(norm.clauses(rule))
        while norm.pending:
            rules.extend(norm.clauses(norm.pending.pop(0)))
    for k, rule in enumerate(rules, 1):
        rule.index = k
    program.rules = rules
    return program


def run(unit: AqUnit) -> AqUnit:
    unit.program = normalise(unit.program)
    return unit
