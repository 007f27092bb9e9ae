"""Writing terms as readable Prolog text, with operators, that SWI-Prolog reads back as the
same term. Used for generated code and for `--dump-after`."""
from __future__ import annotations

from .operators import STANDARD_OPERATORS, OperatorTable
from .terms import NIL, Atom, Compound, Number, String, Term, Var, format_number, quote_atom, to_prolog

# Operators that generated code may write in operator form. The event operators are written
# as operators only in comments and dumps (the runtime module does not declare them).
_PLAIN_OPERATORS = set(STANDARD_OPERATORS.infix) | set(STANDARD_OPERATORS.prefix)


def write_term(term: Term, max_priority: int = 1200, ops: OperatorTable = STANDARD_OPERATORS,
               event_operators: bool = True) -> str:
    return _Writer(ops, event_operators).write(term, max_priority)


class _Writer:
    def __init__(self, ops: OperatorTable, event_operators: bool):
        self.ops = ops
        self.event_operators = event_operators

    def usable(self, name: str) -> bool:
        if name in ("rule:", "."):
            return False
        if not self.event_operators:
            return name in _EVENT_FREE
        return True

    def write(self, term: Term, max_priority: int) -> str:
        if isinstance(term, (Var, String)):
            return to_prolog(term)
        if isinstance(term, Number):
            text = format_number(term.value)
            return f"({text})" if text.startswith("-") and max_priority < 999 else text
        if isinstance(term, Atom):
            text = quote_atom(term.name)
            if self.ops.is_operator(term.name) and max_priority < 1200 and term.name not in ("[]", "{}", "!", ";"):
                return f"({text})" if max_priority < 999 else text
            return text
        return self.compound(term, max_priority)

    def operand(self, term: Term, max_priority: int) -> str:
        """An operand of an operator: an atom that is itself an operator is bracketed
        (`dynamic (-->)`, `- (-)`), which SWI-Prolog reads back as the atom."""
        if isinstance(term, Atom) and self.ops.is_operator(term.name) and term.name not in ("[]", "{}", "!"):
            return f"({quote_atom(term.name)})"
        return self.write(term, max_priority)

    def compound(self, term: Compound, max_priority: int) -> str:
        name, args = term.name, term.args
        if name == "[|]" and len(args) == 2:
            return to_prolog_list(term, self)
        if name == "{}" and len(args) == 1:
            return "{" + self.write(args[0], 1200) + "}"
        if len(args) == 2 and self.usable(name) and self.ops.infix_op(name):
            priority, kind = self.ops.infix_op(name)
            left_max = priority if kind == "yfx" else priority - 1
            right_max = priority if kind == "xfy" else priority - 1
            left = self.operand(args[0], left_max)
            right = self.operand(args[1], right_max)
            if name == ",":
                text = f"{left}, {right}"
            else:
                text = f"{left} {quote_atom(name)} {right}"
            return f"({text})" if priority > max_priority else text
        if len(args) == 1 and self.usable(name) and self.ops.prefix_op(name) and name not in ("-", "+"):
            priority, kind = self.ops.prefix_op(name)
            arg_max = priority if kind == "fy" else priority - 1
            text = f"{quote_atom(name)} {self.operand(args[0], arg_max)}"
            return f"({text})" if priority > max_priority else text
        inner = ", ".join(self.write(a, 999) for a in args)
        return f"{quote_atom(name)}({inner})"


def to_prolog_list(term: Compound, writer: _Writer) -> str:
    items = []
    t: Term = term
    while isinstance(t, Compound) and t.name == "[|]" and t.arity == 2:
        items.append(writer.write(t.args[0], 999))
        t = t.args[1]
    inner = ", ".join(items)
    if t == NIL:
        return f"[{inner}]"
    return f"[{inner}|{writer.write(t, 999)}]"


from .operators import EVENT_OPERATORS  # noqa: E402

_EVENT_FREE = (_PLAIN_OPERATORS - set(EVENT_OPERATORS) - {"<-", "do", "rule:", "."})
