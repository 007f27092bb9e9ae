"""Prolog code for active queries: renders a transformed definite program (see
`retalisc/passes/aq_*.py`) into plain SWI-Prolog that loads `prolog_runtime/rtl_aq.pl`,
through `templates/aq_program.j2`.

For rule k `H :- L1, ..., Ln` with wait points (non-builtin literals) w1 < ... < wm, and the
state s<k>_<w>(T, Env) = e_k(w-1) of the binary rules (Env: the variables of H, L1..L(w-1)):

    '$aq_act'(H, T)                  :- builtins, aq_wait_*(L_w1, s<k>_<w1>(T, Env1)).   (e_k0)

The body orders that aq_join_order made of one written rule (rules k..k+n, one per set of
adornments) share one activation: `aq_adornment(HeadVars, M)`, then an if-then-else on M whose
branches are the e_k0 bodies above (`memberchk(M, Masks) -> ...`, the last one `; ...`).
    '$aq_go'(s<k>_<wi>(..), L_wi, R) :- builtins, aq_wait_*(L_w(i+1), ...) | aq_answer(T, H, R).

R is the rank of the answer L_wi (0 for a fact); the answer H gets rank R+1 (see
prolog_runtime/rtl_aq.pl: DRed uses it).
    '$aq_final'(H, T, LastState, Kind, Literal, Check)  how an answer is derived (DRed
                                                         re-derivation of an answer)

A negated literal `\\+ L` (stratified negation) is a wait point `aq_wait_neg(Kind, L, State,
Stratum)` (Stratum: of the rule's head); its state resumes with `'$aq_not'(L)` once the runtime
has found L false (Kind `neg` in `'$aq_final'`).
"""
from __future__ import annotations

from pathlib import Path
from typing import List

import jinja2

from ...frontend.definite import Program, Rule, term_vars
from ...frontend.terms import Atom, Compound, Number, Term, Var, make_list, quote_atom
from ...passes.unit import AqUnit
from ...runtime_location import runtime_dir
from .render import write_clause, write_term

_ENV = jinja2.Environment(
    loader=jinja2.FileSystemLoader(str(Path(__file__).with_name("templates"))),
    keep_trailing_newline=True,
    trim_blocks=False,
    autoescape=False,
)


def render_active_queries(unit: AqUnit) -> str:
    """The complete generated Prolog text of a definite program after its transformation pass."""
    program = unit.program
    if not program.mode:
        raise ValueError("no active-query transformation has run on this program")
    return _render(program)


def _pattern(ind) -> str:
    name, arity = ind
    if arity == 0:
        return quote_atom(name)
    return f"{quote_atom(name)}({', '.join(f'A{i}' for i in range(1, arity + 1))})"


def _record(ind) -> str:
    name, arity = ind
    rname = quote_atom(f"aq_w:{name}/{arity}")
    args = [f"A{i}" for i in range(1, arity + 1)] + ["S"]
    return f"{rname}({', '.join(args)})"


def _indicator(term: Term):
    if isinstance(term, Compound):
        return (term.name, term.arity)
    return (term.name, 0)


def _fresh_var(rule: Rule, base: str, taken=()) -> str:
    used = set(term_vars([rule.head] + [literal.term for literal in rule.body])) | set(taken)
    name, n = base, 0
    while name in used:
        n += 1
        name = f"{base}{n}"
    return name


def _conj(goals: List[Term]) -> Term:
    if not goals:
        return Atom("true")
    term = goals[-1]
    for goal in reversed(goals[:-1]):
        term = Compound(",", (goal, term))
    return term


def _clause(head: Term, goals: List[Term]) -> str:
    """A clause as render.write_clause writes the clauses of event programs: one goal a line,
    an if-then-else in the usual layout, long terms broken over lines."""
    return write_clause(Compound(":-", (head, _conj(goals))) if goals else head)


def rule_clauses(rule: Rule) -> List[str]:
    """The activation, the steps and the final step of one rule."""
    return [_clause(_act_head(rule), _activation(rule))] + step_clauses(rule)


def variant_clauses(rules: List[Rule]) -> List[str]:
    """The body orders of one written rule (aq_join_order), one per set of adornment masks:
    one activation clause computes the mask of the call once and picks the order by it (an
    if-then-else whose last branch takes the masks the others do not); then the steps of each."""
    first = rules[0]
    t = _fresh_var(first, "T")
    m = Var(_fresh_var(first, "M", taken=[t, _fresh_var(first, "R", taken=[t])]))
    names, _ = first.guard
    dispatch = _conj(_activation(rules[-1]))
    for rule in reversed(rules[:-1]):
        test = Compound("memberchk", (m, make_list([Number(mask) for mask in rule.guard[1]])))
        dispatch = Compound(";", (Compound("->", (test, _conj(_activation(rule)))), dispatch))
    adornment = Compound("aq_adornment", (make_list([Var(name) for name in names]), m))
    act = _clause(_act_head(first), [adornment, dispatch])
    return [act] + [c for rule in rules for c in step_clauses(rule)]


def _act_head(rule: Rule) -> Term:
    return Compound("$aq_act", (rule.head, Var(_fresh_var(rule, "T"))))


def _waits(rule: Rule) -> List[int]:
    return [i for i, lit in enumerate(rule.body) if lit.kind != "builtin"]


def _state(rule: Rule, i: int) -> Term:
    t = _fresh_var(rule, "T")
    env = term_vars([rule.head] + [literal.term for literal in rule.body[:i]])
    return Compound(f"s{rule.index}_{i + 1}", tuple(Var(name) for name in [t] + env))


def _builtins(rule: Rule, lo: int, hi: int) -> List[Term]:
    return [rule.body[j].term for j in range(lo, hi)]


def _enter(rule: Rule, i: int) -> Term:
    lit = rule.body[i]
    if lit.negated:
        return Compound("aq_wait_neg", (Atom(lit.kind), lit.term, _state(rule, i), Number(rule.stratum)))
    pred = "aq_wait_call" if lit.kind == "call" else "aq_wait_fact"
    return Compound(pred, (lit.term, _state(rule, i)))


def _answer(rule: Rule, rank: Term) -> Term:
    return Compound("aq_answer", (Var(_fresh_var(rule, "T")), rule.head, rank))


def _activation(rule: Rule) -> List[Term]:
    """The goals of e_k0: the builtins before the first wait point, then the wait (or the answer)."""
    waits = _waits(rule)
    first_hi = waits[0] if waits else len(rule.body)
    return _builtins(rule, 0, first_hi) + [_enter(rule, waits[0]) if waits else _answer(rule, Number(0))]


def step_clauses(rule: Rule) -> List[str]:
    """'$aq_go' for every wait point, and '$aq_final'."""
    t = _fresh_var(rule, "T")
    r = Var(_fresh_var(rule, "R", taken=[t]))
    body = rule.body
    waits = _waits(rule)

    def literal(i: int) -> Term:
        """The literal a state resumes with: an answer or fact, or '$aq_not'(G) once `\\+ G` holds."""
        return Compound("$aq_not", (body[i].term,)) if body[i].negated else body[i].term

    def kind(i: int) -> str:
        return "neg" if body[i].negated else body[i].kind

    clauses = []
    for n, i in enumerate(waits):
        hi = waits[n + 1] if n + 1 < len(waits) else len(body)
        last = n + 1 == len(waits)
        nxt = _answer(rule, r) if last else _enter(rule, waits[n + 1])
        clauses.append(_clause(Compound("$aq_go", (_state(rule, i), literal(i), r if last else Var("_"))),
                               _builtins(rule, i + 1, hi) + [nxt]))
    if waits:
        j = waits[-1]
        clauses.append(_clause(Compound("$aq_final", (rule.head, Var(t), _state(rule, j), Atom(kind(j)), literal(j),
                                                      _conj(_builtins(rule, j + 1, len(body))))), []))
    else:
        clauses.append(_clause(Compound("$aq_final", (rule.head, Var(t), Compound("act", (Var(t),)), Atom("none"),
                                                      Atom("true"), _conj(_builtins(rule, 0, len(body))))), []))
    return clauses


def _render(program: Program) -> str:
    kinds = []
    rule_preds = set(program.rule_predicates) | {r.indicator for r in program.rules}
    for ind in program.predicates():
        kind = "call" if ind in rule_preds else "fact"
        kinds.append(f"'$aq_kind'({_pattern(ind)}, {kind}).")
    dynamic = []
    for ind in program.dynamic:
        name, arity = ind
        dynamic.append({
            "decl": f"{quote_atom(name)}/{arity}",
            "record_decl": f"{quote_atom(f'aq_w:{name}/{arity}')}/{arity + 1}",
            "pattern": _pattern(ind),
            "record": _record(ind),
            "args": [f"A{i}" for i in range(1, arity + 1)],
        })
    order = {ind: n for n, ind in enumerate(program.dynamic)}
    grouped = sorted(program.facts, key=lambda f: order.get(_indicator(f.term), len(order)))
    facts = [write_clause(f.term) for f in grouped]
    rules = []
    for group in _variant_groups(program.rules):
        rule = group[0]
        where = str(rule.span) if rule.span else ""
        text = " ".join(rule.text.split()) if rule.text else write_term(rule.head)
        if len(group) == 1:
            label, clauses = f"rule {rule.index}", rule_clauses(rule)
        else:
            label = f"rules {rule.index}-{group[-1].index}, a body order each by what the call binds"
            clauses = variant_clauses(group)
        rules.append({"label": label, "where": where, "text": text, "clauses": clauses})
    runtime = quote_atom(str(runtime_dir()))
    return _ENV.get_template("aq_program.j2").render(
        file=program.file, mode=program.mode, subsumption=program.subsumption, kinds=kinds,
        negation=any(lit.negated for rule in program.rules for lit in rule.body),
        dynamic=dynamic, facts=facts, rules=rules, runtime_dir=runtime)


def _variant_groups(rules: List[Rule]) -> List[List[Rule]]:
    """The rules in order, the body orders of one written rule (same variant_of) together."""
    groups: List[List[Rule]] = []
    for rule in rules:
        if rule.variant_of and groups and groups[-1][0].variant_of == rule.variant_of:
            groups[-1].append(rule)
        else:
            groups.append([rule])
    return groups
