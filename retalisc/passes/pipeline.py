"""The pass pipeline: the whole compilation, in order, as one list."""
from __future__ import annotations

from typing import Callable, List, Optional

from ..frontend.program import Program, pattern_text
from ..frontend.writer import write_term
from . import apply_rule_windows, binarize, collect_settings, edbc, push_conditions, validate
from .unit import Unit

PIPELINE = [validate, collect_settings, apply_rule_windows, push_conditions, binarize, edbc]

PASS_NAMES = [p.name for p in PIPELINE]


def run_pipeline(unit: Unit, dump_after: Optional[str] = None, dump: Callable[[str], None] = print) -> Unit:
    """Run every pass in order; after the pass named `dump_after`, hand its result to `dump`."""
    for compiler_pass in PIPELINE:
        unit = compiler_pass.run(unit)
        if compiler_pass.name == dump_after:
            dump(dump_unit(unit, compiler_pass.name))
    return unit


def dump_unit(unit: Unit, after: str) -> str:
    header = f"% retalisc: the program after pass '{after}'"
    if after == "edbc":
        return header + "\n\n" + edbc.dump(unit)
    if after == "binarize":
        return header + "\n\n" + "\n\n".join(rule.dump() for rule in unit.rules)
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
