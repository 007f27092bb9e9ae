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
    used = set(term_vars([rule.head] + [literal.term for literal in rule.body])) | set(taken)
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
    """The activation, the steps and the final step of one rule."""
    return [_clause(_act_head(rule), _activation(rule))] + step_clauses(rule)


def variant_clauses(rules: List[Rule]) -> List[str]:
    """The body orders of one written rule (aq_join_order), one per set of adornment masks:
    one activation clause computes the mask of the call once and picks the order by it (an
    if-then-else whose last branch takes the masks the others do not); then the steps of each."""
    first = rules[0]
    t = _fresh_var(first, "T")
    m = _fresh_var(first, "M", taken=[t, _fresh_var(first, "R", taken=[t])])
    names, _ = first.guard
    branches = []
    for n, rule in enumerate(rules):
        goals = ",\n        ".join(_activation(rule))
        if n + 1 < len(rules):
            test = f"memberchk({m}, [{', '.join(map(str, rule.guard[1]))}])"
            branches.append(f"{'(' if n == 0 else ';'}   {test}\n    ->  {goals}")
        else:
            branches.append(f";   {goals}")
    dispatch = "\n    ".join(branches) + "\n    )"
    act = _clause(_act_head(first), [f"aq_adornment([{', '.join(names)}], {m})", dispatch])
    return [act] + [c for rule in rules for c in step_clauses(rule)]


def _act_head(rule: Rule) -> str:
    return f"'$aq_act'({to_prolog(rule.head)}, {_fresh_var(rule, 'T')})"


def _waits(rule: Rule) -> List[int]:
    return [i for i, lit in enumerate(rule.body) if lit.kind != "builtin"]


def _state(rule: Rule, i: int) -> str:
    t = _fresh_var(rule, "T")
    env = term_vars([rule.head] + [literal.term for literal in rule.body[:i]])
    return f"s{rule.index}_{i + 1}({', '.join([t] + env)})"


def _builtins(rule: Rule, lo: int, hi: int) -> List[str]:
    return [to_prolog_goal(rule.body[j].term) for j in range(lo, hi)]


def _enter(rule: Rule, i: int) -> str:
    lit = rule.body[i]
    if lit.negated:
        return f"aq_wait_neg({lit.kind}, {to_prolog(lit.term)}, {_state(rule, i)}, {rule.stratum})"
    pred = "aq_wait_call" if lit.kind == "call" else "aq_wait_fact"
    return f"{pred}({to_prolog(lit.term)}, {_state(rule, i)})"


def _answer(rule: Rule, rank: str) -> str:
    return f"aq_answer({_fresh_var(rule, 'T')}, {to_prolog(rule.head)}, {rank})"


def _activation(rule: Rule) -> List[str]:
    """The goals of e_k0: the builtins before the first wait point, then the wait (or the answer)."""
    waits = _waits(rule)
    first_hi = waits[0] if waits else len(rule.body)
    return _builtins(rule, 0, first_hi) + [_enter(rule, waits[0]) if waits else _answer(rule, "0")]


def step_clauses(rule: Rule) -> List[str]:
    """'$aq_go' for every wait point, and '$aq_final'."""
    t = _fresh_var(rule, "T")
    r = _fresh_var(rule, "R", taken=[t])
    head = to_prolog(rule.head)
    body = rule.body
    waits = _waits(rule)

    def literal(i: int) -> str:
        """The literal a state resumes with: an answer or fact, or '$aq_not'(G) once `\\+ G` holds."""
        text = to_prolog(body[i].term)
        return f"'$aq_not'({text})" if body[i].negated else text

    def kind(i: int) -> str:
        return "neg" if body[i].negated else body[i].kind

    clauses = []
    for n, i in enumerate(waits):
        hi = waits[n + 1] if n + 1 < len(waits) else len(body)
        last = n + 1 == len(waits)
        nxt = _answer(rule, r) if last else _enter(rule, waits[n + 1])
        clauses.append(_clause(f"'$aq_go'({_state(rule, i)}, {literal(i)}, {r if last else '_'})",
                               _builtins(rule, i + 1, hi) + [nxt]))
    if waits:
        j = waits[-1]
        clauses.append(f"'$aq_final'({head}, {t}, {_state(rule, j)}, {kind(j)}, {literal(j)}, "
                       f"({_conj(_builtins(rule, j + 1, len(body)))})).")
    else:
        clauses.append(f"'$aq_final'({head}, {t}, act({t}), none, true, ({_conj(_builtins(rule, 0, len(body)))})).")
    return clauses


_INFIX = {"<", ">", "=<", ">=", "=:=", "=\\=", "is", "=", "\\=", "==", "\\==", "@<", "@>", "@=<", "@>="}


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
    for group in _variant_groups(program.rules):
        rule = group[0]
        where = str(rule.span) if rule.span else ""
        text = " ".join(rule.text.split()) if rule.text else to_prolog(rule.head)
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
