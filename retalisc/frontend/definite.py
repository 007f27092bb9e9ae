"""Definite logic programs for active queries (thesis 6.2): the program model and its reader.

A program is a set of rules `H :- B1, ..., Bn` and facts.  Body literals are user predicates or
the builtins listed in `BUILTINS` (arithmetic comparison, `is`, unification and term
(in)equality).  Dynamic predicates are those with facts in the program or declared with
`:- dynamic p/N`.

`read_definite_program` sorts the clauses read by the parser into rules, facts and dynamic
declarations, and rejects what cannot be a clause of such a program (other directives, a
variable or number as head, a definition of a builtin).  What the rule bodies may contain is
checked by the `aq_program` pass, which also marks each body literal's `kind`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Set, Tuple

from .errors import RetalisSemanticError
from .operators import STANDARD_OPERATORS
from .parser import read_program
from .terms import Atom, Compound, Number, Span, Term, Var, indicator, list_items, span_of, to_prolog, variables

Indicator = Tuple[str, int]

#: Builtins allowed in rule bodies: evaluated where their arguments are bound (the aq_join_order
#: pass places them), like XSB does.
BUILTINS: Set[Indicator] = {
    ("<", 2), (">", 2), ("=<", 2), (">=", 2), ("=:=", 2), ("=\\=", 2),
    ("is", 2), ("=", 2), ("\\=", 2), ("==", 2), ("\\==", 2), ("true", 0),
}

#: Constructs that make a program non-definite, with the reason given to the user.
REJECTED: Dict[Indicator, str] = {
    ("\\+", 1): "negation (\\+) is not definite",
    ("not", 1): "negation (not/1) is not definite",
    ("!", 0): "cut (!) is not allowed in a definite program",
    (";", 2): "disjunction (;) is not allowed: write one rule per alternative",
    ("->", 2): "if-then-else (->) is not allowed in a definite program",
    ("*->", 2): "soft-cut (*->) is not allowed in a definite program",
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
    """One body literal; `kind` is filled in by the passes: `builtin`, `fact` (resolved in
    place against the stored facts) or `call` (through a table); empty as read."""

    term: Term
    kind: str = ""
    negated: bool = False  # `\+ term` over a user predicate (stratified negation)

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
    stratum: int = 0         # of the head predicate (set by aq_program: stratified negation)
    # (head variables, adornment masks) this body order is for (aq_join_order); None: every call
    guard: Optional[tuple] = None
    # the number of the written rule this body order was made from (aq_join_order: the rules
    # with one variant_of share one activation, which picks the order); 0: not a variant
    variant_of: int = 0

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
    notes: List[str] = field(default_factory=list)  # `file:line:col: note: ...` (ignored XSB directives)
    # set by the transformation pass (aq_naive, aq_optimized or aq_tabled)
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


def program_error(message: str, term: Term, fallback: Optional[Span]) -> RetalisSemanticError:
    """An error located at `term`, or at `fallback` (its clause) when the term has no span."""
    return RetalisSemanticError(message, span_of(term) or fallback)


#: XSB's module directives, read so that `:- import member/2 from basics.` parses (and is ignored).
XSB_OPERATORS = STANDARD_OPERATORS.copy()
for _name in ("import", "export", "local"):
    XSB_OPERATORS.add(1150, "fx", _name)
XSB_OPERATORS.add(1100, "xfx", "from")


def _as_modifier(term: Term) -> Optional[Term]:
    """The `as ...` part of an XSB/SWI declaration `p/2 as incremental`, anywhere in the spec."""
    if isinstance(term, Compound) and term.name == "as" and term.arity == 2:
        return term.args[1]
    if isinstance(term, Compound) and term.name in (",", "[|]", ".") and term.arity == 2:
        return _as_modifier(term.args[0]) or _as_modifier(term.args[1])
    return None


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
    raise program_error("expected a predicate indicator Name/Arity in the dynamic declaration", term, span)


def read_definite_program(text: str, file: str) -> Program:
    """Read a definite program: its rules (bodies not yet checked, see the `aq_program` pass),
    facts and dynamic predicates. Raises RetalisSyntaxError / RetalisSemanticError."""
    program = Program(file=file)
    dynamic: Dict[Indicator, None] = {}
    for clause in read_program(text, file, XSB_OPERATORS):
        term, span = clause.term, clause.span
        if isinstance(term, Compound) and term.name == ":-" and term.arity == 1:
            directive = term.args[0]
            if isinstance(directive, Compound) and directive.name == "dynamic" and directive.arity == 1:
                for ind in _pred_spec(directive.args[0], span):
                    dynamic.setdefault(ind)
                modifier = _as_modifier(directive.args[0])
                if modifier is not None:
                    program.notes.append(
                        f"{span}: note: `as {to_prolog(modifier)}` ignored: every dynamic predicate of an "
                        f"active-query program propagates its changes incrementally")
                continue
            if isinstance(directive, Compound) and directive.name in ("table", "discontiguous") and directive.arity == 1:
                # meaningless here: every predicate with rules is tabled by the transformation
                modifier = _as_modifier(directive.args[0]) if directive.name == "table" else None
                if modifier is not None:
                    program.notes.append(
                        f"{span}: note: `:- table ... as {to_prolog(modifier)}` ignored: every predicate with "
                        f"rules is tabled and maintained incrementally by the active-query transformation")
                continue
            if isinstance(directive, Compound) and directive.name in ("import", "export", "local") \
                    and directive.arity == 1:
                program.notes.append(
                    f"{span}: note: XSB `:- {directive.name}` ignored: an active-query program is one module "
                    f"and its builtins need no import")
                continue
            raise program_error("only `:- dynamic` declarations are allowed in an active-query program",
                                directive, span)
        if isinstance(term, Compound) and term.name == ":-" and term.arity == 2:
            head, body = term.args
            goals = _conjuncts(body)
        else:
            head, goals = term, []
        if isinstance(head, Var) or indicator(head) is None:
            raise program_error("the head of a clause must be an atom or a compound term", head, span)
        hind = indicator(head)
        if hind in BUILTINS or hind in REJECTED or hind in ((",", 2), (":-", 2), ("-->", 2)):
            raise program_error(f"cannot define the builtin {hind[0]}/{hind[1]}", head, span)
        if not goals or goals == [Atom("true")]:
            program.facts.append(Fact(head, span))
            dynamic.setdefault(hind)
            continue
        program.rules.append(Rule(len(program.rules) + 1, head, [Literal(goal) for goal in goals], span,
                                  clause.text.strip()))
    program.dynamic = list(dynamic)
    return program


def term_vars(terms) -> List[str]:
    """The names of the variables of `terms`, in order of first occurrence."""
    seen: Dict[str, None] = {}
    for t in terms:
        for v in variables(t):
            seen.setdefault(v.name)
    return list(seen)
