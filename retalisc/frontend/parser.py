"""Reading program text into terms.

Two steps: the lark grammar (`retalis.lark`) splits the text into clauses, each a flat
sequence of operands and names; `_Resolver` then applies the operator table to each
sequence, exactly like a Prolog reader. `:- op(P, T, N)` directives take effect for the
clauses after them.
"""
from __future__ import annotations

import bisect
import re
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional, Tuple

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from .depth import MAX_TERM_DEPTH, deepest_tree, term_depth
from .errors import RetalisSyntaxError
from .lexemes import EscapeError as _EscapeError, number as _number, unescape as _unescape
from .operators import (ARGUMENT_PRIORITY, CLAUSE_PRIORITY, ETALIS_ALIASES, EVENT_OPERATORS, OP_TYPES,
                        STANDARD_OPERATORS, OperatorTable)
from .terms import Atom, Compound, Number, Span, String, Term, Var, list_items, make_list

_GRAMMAR = (Path(__file__).with_name("retalis.lark")).read_text()
# cache=True: the LALR tables are kept in the temporary directory, keyed by the grammar's hash
# (building them took 0.4 s of every command's start-up)
_LARK = Lark(_GRAMMAR, start="program", parser="lalr", propagate_positions=True, maybe_placeholders=False,
             cache=True)


@dataclass
class ReadClause:
    """One clause as read: its term, where it starts, and the variable names in it."""

    term: Term
    span: Span
    text: str


# ---- items of a flat sequence ------------------------------------------------------------


@dataclass
class _Operand:
    term: Term
    start: int
    end: int
    functional: bool = False     # written in functional notation, name( glued to its name


@dataclass
class _Name:
    name: str
    span: Span
    start: int
    end: int
    quoted: bool = False


class _Resolver:
    """Operator-precedence parsing of one flat sequence of `_Operand`s and `_Name`s."""

    def __init__(self, items: list, ops: OperatorTable, file: str, source: "_Source"):
        self.items = items
        self.pos = 0
        self.ops = ops
        self.file = file
        self.source = source

    def error(self, message: str, at: Optional[int] = None) -> RetalisSyntaxError:
        if at is None:
            at = self.pos if self.pos < len(self.items) else len(self.items) - 1
        item = self.items[at]
        span = item.span if isinstance(item, _Name) else self.source.span_at(item.start)
        return RetalisSyntaxError(message, span)

    def peek(self, offset: int = 0):
        index = self.pos + offset
        return self.items[index] if index < len(self.items) else None

    def parse_all(self, max_priority: int) -> Term:
        term, _ = self.parse(max_priority)
        if self.pos < len(self.items):
            item = self.items[self.pos]
            if isinstance(item, _Operand) and isinstance(item.term, Var) and item.term.name.lower() in EVENT_OPERATORS:
                lower = item.term.name.lower()
                raise self.error(f"'{item.term.name}' reads as a variable; write the event operator in lowercase: '{lower}'")
            if isinstance(item, _Name) and self.ops.infix_op(item.name):
                raise self.error(f"operator priority clash at '{item.name}' (put brackets around the operands)")
            raise self.error("operator expected")
        return term

    def parse(self, max_priority: int) -> Tuple[Term, int]:
        left, left_priority = self.parse_primary(max_priority)
        return self.parse_infix(left, left_priority, max_priority)

    def parse_infix(self, left: Term, left_priority: int, max_priority: int) -> Tuple[Term, int]:
        while True:
            item = self.peek()
            if isinstance(item, _Operand) and self._is_glued_infix(item):
                # `(X-1)*(X-1)`: the lexer read `*(X-1)` as functional notation; after a
                # complete term it can only be the infix operator with a bracketed operand
                # (SWI-Prolog reads it so too).
                priority, kind = self.ops.infix_op(item.term.name)
                left_max = priority if kind == "yfx" else priority - 1
                if priority <= max_priority and left_priority <= left_max:
                    self.pos += 1
                    right, right_priority = item.term.args[0], 0
                    right, _ = self.parse_infix(right, right_priority, priority if kind == "xfy" else priority - 1)
                    left = Compound(ETALIS_ALIASES.get(item.term.name, item.term.name), (left, right), _span_of(left))
                    left_priority = priority
                    continue
            if not isinstance(item, _Name):
                return left, left_priority
            op = self.ops.infix_op(item.name)
            if op is not None:
                priority, kind = op
                left_max = priority if kind == "yfx" else priority - 1
                right_max = priority if kind == "xfy" else priority - 1
                if priority <= max_priority and left_priority <= left_max and self.peek(1) is not None:
                    self.pos += 1
                    right, _ = self.parse(right_max)
                    name = ETALIS_ALIASES.get(item.name, item.name) if item.quoted else item.name
                    left = Compound(name, (left, right), _span_of(left) or item.span)
                    left_priority = priority
                    continue
            op = self.ops.postfix.get(item.name)
            if op is not None:
                priority, kind = op
                left_max = priority if kind == "yf" else priority - 1
                if priority <= max_priority and left_priority <= left_max:
                    self.pos += 1
                    left = Compound(item.name, (left,), _span_of(left) or item.span)
                    left_priority = priority
                    continue
            return left, left_priority

    def parse_primary(self, max_priority: int) -> Tuple[Term, int]:
        item = self.peek()
        if item is None:
            raise self.error("unexpected end of clause", len(self.items) - 1)
        self.pos += 1
        if isinstance(item, _Operand):
            return item.term, 0
        name = item.name
        if name in (",", "|") and not item.quoted:          # ',' and '|' quoted are atoms
            raise self.error(f"unexpected '{name}'", self.pos - 1)
        nxt = self.peek()
        # A minus sign written directly before a number is part of the number.
        if name == "-" and not item.quoted and isinstance(nxt, _Operand) and isinstance(nxt.term, Number) \
                and nxt.start == item.end:
            self.pos += 1
            return Number(-nxt.term.value, item.span), 0
        prefix = self.ops.prefix_op(name)
        if prefix is not None and self._can_take_argument(nxt):
            priority, kind = prefix
            if priority > max_priority:
                priority = min(max_priority, ARGUMENT_PRIORITY)
            arg_max = priority if kind == "fy" else priority - 1
            saved = self.pos
            try:
                arg, _ = self.parse(arg_max)
                return Compound(name, (arg,), item.span), priority
            except RetalisSyntaxError:
                self.pos = saved
        return Atom(name, item.span), 0

    def _is_glued_infix(self, item: "_Operand") -> bool:
        term = item.term
        return (isinstance(term, Compound) and term.arity == 1 and item.functional
                and self.ops.infix_op(term.name) is not None)

    def _can_take_argument(self, nxt) -> bool:
        if nxt is None:
            return False
        if isinstance(nxt, _Operand):
            return True
        if nxt.name in (",", "|"):
            return False
        if self.ops.infix_op(nxt.name) and not self.ops.prefix_op(nxt.name):
            # `- = x`: the prefix operator stands as an atom before an infix operator,
            # unless that name is the last thing (then it is an atom operand: `- =`).
            return self.pos + 1 >= len(self.items)
        return True


def _span_of(term: Term) -> Optional[Span]:
    return getattr(term, "span", None)


class _Source:
    def __init__(self, text: str, file: str):
        self.text = text
        self.file = file
        self.line_starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def span_at(self, offset: int) -> Span:
        line = bisect.bisect_right(self.line_starts, offset)
        column = offset - self.line_starts[line - 1] + 1
        return Span(self.file, line, column)


class _Builder:
    """Turns the lark tree of one clause into a term, resolving operators."""

    def __init__(self, source: _Source, ops: OperatorTable):
        self.source = source
        self.ops = ops
        self.file = source.file

    def span(self, token_or_tree) -> Span:
        meta = token_or_tree if isinstance(token_or_tree, Token) else token_or_tree.meta
        return Span(self.file, meta.line, meta.column, getattr(meta, "end_line", 0) or 0,
                    getattr(meta, "end_column", 0) or 0)

    def unescape(self, body: str, quote: str, offset: int) -> str:
        """`_unescape`, with a bad escape reported where it is (`offset`: where `body` starts)."""
        try:
            return _unescape(body, quote)
        except _EscapeError as error:
            raise RetalisSyntaxError(error.message, self.source.span_at(offset + error.offset)) from None

    def sequence(self, tree: Tree, max_priority: int) -> Term:
        items = [self.item(child) for child in tree.children]
        resolver = _Resolver(items, self.ops, self.file, self.source)
        return resolver.parse_all(max_priority)

    def item(self, node):
        if isinstance(node, Token):
            if node.type in ("COMMA", "BAR"):
                return _Name(str(node), self.span(node), node.start_pos, node.end_pos)
            raise AssertionError(node.type)
        if node.data == "name":
            token = node.children[0]
            text = str(token)
            if token.type == "NAME" and text[0].isupper():      # a non-ASCII capital: a variable
                return _Operand(Var(text, self.span(token)), token.start_pos, token.end_pos, False)
            quoted = token.type == "QUOTED_NAME"
            name = self.unescape(text[1:-1], "'", token.start_pos + 1) if quoted else text
            return _Name(name, self.span(token), token.start_pos, token.end_pos, quoted)
        term = self.operand(node)
        return _Operand(term, node.meta.start_pos, node.meta.end_pos, node.data == "compound")

    def operand(self, node: Tree) -> Term:
        kind = node.data
        span = self.span(node)
        if kind == "variable":
            return Var(str(node.children[0]), span)
        if kind == "number":
            return Number(_number(str(node.children[0])), span)
        if kind == "char_code":
            body = str(node.children[0])[2:]
            start = node.meta.start_pos + 2
            char = "'" if body == "''" else self.unescape(body, "'", start) if body.startswith("\\") else body
            return Number(ord(char[0]), span)
        if kind == "string":
            return String(self.unescape(str(node.children[0])[1:-1], '"', node.meta.start_pos + 1), span)
        if kind == "backquoted":
            text = self.unescape(str(node.children[0])[1:-1], "`", node.meta.start_pos + 1)
            return make_list([Number(ord(c)) for c in text])
        if kind == "compound":
            functor = str(node.children[0])[:-1]
            if functor.startswith("'"):
                functor = self.unescape(functor[1:-1], "'", node.meta.start_pos + 1)
            # SWI-Prolog reads an argument up to priority 1200 (`ins_event_rule(d(Y) <- c(Y))`,
            # `f(a :- b)`), not 999 as ISO; a labelled rule (1210) may be an argument too
            args = tuple(self.sequence(child, CLAUSE_PRIORITY) for child in node.children[1:])
            return Compound(functor, args, span)
        if kind == "empty_list":
            return Atom("[]", span)
        if kind == "list":
            args = [self.sequence(child, CLAUSE_PRIORITY) for child in node.children]
            # the grammar cannot tell "[a, b | T]" from "[a, b]" by child count alone
            if self._has_tail(node):
                return make_list(args[:-1], args[-1])
            return make_list(args)
        if kind == "empty_curly":
            return Atom("{}", span)
        if kind == "curly":
            return Compound("{}", (self.sequence(node.children[0], 1200),), span)
        if kind == "bracketed":
            term = self.sequence(node.children[0], 1200)
            return term
        raise AssertionError(kind)

    def _has_tail(self, node: Tree) -> bool:
        text = self.source.text[node.meta.start_pos:node.meta.end_pos]
        # find a top-level '|' in the list text (outside nested brackets and quotes)
        depth = 0
        i = 0
        quote = None
        while i < len(text):
            c = text[i]
            if quote:
                if c == "\\":
                    i += 2
                    continue
                if c == quote:
                    quote = None
            elif c in "'\"`":
                if c == "'" and i > 0 and text[i - 1] == "0" and (i < 2 or not text[i - 2].isalnum()):
                    i += 2
                    continue
                quote = c
            elif c == "%":
                nl = text.find("\n", i)
                i = len(text) if nl < 0 else nl
                continue
            elif c in "([{":
                depth += 1
            elif c in ")]}":
                depth -= 1
            elif c == "|" and depth == 1:
                return True
            i += 1
        return False


def read_program(text: str, file: str = "<program>", ops: Optional[OperatorTable] = None) -> List[ReadClause]:
    """Read every clause of a program; raise RetalisSyntaxError at the first error."""
    source = _Source(text, file)
    try:
        tree = _LARK.parse(text)
    except UnexpectedInput as exc:
        raise _lark_error(exc, source) from None
    ops = (ops or STANDARD_OPERATORS).copy()
    builder = _Builder(source, ops)
    clauses = []
    for clause_tree in tree.children:
        span = builder.span(clause_tree)
        term = _build_clause(builder, clause_tree, span)
        clauses.append(ReadClause(term, span, text[clause_tree.meta.start_pos:clause_tree.meta.end_pos]))
        _apply_op_directive(term, ops)
    return clauses


def _build_clause(builder: "_Builder", clause_tree: Tree, span: Span) -> Term:
    """The term of one clause; a located error when it nests deeper than MAX_TERM_DEPTH."""
    depth, node = deepest_tree(clause_tree)
    if depth > 2 * MAX_TERM_DEPTH + 2:         # two tree levels per level of brackets
        raise RetalisSyntaxError(_too_deep(), builder.span(node) if node.meta and not node.meta.empty else span)
    try:
        term = builder.sequence(clause_tree.children[0], CLAUSE_PRIORITY)
    except RecursionError:
        raise RetalisSyntaxError(_too_deep(), span) from None
    if term_depth(term) > MAX_TERM_DEPTH:
        raise RetalisSyntaxError(_too_deep(), span)
    return term


def _too_deep() -> str:
    return f"clause too deep: terms may nest at most {MAX_TERM_DEPTH} levels (brackets, arguments, operators)"


def read_term(text: str, file: str = "<term>", ops: Optional[OperatorTable] = None) -> Term:
    """Read a single term (with or without a final full stop)."""
    stripped = text.strip()
    if not stripped.endswith(".") or stripped.endswith(".."):
        stripped += " ."
    else:
        stripped += " "
    clauses = read_program(stripped, file, ops)
    if len(clauses) != 1:
        raise RetalisSyntaxError("expected exactly one term", Span(file, 1, 1))
    return clauses[0].term


def _apply_op_directive(term: Term, ops: OperatorTable) -> None:
    if not (isinstance(term, Compound) and term.name == ":-" and term.arity == 1):
        return
    goal = term.args[0]
    goals = []
    while isinstance(goal, Compound) and goal.name == "," and goal.arity == 2:
        goals.append(goal.args[0])
        goal = goal.args[1]
    goals.append(goal)
    for g in goals:
        if isinstance(g, Compound) and g.name == "op" and g.arity == 3:
            priority, kind, names = g.args
            # one SWI-Prolog refuses changes nothing (the loadable pass reports it at its place)
            if not (isinstance(priority, Number) and isinstance(priority.value, int)
                    and 0 <= priority.value <= 1200 and isinstance(kind, Atom) and kind.name in OP_TYPES):
                continue
            names_list = list_items(names)
            if names_list is None:
                names_list = [names]
            for n in names_list:
                if isinstance(n, Atom):
                    ops.add(priority.value, kind.name, n.name)


def _lark_error(exc: UnexpectedInput, source: _Source) -> RetalisSyntaxError:
    line = getattr(exc, "line", None) or 1
    column = getattr(exc, "column", None) or 1
    if isinstance(exc, UnexpectedCharacters):
        char = source.text[exc.pos_in_stream] if exc.pos_in_stream < len(source.text) else "end of file"
        message = f"unexpected character {char!r}"
    elif isinstance(exc, UnexpectedEOF):
        line = source.text.count("\n") + 1
        column = len(source.text) - source.text.rfind("\n")
        message = "unexpected end of file (missing '.' at the end of a clause?)"
    elif isinstance(exc, UnexpectedToken):
        token = exc.token
        if token.type == "$END":
            line = source.text.rstrip().count("\n") + 1
            last = source.text.rstrip()
            column = len(last) - last.rfind("\n")
            message = "unexpected end of file (missing '.' at the end of the last clause?)"
        else:
            expected = _describe_expected(exc.expected)
            message = f"unexpected {_describe_token(token)}" + (f"; expected {expected}" if expected else "")
    else:
        message = str(exc).splitlines()[0]
    return RetalisSyntaxError(message, Span(source.file, line, column))


_TOKEN_NAMES = {"END": "end of clause '.'", "RPAR": "')'", "RSQB": "']'", "RBRACE": "'}'",
                "COMMA": "','", "BAR": "'|'", "LPAR": "'('", "LSQB": "'['", "LBRACE": "'{'"}


def _describe_token(token: Token) -> str:
    if token.type == "END":
        return "end of clause '.' (unbalanced brackets?)"
    return f"{str(token)!r}"


def _describe_expected(expected) -> str:
    names = sorted({_TOKEN_NAMES.get(e, "") for e in expected} - {""})
    return " or ".join(names[:4])
