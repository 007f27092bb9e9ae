"""Compiling event rules for a program that is already running (ETALIS `ins_event_rule`).

A rule added at runtime goes through the same pipeline as the rules of a program file (after
the `added_rules` pass, see `retalisc.compiler.compile_added_rules`), and comes out as the
clauses to add to the program's module, each rule introduced by a marker:

    '$rtl_rule'(Id, [store(Name, Arity, Window), ...]).
    ele_trigger(...) :- ...
    e_<Id>_1_left(...) :- ...

`Window` is `none` for a store without a window. The runtime (`prolog_runtime/rtl_rules.pl`)
reads this text, checks that no rule `Id` exists yet and asserts the clauses; unlabelled
rules are named `<prefix>_<n>` so that the runtime can keep their ids fresh. The runtime gets
the text from `retalisc compile-rules` (a subprocess of a standalone `swipl PROGRAM.pl`) or,
inside a Python process, from `compile_rules_for_the_runtime` (served by the Engine).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List

from .compiler import compile_added_rules
from .frontend.errors import RetalisError


@dataclass
class CompiledRules:
    text: str               # the marker and clauses of every rule, Prolog text
    rule_ids: List[str]


def compile_rules(text: str, module: str, prefix: str = "rt", file: str = "<rules>") -> CompiledRules:
    """Compile the event rules in `text` for program module `module`. Raises RetalisError with
    a location for anything that is not an event rule (or `event_rule_property/3`), and for a
    label that cannot name generated predicates; ValueError for a bad `prefix`."""
    result = compile_added_rules(text, module, prefix, file)
    return CompiledRules(result.prolog, [generated.rule_id for generated in result.unit.generated])


class RulesRefused(Exception):
    """The rules do not compile; the text is the message (`FILE:LINE:COL: ...`)."""


def compile_rules_for_the_runtime(module: str, prefix: str, text: str, file: str = "ins_event_rule") -> str:
    """The text of the rules in `text` compiled for `module` (rtl_rules.pl reads it), what
    `retalisc compile-rules --module MODULE --rule-prefix PREFIX --name FILE` writes; raises
    RulesRefused with what that command prints when they do not compile."""
    try:
        return compile_rules(text, module, prefix, file).text
    except RetalisError as error:
        raise RulesRefused(error.render()) from None
    except ValueError as error:
        raise RulesRefused(f"error: {error}") from None


__all__ = ["CompiledRules", "RulesRefused", "compile_rules", "compile_rules_for_the_runtime"]
