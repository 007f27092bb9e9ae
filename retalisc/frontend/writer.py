"""Writing terms as readable Prolog text, with operators, that SWI-Prolog reads back as the
same term. Used for generated code and for `--dump-after`.

`write_term` writes a term on one line. `layout_term` writes the same text broken over lines
where it would pass a width: a conjunction one goal a line, a parenthesised `( If -> Then ;
Else )` in the usual Prolog layout (`(   If` / `->  Then` / `;   Else` / `)`), the arguments of
a compound or the elements of a list one a line, indented by four. Line breaks go only where
the one-line text has a space or after an opening bracket, and never inside an atom, a string or
a number, so SWI-Prolog reads both texts as the same term."""
from __future__ import annotations

from typing import List, Optional, Tuple

from .operators import STANDARD_OPERATORS, OperatorTable
from .terms import NIL, Atom, Compound, Number, String, Term, Var, format_number, quote_atom, to_prolog

# Operators that generated code may write in operator form. The event operators are written
# as operators only in comments and dumps (the runtime module does not declare them).
_PLAIN_OPERATORS = set(STANDARD_OPERATORS.infix) | set(STANDARD_OPERATORS.prefix)

#: The width `layout_term` keeps lines within where a term can be broken.
WIDTH = 100


def write_term(term: Term, max_priority: int = 1200, ops: OperatorTable = STANDARD_OPERATORS,
               event_operators: bool = True) -> str:
    return _Writer(ops, event_operators).write(term, max_priority).flat


def layout_term(term: Term, max_priority: int = 1200, column: int = 0, trailing: int = 0,
                ops: OperatorTable = STANDARD_OPERATORS, event_operators: bool = True,
                width: Optional[int] = None, break_control: bool = False) -> str:
    """The text of `write_term`, broken over lines to stay within `width` where it can be:
    `column` is where its first line starts (its other lines are indented from there) and
    `trailing` the number of characters that will follow its last line (`,`, `.`, ` :-`);
    `width` is WIDTH unless given.
    With `break_control`, a term that is a bracketed control construct (`( If -> Then ; Else
    )`) is broken even when it would fit (a body goal of a clause)."""
    width = WIDTH if width is None else width
    doc = _Writer(ops, event_operators).write(term, max_priority)
    if break_control and isinstance(doc, _Block):
        return _layout_block(doc, column, width)
    return _layout(doc, column, trailing, width)


# ---- documents: the text of a term with the places where it may be broken -----------------

class _Doc:
    __slots__ = ("flat",)


class _Text(_Doc):
    """Text never broken."""
    __slots__ = ()

    def __init__(self, text: str):
        self.flat = text


class _Cat(_Doc):
    """Parts written one after the other; only the parts themselves break."""
    __slots__ = ("parts",)

    def __init__(self, parts: List[_Doc]):
        self.parts = parts
        self.flat = "".join(p.flat for p in parts)


class _Args(_Doc):
    """`open` items `close` (`f(` a, b `)`, `[` a, b `]`): broken, one item a line indented by
    four from where it starts, `close` after the last item."""
    __slots__ = ("open", "items", "close")

    def __init__(self, open_: str, items: List[_Doc], close: str):
        self.open, self.items, self.close = open_, items, close
        self.flat = open_ + ", ".join(i.flat for i in items) + close


class _Conj(_Doc):
    """A conjunction: broken, one goal a line, each starting in the column of the first."""
    __slots__ = ("items",)

    def __init__(self, items: List[_Doc]):
        self.items = items
        self.flat = ", ".join(i.flat for i in items)


class _Block(_Doc):
    """A bracketed control construct `( A -> B ; C )`: `parts` are (operator, goal) with "" for
    the first. Broken: `(   A` / `->  B` / `;   C` / `)`, every line in the column of `(`."""
    __slots__ = ("parts",)

    def __init__(self, parts: List[Tuple[str, _Doc]]):
        self.parts = parts
        self.flat = "(" + " ".join((f"{op} " if op else "") + d.flat for op, d in parts) + ")"


def _layout(doc: _Doc, column: int, trailing: int, width: int) -> str:
    if isinstance(doc, _Text) or column + len(doc.flat) + trailing <= width:
        return doc.flat
    if isinstance(doc, _Cat):
        out, col = [], column
        for i, part in enumerate(doc.parts):
            text = _layout(part, col, _trailing(doc.parts[i + 1:], trailing), width)
            out.append(text)
            col = _end_column(text, col)
        return "".join(out)
    if isinstance(doc, _Args):
        inner = column + 4
        if all(isinstance(item, _Text) for item in doc.items):
            return doc.open + _fill(doc, inner, trailing, width)
        lines = [doc.open]
        for i, item in enumerate(doc.items):
            last = i == len(doc.items) - 1
            after = len(doc.close) + trailing if last else 1
            lines.append("\n" + " " * inner + _layout(item, inner, after, width) + (doc.close if last else ","))
        return "".join(lines)
    if isinstance(doc, _Conj):
        texts = [_layout(item, column, trailing if i == len(doc.items) - 1 else 1, width)
                 for i, item in enumerate(doc.items)]
        return (",\n" + " " * column).join(texts)
    if isinstance(doc, _Block):
        return _layout_block(doc, column, width)
    raise TypeError(doc)


def _fill(doc: _Args, inner: int, trailing: int, width: int) -> str:
    """Items that never break (variables, atoms, numbers), as many a line as fit, on lines
    indented to `inner`."""
    lines, line = [], ""
    for i, item in enumerate(doc.items):
        text = item.flat + (doc.close if i == len(doc.items) - 1 else ",")
        after = trailing if i == len(doc.items) - 1 else 0
        if line and inner + len(line) + 1 + len(text) + after > width:
            lines.append(line)
            line = ""
        line = f"{line} {text}" if line else text
    lines.append(line)
    return "".join("\n" + " " * inner + text for text in lines)


def _layout_block(doc: _Block, column: int, width: int) -> str:
    lines = [(op or "(").ljust(4) + _layout(part, column + 4, 0, width) for op, part in doc.parts]
    return ("\n" + " " * column).join(lines + [")"])


def _trailing(rest: List[_Doc], trailing: int) -> int:
    """How much follows a part of a `_Cat` on its line: the unbreakable text up to the next
    part that can break (or the end)."""
    n = 0
    for part in rest:
        if not isinstance(part, _Text):
            return n + min(len(part.flat), 1)
        n += len(part.flat)
    return n + trailing


def _end_column(text: str, column: int) -> int:
    newline = text.rfind("\n")
    return column + len(text) if newline < 0 else len(text) - newline - 1


# ---- the writer ----------------------------------------------------------------------------

_CONTROL = {";", "->", "*->"}


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

    def write(self, term: Term, max_priority: int) -> _Doc:
        if isinstance(term, (Var, String)):
            return _Text(to_prolog(term))
        if isinstance(term, Number):
            text = format_number(term.value)
            return _Text(f"({text})" if text.startswith("-") and max_priority < 999 else text)
        if isinstance(term, Atom):
            text = quote_atom(term.name)
            if self.ops.is_operator(term.name) and max_priority < 1200 and term.name not in ("[]", "{}", "!", ";"):
                return _Text(f"({text})" if max_priority < 999 else text)
            return _Text(text)
        return self.compound(term, max_priority)

    def operand(self, term: Term, max_priority: int) -> _Doc:
        """An operand of an operator: an atom that is itself an operator is bracketed
        (`dynamic (-->)`, `- (-)`), which SWI-Prolog reads back as the atom."""
        if isinstance(term, Atom) and self.ops.is_operator(term.name) and term.name not in ("[]", "{}", "!"):
            return _Text(f"({quote_atom(term.name)})")
        return self.write(term, max_priority)

    def compound(self, term: Compound, max_priority: int) -> _Doc:
        name, args = term.name, term.args
        if name == "[|]" and len(args) == 2:
            return self.list_doc(term)
        if name == "{}" and len(args) == 1:
            return _Args("{", [self.write(args[0], 1200)], "}")
        if len(args) == 2 and self.usable(name) and self.ops.infix_op(name):
            priority, kind = self.ops.infix_op(name)
            bracketed = priority > max_priority
            if name == "," or (bracketed and name in _CONTROL):
                return self.control(term, priority, kind, bracketed)
            left_max = priority if kind == "yfx" else priority - 1
            right_max = priority if kind == "xfy" else priority - 1
            doc = _Cat([self.operand(args[0], left_max), _Text(f" {quote_atom(name)} "),
                        self.operand(args[1], right_max)])
            return _Cat([_Text("("), doc, _Text(")")]) if bracketed else doc
        if len(args) == 1 and self.usable(name) and self.ops.prefix_op(name) and name not in ("-", "+"):
            priority, kind = self.ops.prefix_op(name)
            arg_max = priority if kind == "fy" else priority - 1
            doc = _Cat([_Text(f"{quote_atom(name)} "), self.operand(args[0], arg_max)])
            return _Cat([_Text("("), doc, _Text(")")]) if priority > max_priority else doc
        return _Args(f"{quote_atom(name)}(", [self.write(a, 999) for a in args], ")")

    def control(self, term: Compound, priority: int, kind: str, bracketed: bool) -> _Doc:
        """A conjunction, or a bracketed `;`, `->` or `*->`: the goals of its right spine (the
        operators are xfy), each written as `compound` would write it."""
        parts: List[Tuple[str, Term]] = [("", term.args[0])]
        rest: Term = term.args[1]
        while isinstance(rest, Compound) and rest.name == term.name and rest.arity == 2:
            parts.append((term.name, rest.args[0]))
            rest = rest.args[1]
        parts.append((term.name, rest))
        left_max = priority if kind == "yfx" else priority - 1
        right_max = priority if kind == "xfy" else priority - 1
        docs = [(op, self.operand(t, right_max if i == len(parts) - 1 else left_max))
                for i, (op, t) in enumerate(parts)]
        if term.name == ",":
            doc: _Doc = _Conj([d for _, d in docs])
            return _Block([("", doc)]) if bracketed else doc
        if term.name == ";":                    # (If -> Then ; ...): the arrows in the layout too
            split: List[Tuple[str, _Doc]] = []
            for (op, t), (_, d) in zip(parts, docs):
                if isinstance(t, Compound) and t.name in ("->", "*->") and t.arity == 2 and isinstance(d, _Cat):
                    split.extend([(op, d.parts[0]), (t.name, d.parts[2])])
                else:
                    split.append((op, d))
            return _Block(split)
        return _Block(docs)

    def list_doc(self, term: Compound) -> _Doc:
        items: List[_Doc] = []
        t: Term = term
        while isinstance(t, Compound) and t.name == "[|]" and t.arity == 2:
            items.append(self.write(t.args[0], 999))
            t = t.args[1]
        if t != NIL:
            items[-1] = _Cat([items[-1], _Text("|"), self.write(t, 999)])
        return _Args("[", items, "]")


from .operators import EVENT_OPERATORS  # noqa: E402

_EVENT_FREE = (_PLAIN_OPERATORS - set(EVENT_OPERATORS) - {"<-", "do", "rule:", "."})
