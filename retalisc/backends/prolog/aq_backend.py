"""Prolog code for active queries: renders a transformed definite program (see
`retalisc/passes/aq_*.py`) into plain SWI-Prolog that loads `prolog_runtime/rtl_aq.pl`,
through `templates/aq_program.j2`.

For rule k `H :- L1, ..., Ln` with wait points (non-builtin literals) w1 < ... < wm, and the
state s<k>_<w>(T, Env) = e_k(w-1) of the binary rules (Env: the variables of H, L1..L(w-1)):

    '$aq_act'(H, T)                  :- builtins, aq_wait_*(L_w1, s<k>_<w1>(T, Env1)).   (e_k0)
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
from ...frontend.terms import Compound, Term, quote_atom, to_prolog
from ...passes.unit import AqUnit
from ...runtime_location import runtime_dir

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
    used = set(term_vars([rule.head] + [l.term for l in rule.body])) | set(taken)
    name, n = base, 0
    while name in used:
        n += 1
        name = f"{base}{n}"
    return name


def _conj(goals: List[str]) -> str:
    return ", ".join(goals) if goals else "true"


def _clause(head: str, goals: List[str]) -> str:
    if not goals:
        return f"{head}."
    return f"{head} :-\n    " + ",\n    ".join(goals) + "."


def rule_clauses(rule: Rule) -> List[str]:
    t = _fresh_var(rule, "T")
    r = _fresh_var(rule, "R", taken=[t])
    head = to_prolog(rule.head)
    body = rule.body
    waits = [i for i, lit in enumerate(body) if lit.kind != "builtin"]

    def state(i: int) -> str:
        env = term_vars([rule.head] + [l.term for l in body[:i]])
        return f"s{rule.index}_{i + 1}({', '.join([t] + env)})"

    def builtins(lo: int, hi: int) -> List[str]:
        return [to_prolog_goal(body[j].term) for j in range(lo, hi)]

    def enter(i: int) -> str:
        if body[i].negated:
            return f"aq_wait_neg({body[i].kind}, {to_prolog(body[i].term)}, {state(i)}, {rule.stratum})"
        pred = "aq_wait_call" if body[i].kind == "call" else "aq_wait_fact"
        return f"{pred}({to_prolog(body[i].term)}, {state(i)})"

    def literal(i: int) -> str:
        """The literal a state resumes with: an answer or fact, or '$aq_not'(G) once `\\+ G` holds."""
        text = to_prolog(body[i].term)
        return f"'$aq_not'({text})" if body[i].negated else text

    def kind(i: int) -> str:
        return "neg" if body[i].negated else body[i].kind

    def answer(rank: str) -> str:
        return f"aq_answer({t}, {head}, {rank})"

    guard = []
    if rule.guard:
        names, masks = rule.guard
        m = _fresh_var(rule, "M", taken=[t, r])
        guard = [f"aq_adornment([{', '.join(names)}], {m})", f"memberchk({m}, [{', '.join(map(str, masks))}])"]
    clauses = []
    first_hi = waits[0] if waits else len(body)
    clauses.append(_clause(f"'$aq_act'({head}, {t})",
                           guard + builtins(0, first_hi) + [enter(waits[0]) if waits else answer("0")]))
    for n, i in enumerate(waits):
        hi = waits[n + 1] if n + 1 < len(waits) else len(body)
        last = n + 1 == len(waits)
        nxt = answer(r) if last else enter(waits[n + 1])
        clauses.append(_clause(f"'$aq_go'({state(i)}, {literal(i)}, {r if last else '_'})",
                               builtins(i + 1, hi) + [nxt]))
    if waits:
        j = waits[-1]
        clauses.append(f"'$aq_final'({head}, {t}, {state(j)}, {kind(j)}, {literal(j)}, "
                       f"({_conj(builtins(j + 1, len(body)))})).")
    else:
        clauses.append(f"'$aq_final'({head}, {t}, act({t}), none, true, ({_conj(builtins(0, len(body)))})).")
    return clauses


_INFIX = {"<", ">", "=<", ">=", "=:=", "=\\=", "is", "=", "==", "\\=="}


def to_prolog_goal(term: Term) -> str:
    """Builtins are written infix (readable); their arguments canonically."""
    if isinstance(term, Compound) and term.name in _INFIX and term.arity == 2:
        return f"{to_prolog(term.args[0])} {term.name} {to_prolog(term.args[1])}"
    return to_prolog(term)


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
    facts = [f"{to_prolog(f.term)}." for f in grouped]
    rules = []
    for rule in program.rules:
        where = str(rule.span) if rule.span else ""
        text = " ".join(rule.text.split()) if rule.text else to_prolog(rule.head)
        rules.append({"k": rule.index, "where": where, "text": text, "clauses": rule_clauses(rule)})
    runtime = quote_atom(str(runtime_dir()))
    return _ENV.get_template("aq_program.j2").render(
        file=program.file, mode=program.mode, subsumption=program.subsumption, kinds=kinds,
        negation=any(lit.negated for rule in program.rules for lit in rule.body),
        dynamic=dynamic, facts=facts, rules=rules, runtime_dir=runtime)
