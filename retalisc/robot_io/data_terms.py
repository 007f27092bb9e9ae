"""Ground data terms as Python values, and back to Prolog text.

The event terms that carry ROS messages are data: compounds, lists, atoms, strings and
numbers, written by the runtime with writeq. `read_data_term` reads such text into

    int | float                  numbers (1.0Inf, -1.0Inf and 1.5NaN are floats)
    Atom(name)                   atoms ([] is the empty list, not an atom)
    String(text)                 SWI-Prolog strings ("text")
    Compound(name, args)         compound terms (frontend.terms.Compound)
    list                         proper lists

with a small tokenizer that handles exactly this syntax, several times faster than the
program parser. Text it does not handle (operators such as `a-b` or `0:'|'`, which writeq
prints for compounds whose functor is an operator) is read by SWI-Prolog itself (read_term
from a string) and written back with write_canonical/1, which the tokenizer reads: every
term writeq can print is read.
"""
from __future__ import annotations

import math
import re
from typing import Union

from ..frontend.lexemes import number as _number, unescape as _unescape
from ..frontend.terms import Atom, Compound, String
from ..driver.values import ground_canonical

DataTerm = Union[int, float, Atom, String, Compound, list]

_TOKEN = re.compile(r"""
    \s*(?:
      (?P<num>-?(?:0'(?:\\.|[^\\])|0x[0-9a-fA-F]+|0o[0-7]+|0b[01]+
          |\d[\d_]*(?:\.\d+(?:[eE][+-]?\d+)?(?:Inf|NaN)?|[eE][+-]?\d+)?))
     |(?P<name>[^\W\d_]\w*)
     |'(?P<qatom>(?:[^'\\]|\\x[0-9a-fA-F]+\\|\\[0-7]+\\|\\.|'')*)'
     |"(?P<str>(?:[^"\\]|\\x[0-9a-fA-F]+\\|\\[0-7]+\\|\\.|"")*)"
     |(?P<punct>\[\]|\{\}|[()\[\],|])
     |(?P<solo>[!;])
     |(?P<sym>(?:[-+*/\\^<>=~:.?@#&$]|[^\x00-\x7f\w\s])+)
    )""", re.VERBOSE | re.DOTALL)


class _Unsupported(Exception):
    """The fast reader does not handle this text; the full reader will."""


def read_data_term(text: str) -> DataTerm:
    """Read one ground term from `text` (no final period needed). Raises ValueError when
    `text` is not one ground term."""
    try:
        return _read_fast(text)
    except _Unsupported:
        pass
    canonical = _canonical(text)
    try:
        return _read_fast(canonical)
    except _Unsupported as error:
        raise ValueError(str(error) or f"not a data term: {text[:60]}") from None


def _read_fast(text: str) -> DataTerm:
    tokens = _tokens(text)
    value, position = _parse(tokens, 0)
    if position != len(tokens):
        raise _Unsupported
    return value


def _canonical(text: str) -> str:
    """`text` read by SWI-Prolog (read_term from a string, never pasted into a goal) and
    written back with write_canonical/1: no operators left, which the fast reader reads."""
    return ground_canonical(text)


def _tokens(text: str) -> list:
    tokens = []
    position, end = 0, len(text)
    match = _TOKEN.match
    while True:
        m = match(text, position)
        if m is None or m.end() == position:
            if text[position:].strip():
                raise _Unsupported
            return tokens
        position = m.end()
        kind = m.lastgroup
        value = m.group(kind)
        if kind == "num":
            if value.startswith("0'") or value.startswith("-0'"):
                raise _Unsupported       # character codes: rare, the full reader knows them
            tokens.append(("num", _number_value(value)))
        elif kind == "name":
            if value[0].isupper() or value[0].istitle():
                raise _Unsupported          # a variable
            tokens.append(("atom", value))
        elif kind == "qatom":
            tokens.append(("atom", _unescape(value, "'") if ("\\" in value or "''" in value) else value))
        elif kind == "str":
            tokens.append(("str", _unescape(value, '"') if ("\\" in value or '""' in value) else value))
        elif kind == "sym" or kind == "solo":
            tokens.append(("atom", value))
        else:
            tokens.append((value, None))
        if position >= end:
            return tokens


def _number_value(text: str):
    negative = text.startswith("-")
    value = _number(text[1:] if negative else text)
    return -value if negative else value


def _parse(tokens: list, i: int):
    if i >= len(tokens):
        raise _Unsupported
    kind, value = tokens[i]
    if kind == "num" or kind == "str":
        result = value if kind == "num" else String(value)
        return result, i + 1
    if kind == "atom":
        if i + 1 < len(tokens) and tokens[i + 1][0] == "(":
            args = []
            i += 2
            while True:
                arg, i = _parse(tokens, i)
                args.append(arg)
                if i >= len(tokens):
                    raise _Unsupported
                if tokens[i][0] == ",":
                    i += 1
                elif tokens[i][0] == ")":
                    return Compound(value, tuple(args)), i + 1
                else:
                    raise _Unsupported
        if i + 1 < len(tokens) and tokens[i + 1][0] not in (",", ")", "]", "|"):
            raise _Unsupported            # an operator term such as a-b or - 1
        return Atom(value), i + 1
    if kind == "[]":
        return [], i + 1
    if kind == "{}":
        if i + 1 < len(tokens) and tokens[i + 1][0] == "(":   # {}(Args): a curly term, written canonically
            tokens[i] = ("atom", "{}")
            return _parse(tokens, i)
        return Atom("{}"), i + 1
    if kind == "[":
        items = []
        i += 1
        while True:
            item, i = _parse(tokens, i)
            items.append(item)
            if i >= len(tokens):
                raise _Unsupported
            if tokens[i][0] == ",":
                i += 1
            elif tokens[i][0] == "]":
                return items, i + 1
            elif tokens[i][0] == "|":
                raise _Unsupported("not a proper list")
            else:
                raise _Unsupported
    raise _Unsupported


# ---- writing ---------------------------------------------------------------------------

_SOLO = re.compile(r"[a-z][A-Za-z0-9_]*\Z")


_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f'\\]")
_STRING_CONTROL = re.compile(r'[\x00-\x1f\x7f-\x9f"\\]')


def quote_atom(text: str) -> str:
    """`text` as a quoted Prolog atom that reads back as exactly `text`: quotes, backslashes
    and control characters escaped, every other character as it is (SWI-Prolog does not read
    back the \\x escapes it writes for some unassigned code points)."""
    if _CONTROL.search(text) is None:
        return "'" + text + "'"
    return "'" + _CONTROL.sub(_escape, text) + "'"


def _escape(match) -> str:
    c = match.group()
    if c in "'\"\\":
        return "\\" + c
    if c == "\n":
        return "\\n"
    if c == "\t":
        return "\\t"
    return f"\\x{ord(c):x}\\"


def atom_text(name: str) -> str:
    """An atom as writeq writes it: unquoted when it may be."""
    return name if _SOLO.match(name) else quote_atom(name)


def float_text(value: float) -> str:
    """A float as Prolog text that reads back as the same float (1.0Inf, 1.5NaN)."""
    if math.isfinite(value):
        return repr(value)
    if math.isnan(value):
        return "1.5NaN"
    return "1.0Inf" if value > 0 else "-1.0Inf"


def write_data_term(value: DataTerm) -> str:
    """Prolog text of a data term (the inverse of read_data_term)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return float_text(value)
    if isinstance(value, Atom):
        return atom_text(value.name)
    if isinstance(value, String):
        return '"' + _STRING_CONTROL.sub(_escape, value.text) + '"'
    if isinstance(value, list):
        return "[" + ",".join(write_data_term(item) for item in value) + "]"
    if isinstance(value, Compound):
        return atom_text(value.name) + "(" + ",".join(write_data_term(arg) for arg in value.args) + ")"
    raise TypeError(f"not a data term: {value!r}")
