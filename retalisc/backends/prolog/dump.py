"""`retalisc compile --dump-after PASS`: a compilation unit as text, for a developer to read.

An event unit shows its most developed form: the generated clauses once `edbc` has run, else
the binary steps once `binarize` has run, else the program. An active-query unit shows its
definite program with the kind of every body literal.
"""
from __future__ import annotations

from typing import List, Union

from ...frontend import definite
from ...frontend.program import Program, pattern_text
from ...frontend.terms import quote_atom
from ...frontend.writer import write_term
from ...passes.unit import AqUnit, BinaryRule, Operand, Unit
from .render import render_rule


_NOT = "\\+ "


def dump_unit(unit: Union[Unit, AqUnit], after: str) -> str:
    header = f"% retalisc: the program after pass '{after}'"
    if isinstance(unit, AqUnit):
        return header + "\n\n" + dump_definite_program(unit.program)
    if unit.generated is not None:
        return header + "\n\n" + "\n\n".join(render_rule(g) for g in unit.generated)
    if unit.rules is not None:
        return header + "\n\n" + "\n\n".join(dump_binary_rule(rule) for rule in unit.rules)
    return header + "\n\n" + dump_program(unit.program)


def dump_program(program: Program) -> str:
    lines: List[str] = []
    for clause in program.clauses:
        kind = type(clause).__name__
        if hasattr(clause, "pattern"):
            label = f"{clause.label} 'rule:' " if clause.label else ""
            action = f" do {write_term(clause.action, 1149)}" if clause.action is not None else ""
            lines.append(f"{label}{write_term(clause.head, 1149)}{action} <- {pattern_text(clause.pattern)}.")
        elif kind == "StaticClause":
            lines.append(write_term(clause.term, 1200) + ".")
        else:
            prefix = ":- " if kind == "Directive" else ""
            lines.append(prefix + write_term(clause.goal, 1199) + ".")
    return "\n".join(lines)


def dump_binary_rule(rule: BinaryRule) -> str:
    lines = [f"% {rule.rule_id}: {write_term(rule.rule.head)} <- {pattern_text(rule.rule.pattern)}"]
    for step in rule.steps:
        right = f" {step.op} {_operand_text(step.right)}" if step.right is not None else ""
        if step.op == "cnot":
            right = f" seq {_operand_text(step.right)} with no {_operand_text(step.negated)} between"
        elif step.op == "fnot":
            right = f" fnot {_operand_text(step.negated)}"
        elif step.op == "absence":
            right = f" then no {_operand_text(step.negated)} for {step.duration:g} s"
        elif step.op == "sliding":
            function, group, value = step.sliding
            right = (f" sliding {write_term(function, 999)} by {write_term(group, 999)} over {step.duration:g} s "
                     f"as {write_term(value, 999)}")
        elif step.op == "aggregate":
            function, value = step.aggregate
            right = (f" seq aggregate({write_term(function, 999)}, {_operand_text(step.right)}, "
                     f"{write_term(value, 999)})")
        cond = f" where {', '.join(write_term(c, 999) for c in step.conditions)}" if step.conditions else ""
        window = f" within {step.window:g}" if step.window is not None else ""
        lines.append(f"{write_term(step.output)} <- {_operand_text(step.left)}{right}{cond}{window}")
    return "\n".join(lines)


def _operand_text(operand: Operand) -> str:
    text = write_term(operand.term, 999)
    if operand.filters:
        text += " {" + ", ".join(write_term(f, 999) for f in operand.filters) + "}"
    return text


def dump_definite_program(program: definite.Program) -> str:
    """Dynamic predicates, facts, then each rule with the kind of each body literal (`call`:
    through a table, `fact`: stored facts resolved in place, `builtin`)."""
    lines: List[str] = []
    if program.mode:
        subsumption = " with subsumption" if program.subsumption else ""
        lines.append(f"% transformation: {program.mode}{subsumption}")
    lines.extend(f":- dynamic {quote_atom(name)}/{arity}." for name, arity in program.dynamic)
    lines.extend(write_term(fact.term, 1199) + "." for fact in program.facts)
    for rule in program.rules:
        where = f" ({rule.span})" if rule.span else ""
        lines.append("")
        lines.append(f"% rule {rule.index}{where}{' (added by the transformation)' if rule.synthetic else ''}")
        goals = [f"    {_NOT if lit.negated else ''}{write_term(lit.term, 999)}{',' if n < len(rule.body) else '.'}"
                 f"  % {('negated ' if lit.negated else '') + (lit.kind or '?')}"
                 for n, lit in enumerate(rule.body, start=1)]
        lines.append(write_term(rule.head, 1199) + (" :-" if goals else "."))
        lines.extend(goals)
    return "\n".join(lines).lstrip("\n")

