"""What the passes work on: the compilation unit and the intermediate forms it carries.

The program model (`retalisc.frontend.program.Program`) comes in; `binarize` adds the
binary steps of every event rule (thesis 6.3.1, first step); `edbc` adds the generated
Prolog clauses (Algorithms 1 and 2). Every form can `dump()` itself for `--dump-after`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional

from ..frontend.program import EventRule, Program, pattern_text
from ..frontend.terms import Span, Term
from ..frontend.writer import write_term


@dataclass
class Settings:
    """Program-wide settings collected from directives and declarations."""

    consumption_policy: str = "unrestricted"
    printed: Optional[List[tuple]] = None     # print_trigger(F/A) indicators; None = all
    rule_properties: Dict[str, dict] = field(default_factory=dict)  # label -> {name: value}


@dataclass
class Operand:
    """One input of a step: an event pattern atom, or the output of another step."""

    term: Term                      # the event atom, or the intermediate event of `step`
    step: Optional["Step"] = None   # None for an event atom of the source
    filters: List[Term] = field(default_factory=list)  # where-conjuncts checked on arrival
    start: Optional[Term] = None    # variables bound by E^[Start, End]
    end: Optional[Term] = None
    span: Optional[Span] = None

    @property
    def is_event(self) -> bool:
        return self.step is None


@dataclass
class Step:
    """A binary rule `output <- left OP right` (or a unary pass-through, op `pass`), with the
    where-conditions checked on its result and the window its matches must fit in."""

    name: str                       # e_<rule>_<n>
    op: str                         # seq, and, par, or, equals, ..., cnot, fnot, pass
    left: Operand
    right: Optional[Operand]
    output: Term                    # e_<rule>_<n>(Vars...) or, for the last step, the head
    window: Optional[float] = None
    conditions: List[Term] = field(default_factory=list)
    derives_head: bool = False
    negated: Optional[Operand] = None   # cnot: no `negated` between left and right;
                                        # fnot: no `negated` before left
    aggregate: Optional[tuple] = None   # (function, value variable) of `left seq aggregate(F, right, V)`


@dataclass
class BinaryRule:
    """An event rule after binarization: its steps, innermost first, the last one deriving
    the head."""

    rule_id: str
    rule: EventRule
    steps: List[Step]

    def dump(self) -> str:
        lines = [f"% {self.rule_id}: {write_term(self.rule.head)} <- {pattern_text(self.rule.pattern)}"]
        for step in self.steps:
            right = f" {step.op} {_operand_text(step.right)}" if step.right is not None else ""
            if step.op == "cnot":
                right = f" seq {_operand_text(step.right)} with no {_operand_text(step.negated)} between"
            elif step.op == "fnot":
                right = f" fnot {_operand_text(step.negated)}"
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


@dataclass
class GeneratedRule:
    """The Prolog clauses generated for one source rule, with what the runtime must know."""

    rule_id: str
    comment: str                    # the source rule and its location
    clauses: List[Term]
    triggers: List[Term]            # ele_trigger/3 clauses
    stores: List[tuple]             # (name, arity, window or None)


@dataclass
class Unit:
    program: Program
    module: str
    settings: Settings = field(default_factory=Settings)
    rules: List[BinaryRule] = field(default_factory=list)
    generated: List[GeneratedRule] = field(default_factory=list)
    warnings: List[str] = field(default_factory=list)
