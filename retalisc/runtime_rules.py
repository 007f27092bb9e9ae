"""Compiling event rules for a program that is already running (ETALIS `ins_event_rule`).

A rule added at runtime goes through the same pipeline as the rules of a program file, and
comes out as the clauses to add to the program's module, each rule introduced by a marker:

    '$rtl_rule'(Id, [store(Name, Arity, Window), ...]).
    ele_trigger(...) :- ...
    e_<Id>_1_left(...) :- ...

`Window` is `none` for a store without a window. The runtime (`prolog_runtime/rtl_rules.pl`)
reads this text, checks that no rule `Id` exists yet and asserts the clauses; unlabelled
rules are named `<prefix>_<n>` so that the runtime can keep their ids fresh.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import List

from .backends.prolog.render import write_clause
from .frontend.errors import RetalisSemanticError
from .frontend.program import Declaration, EventRule, parse_program
from .frontend.terms import Atom, Compound, quote_atom
from .passes.pipeline import run_pipeline
from .passes.unit import Unit

RULE_ID = re.compile(r"[a-z][A-Za-z0-9_]*")

# Declarations allowed next to the rules: they configure the rules being compiled.
_RULE_SETTINGS = {("event_rule_property", 3)}


@dataclass
class CompiledRules:
    text: str               # the marker and clauses of every rule, Prolog text
    rule_ids: List[str]


def compile_rules(text: str, module: str, prefix: str = "rt", file: str = "<rules>") -> CompiledRules:
    """Compile the event rules in `text` for program module `module`. Raises RetalisError with
    a location for anything that is not an event rule (or `event_rule_property/3`), and for a
    label that cannot name generated predicates."""
    if not RULE_ID.fullmatch(prefix):
        raise ValueError(f"rule prefix {prefix!r} must match [a-z][A-Za-z0-9_]*")
    program = parse_program(text, file)
    unlabelled = 0
    for clause in program.clauses:
        if isinstance(clause, EventRule):
            if clause.label is None:
                unlabelled += 1
                clause.label = f"{prefix}_{unlabelled}"
            elif not RULE_ID.fullmatch(clause.label):
                raise RetalisSemanticError(
                    f"the label {clause.label!r} of a rule added at runtime must match [a-z][A-Za-z0-9_]* "
                    "(it names the rule's predicates)", clause.span)
        elif isinstance(clause, Declaration) and _key(clause.goal) in _RULE_SETTINGS:
            continue
        else:
            raise RetalisSemanticError("only event rules (Head <- Pattern) and event_rule_property/3 can be "
                                       "added to a running program here; use ins_static_rule/1 for static "
                                       "clauses", clause.span)
    labels = [c.label for c in program.event_rules]
    duplicates = sorted({label for label in labels if labels.count(label) > 1})
    if duplicates:
        raise RetalisSemanticError(f"two rules are labelled {duplicates[0]}", program.event_rules[0].span)
    unit = run_pipeline(Unit(program, module))
    lines: List[str] = []
    ids = []
    for generated in unit.generated:
        ids.append(generated.rule_id)
        stores = ", ".join(
            f"store({quote_atom(name)}, {arity}, {_window(window)})" for name, arity, window in generated.stores)
        lines.append("")
        lines.extend(f"% {line}" for line in generated.comment.splitlines())
        lines.append(f"'$rtl_rule'({quote_atom(generated.rule_id)}, [{stores}]).")
        lines.extend(write_clause(c) for c in generated.triggers + generated.clauses)
    return CompiledRules("\n".join(lines).lstrip("\n") + "\n", ids)


def _window(window) -> str:
    if window is None:
        return "none"
    return str(int(window)) if float(window).is_integer() else repr(float(window))


def _key(goal):
    if isinstance(goal, Compound):
        return goal.name, goal.arity
    if isinstance(goal, Atom):
        return goal.name, 0
    return None


__all__ = ["CompiledRules", "compile_rules"]
