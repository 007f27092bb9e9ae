"""Monitored conditions written as event patterns, compiled to ELE rules of the agent's IEC
(thesis 7.3.1): `[start: visitor(P) <- {(at_door(P) seq bell).10}]` is the Retalis rule
`visitor(P) <- (at_door(P) seq bell).10.` and the condition `event(visitor(P))`, enabled by the
IEC's derived event in the macro step it joins the event base.

The rules are Retalis program text made from the agent file, which is the program's own source
(like a .rtl file), and compiled by the compiler's one road (`Engine.from_source`), with the
agent's own IEC program, if any, before them."""
from __future__ import annotations

from typing import List, Optional

from .syntax import Agent, NodeSpec
from .iec import SteppedIEC, atom_text, event_text
from .terms import Compound, Var


def _specs(spec: NodeSpec):
    yield spec
    for child in spec.children:
        yield from _specs(child)


def _pattern_conditions(agent: Agent):
    for rule in agent.rules:
        for spec in _specs(rule.plan):
            for name, (event, pattern, span) in spec.patterns.items():
                yield spec, name, event, pattern, span


def check_patterns(agent: Agent) -> int:
    """Compile each pattern condition's rule alone (the compiler's road, nothing loaded); a bad
    one raises RetalisSemanticError at the condition, with the compiler's message. The count."""
    from ..compiler import compile_source
    from ..frontend.errors import RetalisError, RetalisSemanticError

    count = 0
    for spec, name, event, pattern, span in _pattern_conditions(agent):
        try:
            compile_source(f"{_head_text(event)} <- {pattern}.\n", f"{agent.file}:{spec.name}:{name}")
        except RetalisError as error:
            raise RetalisSemanticError(f"node {spec.name}: the {name} pattern is not an ELE rule body: "
                                       f"{error.message}", span) from None
        count += 1
    return count


def condition_rules(agent: Agent) -> List[str]:
    """The ELE rules of the agent's pattern conditions, one per condition, in file order
    (a derived event written by two conditions gets one rule each: the union of their patterns)."""
    rules = []
    for spec, name, event, pattern, span in _pattern_conditions(agent):
        where = f"% {agent.file}:{span.line}: node {spec.name}, {name}" if span else f"% node {spec.name}, {name}"
        rules.append(f"{where}\n{_head_text(event)} <- {pattern}.\n")
    return rules


def _head_text(term) -> str:
    """A rule head's text: the event term, its variables as Retalis variables."""
    if isinstance(term, Var):
        return term.name
    if isinstance(term, Compound):
        return f"{atom_text(term.functor)}({','.join(_head_text(a) for a in term.args)})"
    return event_text(term)


def agent_iec(agent: Agent, program_text: Optional[str] = None, program_name: str = "iec.rtl"
              ) -> Optional[SteppedIEC]:
    """The IEC of `agent`: its own program (`program_text`) and the rules of its pattern
    conditions; None when it has neither."""
    rules = condition_rules(agent)
    if program_text is None and not rules:
        return None
    text = (program_text or "") + ("\n" if program_text and not program_text.endswith("\n") else "")
    if rules:
        text += f"% the pattern conditions of {agent.file} (retalisc/robapl/patterns.py)\n" + "".join(rules)
    return SteppedIEC.from_source(text, program_name if program_text is not None else f"{agent.file}.iec.rtl")
