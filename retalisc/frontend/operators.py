"""The operator table: SWI-Prolog's standard operators plus the Retalis/ETALIS event operators.

Priorities follow ETALIS (docs/language.md, "Patterns"): all event operators are left-associative (yfx).
`<-` separates an event rule's head from its pattern, `do` attaches an action to a head,
`'rule:'` labels a rule, and `.` after a bracketed pattern is the thesis's window `(P).Q`
and negation `not(P).[P1, P2]`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, Optional, Tuple

INFIX_TYPES = ("xfx", "xfy", "yfx")
PREFIX_TYPES = ("fx", "fy")
POSTFIX_TYPES = ("xf", "yf")
OP_TYPES = INFIX_TYPES + PREFIX_TYPES + POSTFIX_TYPES

EVENT_OPERATORS = ("seq", "and", "par", "or", "equals", "meets", "during", "starts", "finishes",
                   "cnot", "fnot", "where", "check")


@dataclass
class OperatorTable:
    infix: Dict[str, Tuple[int, str]] = field(default_factory=dict)
    prefix: Dict[str, Tuple[int, str]] = field(default_factory=dict)
    postfix: Dict[str, Tuple[int, str]] = field(default_factory=dict)

    def add(self, priority: int, kind: str, name: str) -> None:
        table = self.infix if kind in INFIX_TYPES else self.prefix if kind in PREFIX_TYPES else self.postfix
        if priority == 0:
            table.pop(name, None)
        else:
            table[name] = (priority, kind)

    def copy(self) -> "OperatorTable":
        return OperatorTable(dict(self.infix), dict(self.prefix), dict(self.postfix))

    def is_operator(self, name: str) -> bool:
        return name in self.infix or name in self.prefix or name in self.postfix

    def infix_op(self, name: str) -> Optional[Tuple[int, str]]:
        return self.infix.get(name)

    def prefix_op(self, name: str) -> Optional[Tuple[int, str]]:
        return self.prefix.get(name)


def _standard() -> OperatorTable:
    table = OperatorTable()
    for priority, kind, names in [
        (1200, "xfx", [":-", "-->"]),
        (1200, "fx", [":-", "?-"]),
        (1100, "xfy", [";", "|"]),
        (1105, "xfy", ["|"]),
        (1050, "xfy", ["->", "*->"]),
        (1000, "xfy", [","]),
        (990, "xfx", [":="]),
        (900, "fy", ["\\+"]),
        (700, "xfx", ["=", "\\=", "==", "\\==", "@<", "@>", "@=<", "@>=", "=..", "is", "=:=", "=\\=",
                      "<", ">", "=<", ">=", ">:<", ":<", "as"]),
        (600, "xfy", [":"]),
        (500, "yfx", ["+", "-", "/\\", "\\/", "xor"]),
        (500, "fx", ["?"]),
        (400, "yfx", ["*", "/", "//", "rem", "mod", "div", "<<", ">>", "divmod", "rdiv"]),
        (200, "xfx", ["**"]),
        (200, "xfy", ["^"]),
        (200, "fy", ["-", "+", "\\"]),
        (1, "fx", ["$"]),
        (1150, "fx", ["dynamic", "discontiguous", "initialization", "meta_predicate",
                      "module_transparent", "multifile", "public", "thread_local", "table"]),
        # Retalis / ETALIS
        (1210, "xfx", ["rule:"]),
        (1200, "xfx", ["<-"]),
        (1150, "xfx", ["do"]),
        (1060, "yfx", ["where"]),
        (1053, "yfx", ["or"]),
        (1050, "yfx", ["check"]),
        (1045, "yfx", ["par"]),
        (1040, "yfx", ["and"]),
        (1031, "yfx", ["cnot", "fnot"]),
        (1025, "yfx", ["seq", "equals", "meets", "during", "starts", "finishes"]),
        # ETALIS: `P timestamp C` is `P check C`; `P event_multiply G` derives once per
        # solution of G; `P star_times` is P repeated (after a start: `A seq B star_times`)
        (1050, "yfx", ["timestamp", "event_multiply"]),
        (200, "xf", ["star_times"]),
        (100, "yfx", ["."]),
    ]:
        for name in names:
            table.add(priority, kind, name)
    return table


# ETALIS's own examples write the event operators quoted and capitalised ('SEQ', 'Seq', ...):
# the same operators, read as their lowercase forms (an unquoted SEQ is a variable).
ETALIS_ALIASES = {spelling: name
                  for name in EVENT_OPERATORS + ("do", "timestamp", "event_multiply")
                  for spelling in (name.upper(), name.capitalize())}


def _with_aliases(table: OperatorTable) -> OperatorTable:
    for spelling, name in ETALIS_ALIASES.items():
        priority, kind = table.infix[name]
        table.add(priority, kind, spelling)
    return table


STANDARD_OPERATORS = _with_aliases(_standard())

# The highest priority a clause may have: 1200, or 1210 for a labelled event rule.
CLAUSE_PRIORITY = 1210
ARGUMENT_PRIORITY = 999
