"""Definite logic programs for active queries (thesis 6.2): the program model and its validation.

A program is a set of rules `H :- B1, ..., Bn` and facts.  Body literals are user predicates or
the builtins listed in `BUILTINS` (arithmetic comparison, `is`, unification and term
(in)equality).  Dynamic predicates are those with facts in the program or declared with
`:- dynamic p/N`.  Everything else that is not definite (negation, cut, if-then-else,
disjunction, meta-calls, side effects) is rejected with a `file:line:col` error.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Set, Tuple

from ..frontend.errors import RetalisSemanticError
from ..frontend.parser import read_program
from ..frontend.terms import Atom, Compound, Number, Span, Term, Var, indicator, list_items, span_of, variables

Indicator = Tuple[str, int]

#: Builtins allowed in rule bodies: evaluated in place, left to right, like Prolog does.
BUILTINS: Set[Indicator] = {
    ("<", 2), (">", 2), ("=<", 2), (">=", 2), ("=:=", 2), ("=\\=", 2),
    ("is", 2), ("=", 2), ("==", 2), ("\\==", 2), ("true", 0),
}

#: Constructs that make a program non-definite, with the reason given to the user.
_REJECTED: Dict[Indicator, str] = {
    ("\\+", 1): "negation (\\+) is not definite",
    ("not", 1): "negation (not/1) is not definite",
    ("!", 0): "cut (!) is not allowed in a definite program",
    (";", 2): "disjunction (;) is not allowed: write one rule per alternative",
    ("->", 2): "if-then-else (->) is not allowed in a definite program",
    ("*->", 2): "soft-cut (*->) is not allowed in a definite program",
    ("\\=", 2): "\\= is negation of unification and not definite",
    ("call", 1): "meta-calls are not allowed in a definite program",
    ("findall", 3): "findall/3 is not allowed in a definite program",
    ("forall", 2): "forall/2 is not allowed in a definite program",
    ("assert", 1): "side effects (assert) are not allowed in rules",
    ("assertz", 1): "side effects (assertz) are not allowed in rules",
    ("asserta", 1): "side effects (asserta) are not allowed in rules",
    ("retract", 1): "side effects (retract) are not allowed in rules",
    ("fail", 0): "fail/0 is not allowed (a rule that never holds can be deleted)",
}


@dataclass
class Literal:
    """One body literal; `kind` is filled in by the transformation passes:
    `builtin`, `fact` (resolved in place against the stored facts) or `call` (through a table)."""

    term: Term
    kind: str = "builtin"

    @property
    def indicator(self) -> Indicator:
        ind = indicator(self.term)
        assert ind is not None
        return ind


@dataclass
class Rule:
    index: int  # k: rules are numbered 1.. in source order
    head: Term
    body: List[Literal]
    span: Optional[Span] = None
    text: str = ""
    synthetic: bool = False  # `p(X..) :- <stored fact p(X..)>` added by a pass

    @property
    def indicator(self) -> Indicator:
        ind = indicator(self.head)
        assert ind is not None
        return ind


@dataclass
class Fact:
    term: Term
    span: Optional[Span] = None


@dataclass
class Program:
    file: str
    rules: List[Rule] = field(default_factory=list)
    facts: List[Fact] = field(default_factory=list)
    dynamic: List[Indicator] = field(default_factory=list)  # order of first mention
    # set by a transformation pass
    mode: str = ""
    subsumption: bool = False

    @property
    def rule_predicates(self) -> List[Indicator]:
        seen: Dict[Indicator, None] = {}
        for r in self.rules:
            if not r.synthetic:
                seen.setdefault(r.indicator)
        return list(seen)

    @property
    def fact_predicates(self) -> List[Indicator]:
        return list(self.dynamic)

    def rules_for(self, ind: Indicator) -> List[Rule]:
        return [r for r in self.rules if r.indicator == ind]

    def predicates(self) -> List[Indicator]:
        seen: Dict[Indicator, None] = {}
        for ind in self.rule_predicates + self.fact_predicates:
            seen.setdefault(ind)
        return list(seen)


def _conjuncts(term: Term) -> List[Term]:
    if isinstance(term, Compound) and term.name == "," and term.arity == 2:
        return _conjuncts(term.args[0]) + _conjuncts(term.args[1])
    return [term]


def _err(message: str, term: Term, fallback: Optional[Span]) -> RetalisSemanticError:
    return RetalisSemanticError(message, span_of(term) or fallback)


def _pred_spec(term: Term, span: Optional[Span]) -> List[Indicator]:
    """`p/1, q/2` or `[p/1, q/2]` in a dynamic declaration (an `as ...` suffix is ignored)."""
    if isinstance(term, Compound) and term.name == "as" and term.arity == 2:
        term = term.args[0]
    items = list_items(term)
    if items is not None:
        return [ind for item in items for ind in _pred_spec(item, span)]
    if isinstance(term, Compound) and term.name == "," and term.arity == 2:
        return _pred_spec(term.args[0], span) + _pred_spec(term.args[1], span)
    if (
        isinstance(term, Compound) and term.name == "/" and term.arity == 2
        and isinstance(term.args[0], Atom) and isinstance(term.args[1], Number)
        and isinstance(term.args[1].value, int)
    ):
        return [(term.args[0].name, term.args[1].value)]
    raise _err("expected a predicate indicator Name/Arity in the dynamic declaration", term, span)


def load_program(text: str, file: str) -> Program:
    """Read and validate a definite program (raises RetalisSyntaxError / RetalisSemanticError)."""
    program = Program(file=file)
    dynamic: Dict[Indicator, None] = {}
    pending_rules: List[Tuple[Term, List[Term], Span, str]] = []
    for clause in read_program(text, file):
        term, span = clause.term, clause.span
        if isinstance(term, Compound) and term.name == ":-" and term.arity == 1:
            directive = term.args[0]
            if isinstance(directive, Compound) and directive.name == "dynamic" and directive.arity == 1:
                for ind in _pred_spec(directive.args[0], span):
                    dynamic.setdefault(ind)
                continue
            if isinstance(directive, Compound) and directive.name in ("table", "discontiguous") and directive.arity == 1:
                continue  # meaningless here: every predicate is tabled by the transformation
            raise _err("only `:- dynamic` declarations are allowed in an active-query program", directive, span)
        if isinstance(term, Compound) and term.name == ":-" and term.arity == 2:
            head, body = term.args
            goals = [g for g in _conjuncts(body)]
        else:
            head, goals = term, []
        if isinstance(head, Var) or indicator(head) is None:
            raise _err("the head of a clause must be an atom or a compound term", head, span)
        hind = indicator(head)
        if hind in BUILTINS or hind in _REJECTED or hind in ((",", 2), (":-", 2), ("-->", 2)):
            raise _err(f"cannot define the builtin {hind[0]}/{hind[1]}", head, span)
        if not goals or goals == [Atom("true")]:
            program.facts.append(Fact(head, span))
            dynamic.setdefault(hind)
            continue
        pending_rules.append((head, goals, span, clause.text))
    program.dynamic = list(dynamic)
    rule_preds = {indicator(h) for h, _, _, _ in pending_rules}
    known = rule_preds | set(dynamic)
    for k, (head, goals, span, text) in enumerate(pending_rules, start=1):
        body = []
        for goal in goals:
            if isinstance(goal, Var):
                raise _err("a variable cannot be a goal (meta-call) in a definite program", goal, span)
            ind = indicator(goal)
            if ind is None:
                raise _err("a number cannot be a goal", goal, span)
            if ind in _REJECTED:
                raise _err(_REJECTED[ind], goal, span)
            if ind in BUILTINS:
                if ind != ("true", 0):
                    body.append(Literal(goal, "builtin"))
                continue
            if ind not in known:
                raise _err(
                    f"unknown predicate {ind[0]}/{ind[1]}: define it, give it facts or declare "
                    f"`:- dynamic {ind[0]}/{ind[1]}.`", goal, span)
            body.append(Literal(goal, "call" if ind in rule_preds else "fact"))
        program.rules.append(Rule(k, head, body, span, text.strip()))
    return program


def relevant_predicates(program: Program, goal_ind: Indicator) -> List[Indicator]:
    """Relevant predicate set (Def. 33): predicates SLD resolution could reach from `goal_ind`."""
    seen: Dict[Indicator, None] = {goal_ind: None}
    stack = [goal_ind]
    while stack:
        ind = stack.pop()
        for rule in program.rules_for(ind):
            for lit in rule.body:
                if lit.kind != "builtin" and lit.indicator not in seen:
                    seen[lit.indicator] = None
                    stack.append(lit.indicator)
    return list(seen)


def relevant_rules(program: Program, goal_ind: Indicator) -> List[Rule]:
    """Relevant rule set (Def. 30): the rules of the relevant predicates."""
    preds = set(relevant_predicates(program, goal_ind))
    return [r for r in program.rules if r.indicator in preds and not r.synthetic]


def term_vars(terms) -> List[str]:
    seen: Dict[str, None] = {}
    for t in terms:
        for v in variables(t):
            seen.setdefault(v.name)
    return list(seen)
