"""Shared helpers of the active-query tests: run a program and an update sequence in `swipl`,
(1) incrementally, (2) from scratch after every update (same transformation) and (3) with
SWI-Prolog's own `:- table` as the oracle, and return the answer sets after every step."""
from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Dict, List, Tuple

from retalisc.compiler import AqOptions, compile_source
from retalisc.frontend.definite import read_definite_program as load_program
from retalisc.frontend.terms import Atom, Compound, Term, to_prolog
from retalisc.frontend.terms import variables as _variables

SWIPL = shutil.which("swipl") or "swipl"

Step = Tuple[str, str]  # ("+", fact) | ("-", fact) | ("?", "")


_CONTROL = {(",", 2), (";", 2), ("->", 2), ("*->", 2), ("\\+", 1)}


def _rename(term: Term, preds) -> Term:
    """Rename the program's predicates to o_p, also inside control constructs; `not/1` and
    `tnot/1` become `\\+` (SWI-Prolog's tnot/1 wants a tabled goal)."""
    if isinstance(term, Compound) and term.name in ("not", "tnot") and term.arity == 1:
        term = Compound("\\+", term.args)
    if isinstance(term, Compound) and (term.name, term.arity) in _CONTROL:
        return Compound(term.name, tuple(_rename(a, preds) for a in term.args))
    if isinstance(term, Compound) and (term.name, term.arity) in preds:
        return Compound("o_" + term.name, term.args)
    if isinstance(term, Atom) and (term.name, 0) in preds:
        return Atom("o_" + term.name)
    return term


def oracle_rules(source: str, extra=()) -> str:
    """The program's rules for SWI-Prolog tabling: every predicate with rules renamed o_p and
    tabled; a predicate with rules and facts reads its stored facts through one more clause.
    `extra`: predicates that get rules later (update steps that add rules); with them, every
    o_p is dynamic too."""
    program = load_program(source, "oracle.pl")
    preds = set(program.rule_predicates) | set(extra)
    lines = [":- style_check(-singleton)."]
    for name, arity in sorted(preds):
        lines.append(f":- table o_{name}/{arity}.")
        if extra:
            lines.append(f":- dynamic o_{name}/{arity}.")
    for rule in program.rules:
        # `true` last: SWI-Prolog 9.0.4 compiles a last call wrongly after a `\+` in which
        # a variable first occurs (`p(0) :- \+ f(Y), e(Y, Y).` calls e/2 with one argument
        # set; docs/active_queries.md, "Fifth round")
        body = [to_prolog(_rename(g, preds)) for g in tests_last(rule.body)] + ["true"]
        lines.append(f"{to_prolog(_rename(rule.head, preds))} :- {', '.join(body)}.")
    for name, arity in sorted(preds):
        if (name, arity) in program.dynamic:
            args = ", ".join(f"A{i}" for i in range(arity))
            lines.append(f"o_{name}({args}) :- {name}({args}).")
    return "\n".join(lines) + "\n"


_BUILTINS = {"<", ">", "=<", ">=", "=:=", "=\\=", "is", "=", "\\=", "==", "\\==", "@<", "@>", "@=<", "@>="}


def tests_last(body) -> List[Term]:
    """The goals of a body as SWI-Prolog can run them: a builtin written before the literals that
    bind its arguments (XSB style, `X < Y, e(X, Y)`) goes to the end of the body, where every
    variable of a range-restricted rule is bound (SWI-Prolog would raise an instantiation error
    where it stands). A test means the same wherever its arguments are bound."""
    bound: set = set()
    kept, moved = [], []
    for lit in body:
        term = lit.term
        names = {v.name for v in _variables(term)}
        if not _only_builtins(term):
            needed = set()
        elif term.name == "is":
            needed = {v.name for v in _variables(term.args[1])}
        elif term.name == "=":
            needed = set()
        else:
            needed = names          # a test, or a control construct over builtins
        if needed <= bound:
            kept.append(term)
            bound |= names
        else:
            moved.append(term)
    return kept + moved


def _only_builtins(term: Term) -> bool:
    if isinstance(term, Compound) and (term.name, term.arity) in _CONTROL:
        return all(_only_builtins(a) for a in term.args)
    return isinstance(term, Compound) and term.name in _BUILTINS and term.arity == 2


def oracle_goal(goal: str, source: str, extra=()) -> str:
    from retalisc.frontend.parser import read_term
    program = load_program(source, "oracle.pl")
    return to_prolog(_rename(read_term(goal), set(program.rule_predicates) | set(extra)))


def rule_step(text: str):
    """The rule of an update step `(H :- B)`, or None for a fact."""
    from retalisc.frontend.parser import read_term
    term = read_term(text)
    if isinstance(term, Compound) and term.name == ":-" and term.arity == 2:
        return term
    return None


def _rule_heads(steps) -> set:
    heads = set()
    for op, text in steps:
        rule = rule_step(text) if op in "+-" else None
        if rule is not None:
            head = rule.args[0]
            heads.add((head.name, head.arity) if isinstance(head, Compound) else (head.name, 0))
    return heads


def _oracle_rule(rule: Term, preds) -> str:
    head, body = rule.args
    from retalisc.frontend.terms import conjuncts, conjunction
    return to_prolog(Compound(":-", (_rename(head, preds), conjunction([_rename(g, preds) for g in conjuncts(body)]))))


def _run(text: str) -> List[str]:
    with tempfile.TemporaryDirectory(prefix="aqtest_") as tmp:
        path = Path(tmp) / "run.pl"
        path.write_text(text)
        proc = subprocess.run([SWIPL, "--no-tty", "-q", "--no-packs", "-g", "main", "-t", "halt", str(path)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=300)
    if proc.returncode != 0 or "Warning" in proc.stderr or "ERROR" in proc.stderr:
        raise AssertionError(f"swipl failed ({proc.returncode}):\n{proc.stderr}\n{proc.stdout[-2000:]}")
    return proc.stdout.splitlines()


_PRINT = r"""
% the oracle's copy of a rule removed at run time: a variant, not the first clause that unifies
retract_variant((H :- B)) :-
    copy_term(H, H0), clause(H0, B0, Ref), (H0 :- B0) =@= (H :- B), !, erase(Ref).
print_state(K, Qs) :-
    forall(nth1(I, Qs, _), ( aq_answers(I, L), format("~w ~w inc ~q~n", [K, I, L]) )).
print_oracle(K, Os) :-
    abolish_all_tables,
    forall(nth1(I, Os, O-G), ( findall(G, O, L0), sort(L0, L), format("~w ~w oracle ~q~n", [K, I, L]) )).
"""


def _parse(lines: List[str], kind: str) -> Dict[Tuple[int, int], str]:
    out = {}
    for line in lines:
        k, i, what, rest = line.split(" ", 3)
        if what == kind:
            out[(int(k), int(i))] = rest
    return out


def run_all(source: str, goals: List[str], steps: List[Step], mode: str, subsumption: bool = False,
            scratch: bool = True, dred: str = "primary"):
    """Answer sets (writeq text of the sorted list) after registration (step 0) and after every
    step: incremental, oracle (SWI `:- table`), and scratch (fresh registration, same mode).
    dred: the DRed variant (primary or basic, see docs/active_queries.md)."""
    generated = compile_source(source, "program.pl", active_queries=AqOptions(mode, subsumption)).prolog
    generated += f":- aq_configure([dred({dred})]).\n"
    extra = _rule_heads(steps)
    oracle = oracle_rules(source, extra)
    preds = set(load_program(source, "oracle.pl").rule_predicates) | extra
    qlist = "[" + ", ".join(goals) + "]"
    olist = "[" + ", ".join(f"({oracle_goal(g, source, extra)})-({g})" for g in goals) + "]"
    ops = {"+": "aq_assert", "-": "aq_retract"}
    rule_ops = {"+": ("aq_add_rule", "assertz"), "-": ("aq_remove_rule", "retract_variant")}
    body = [f"    Qs = {qlist}, Os = {olist},",
            "    forall(nth1(I, Qs, G), aq_register(I, G, _)),",
            "    print_state(0, Qs), print_oracle(0, Os),"]
    for k, (op, fact) in enumerate(steps, start=1):
        rule = rule_step(fact) if op in ops else None
        if rule is not None:
            ours, theirs = rule_ops[op]
            body.append(f"    {ours}({fact}), {theirs}(({_oracle_rule(rule, preds)})),")
        elif op in ops:
            body.append(f"    {ops[op]}({fact}),")
        body.append(f"    print_state({k}, Qs), print_oracle({k}, Os),")
    body.append("    aq_events(_), forall(nth1(I, Qs, _), aq_unregister(I)), aq_stats(St), format('0 0 stats ~q~n', [St]).")
    text = generated + oracle + _PRINT + "main :-\n" + "\n".join(body) + "\n"
    lines = _run(text)
    inc, orc = _parse(lines, "inc"), _parse(lines, "oracle")
    stats = _parse(lines, "stats")[(0, 0)]
    scr = {}
    if scratch:
        sbody = [f"    Qs = {qlist},", "    scratch(0, Qs),"]
        for k, (op, fact) in enumerate(steps, start=1):
            if op in ops:
                sbody.append(f"    {rule_ops[op][0] if rule_step(fact) is not None else ops[op]}({fact}),")
            sbody.append(f"    scratch({k}, Qs),")
        sbody.append("    true.")
        stext = (generated + _PRINT + "scratch(K, Qs) :- forall(nth1(I, Qs, G), aq_register(I, G, _)), "
                 "print_state(K, Qs), aq_reset.\n" + "main :-\n" + "\n".join(sbody) + "\n")
        scr = _parse(_run(stext), "inc")
    return inc, orc, scr, stats
