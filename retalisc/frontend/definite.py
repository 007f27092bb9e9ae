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
from .terms import (Atom, Compound, Number, Span, String, Term, Var, indicator, list_items, make_list, span_of,
                    to_prolog, variables)

Indicator = Tuple[str, int]

#: Builtins allowed in rule bodies: evaluated where their arguments are bound (the aq_join_order
#: pass places them), like XSB does.
BUILTINS: Set[Indicator] = {
    ("<", 2), (">", 2), ("=<", 2), (">=", 2), ("=:=", 2), ("=\\=", 2),
    ("is", 2), ("=", 2), ("\\=", 2), ("==", 2), ("\\==", 2), ("@<", 2), ("@>", 2), ("@=<", 2), ("@>=", 2),
    ("true", 0),
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


#: The flags of set_prolog_flag/2 that only say how the program text is read, with the values
#: that read it as retalisc does (double_quotes: any value, applied to the clauses after it).
READING_FLAGS = {"double_quotes": ("codes", "chars", "atom", "string"), "back_quotes": ("codes",),
                 "character_escapes": ("true",)}


def _reading_directive(directive: Term, span: Optional[Span], reading: Dict[str, str]) -> Optional[str]:
    """Accept a directive that does not change what the program means (a note to show, or None),
    or raise a located error saying why it is refused."""
    name = directive.name if isinstance(directive, (Atom, Compound)) else None
    args = directive.args if isinstance(directive, Compound) else ()
    if name == "encoding" and len(args) == 1 and isinstance(args[0], Atom):
        if args[0].name.lower().replace("-", "").replace("_", "") in ("utf8", "unicode"):
            return None                         # the file is read as UTF-8
        raise program_error(f"encoding({args[0].name}): an active-query program is read as UTF-8; convert "
                            "the file to UTF-8 and write :- encoding(utf8)", directive, span)
    if name == "set_prolog_flag" and len(args) == 2:
        flag, value = args
        if not isinstance(flag, Atom) or flag.name not in READING_FLAGS:
            shown = to_prolog(flag)
            raise program_error(f"set_prolog_flag({shown}, ...) is not a flag for reading the program text "
                                f"(those are {', '.join(sorted(READING_FLAGS))}): it would change how the "
                                "program runs, which an active-query program does not set", directive, span)
        allowed = READING_FLAGS[flag.name]
        if not isinstance(value, Atom) or value.name not in allowed:
            raise program_error(f"set_prolog_flag({flag.name}, {to_prolog(value)}): an active-query program is "
                                f"read with {flag.name} {' or '.join(allowed)}", directive, span)
        reading[flag.name] = value.name
        return None
    if (name, len(args)) in (("ensure_loaded", 1), ("use_module", 1), ("use_module", 2)):
        if isinstance(args[0], Compound) and args[0].name == "library" and args[0].arity == 1:
            return (f"{span}: note: `:- {name}({to_prolog(args[0])})` ignored: rule bodies use the definite "
                    f"builtins only, which need no library")
        raise program_error(f"{name}({to_prolog(args[0])}) loads a file of clauses, which an active-query "
                            "program cannot do: put its clauses in this program", directive, span)
    raise program_error("only declarations (`:- dynamic`, `:- table`), `:- encoding/1`, `:- set_prolog_flag/2` of "
                        "a reading flag and `:- ensure_loaded(library(...))` are allowed in an active-query "
                        "program: other directives run code", directive, span)


def _with_double_quotes(term: Term, mode: str) -> Term:
    """`term` with its double-quoted texts read as `set_prolog_flag(double_quotes, mode)` says."""
    if mode == "string":
        return term
    if isinstance(term, String):
        if mode == "atom":
            return Atom(term.text, term.span)
        items = [Number(ord(c)) if mode == "codes" else Atom(c) for c in term.text]
        return make_list(items)
    if isinstance(term, Compound):
        return Compound(term.name, tuple(_with_double_quotes(a, mode) for a in term.args), term.span)
    return term


def read_definite_program(text: str, file: str) -> Program:
    """Read a definite program: its rules (bodies not yet checked, see the `aq_program` pass),
    facts and dynamic predicates. Raises RetalisSyntaxError / RetalisSemanticError."""
    program = Program(file=file)
    dynamic: Dict[Indicator, None] = {}
    reading = {"double_quotes": "string"}     # as the reader gives "...": SWI-Prolog 7's default
    for clause in read_program(text, file, XSB_OPERATORS):
        term, span = _with_double_quotes(clause.term, reading["double_quotes"]), clause.span
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
            note = _reading_directive(directive, span, reading)
            if note:
                program.notes.append(note)
            continue
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
