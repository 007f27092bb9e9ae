"""Prolog terms as Python values, and the time forms an Engine accepts.

One value model for the terms that come out of the runtime (output events, ROS message
terms, memory ids): an atom is a `str`, a number an `int` or `float`, a Prolog string a
`String` (a `str` too: tell it from an atom by its type), a proper list a `list`, and a
compound term a `Term` with a `name` and a tuple of `args` in the same form
(`fire_alarm(smoke_1, [1, 2.5])` is `Term("fire_alarm", ("smoke_1", [1, 2.5]))`). A variable,
which a derived event can only carry when a rule leaves one unbound, is a `Variable`. The
result of a synchronized query, which comes among the outputs, is a `QueryAnswer`.

The runtime sends an output's term as data (`term_value` reads that form: rtl_output_data/2 in
prolog_runtime/rtl_io.pl), so an output's term is never read again from its text.
`read_term` is the one reader of term text as data (the text of an event, of a memory id):
a small tokenizer for the syntax writeq writes without operators, and for the rest (operator
terms such as `a-b`) SWI-Prolog's own reader (`ground_canonical`); `write_term` writes a
value back as Prolog text.

Times are given as event files give them: a number of seconds or a ROS stamp
`[secs, nsecs]`; from Python also a `datetime.datetime` (read as UTC when it has no time
zone, like ETALIS's `datime/7`) and a ROS time message (an object with `sec` and
`nanosec`, or `secs` and `nsecs`), both turned into `[secs, nsecs]` exactly. Whether a time
is valid is decided by the runtime's one check of input times (`rtl_input_interval/6` in
prolog_runtime/rtl_time.pl), the one the file reader uses.
"""
from __future__ import annotations

import datetime as _dt
import math
import re
from dataclasses import dataclass
from typing import Any, Dict, List, Sequence, Tuple, Union

from ..frontend.depth import with_room_for_depth
from ..frontend.lexemes import number as _number, unescape as _unescape
from .bridge import Bridge, PrologError
from ..runtime_location import runtime_dir

__all__ = ["Term", "String", "Variable", "Value", "QueryAnswer", "Time", "term_value", "read_term", "write_term",
           "ground_canonical", "time_value", "is_atom", "quote_atom", "atom_text", "float_text"]


@dataclass(frozen=True)
class Variable:
    """An unbound variable in an output term (a rule left it unbound)."""

    name: str


@dataclass(frozen=True)
class Term:
    """A compound term: `name(args...)`, each argument a Python value (see the module doc)."""

    name: str
    args: Tuple["Value", ...]

    @property
    def arity(self) -> int:
        return len(self.args)

    def __getitem__(self, index: int) -> "Value":
        return self.args[index]


class String(str):
    """A Prolog string (`"text"`): a `str` whose type tells it from an atom."""

    __slots__ = ()

    def __repr__(self) -> str:
        return f"String({str.__repr__(self)})"


Value = Union[str, String, int, float, list, Term, Variable]


def is_atom(value) -> bool:
    """Whether `value` is an atom (a `str` that is not a `String`)."""
    return type(value) is str


@dataclass(frozen=True)
class QueryAnswer:
    """The result of a synchronized query (`post_synchronized`, `query_synchronized`, `--query
    Z GOAL` in `retalisc run`), as its output line `{"query": ID, "at": Z, "status": ...,
    "answers": [...], "message": ...}` gives it: `status` is "answered", "failed" (the goal
    raised an error), "timeout" or "dropped" (the input ended first); `answers` the answers,
    each a dict mapping a variable's name to its value as writeq text (as `Engine.query_all`);
    `message` says why there are none (empty when answered)."""

    query: str
    at: Union[int, float]
    status: str
    answers: Tuple[Dict[str, str], ...]
    message: str = ""

    @classmethod
    def from_json(cls, data: dict) -> "QueryAnswer":
        return cls(str(data["query"]), data["at"], data["status"], tuple(data.get("answers") or ()),
                   data.get("message") or "")

#: A time as the Engine accepts it.
Time = Union[int, float, Sequence[int], _dt.datetime, Any]


_text_reader_loaded = False


def ground_canonical(text: str) -> str:
    """`text` read by SWI-Prolog as one ground term (rtl_text.pl: read_term from a string, never
    pasted into a goal) and written back with write_canonical/1 conventions (quoted, no
    operators). ValueError when it is not one ground term."""
    global _text_reader_loaded
    bridge = Bridge()
    if not _text_reader_loaded:           # the runtime's reader of untrusted text, once a process
        bridge.consult(str(runtime_dir() / "rtl_text.pl"))
        _text_reader_loaded = True
    try:
        out = bridge.apply("rtl_text", "rtl_ground_canonical", text)
    except PrologError as error:
        raise ValueError(f"not a term: {str(error).splitlines()[0]}") from None
    if out.startswith("!"):
        raise ValueError(out[1:])
    return out


def term_value(data) -> Value:
    """The Python value of a term in the runtime's data form (rtl_output_data/2): a number, an
    atom as a string, and tagged arrays `["c", Name, Arg...]` (a compound), `["l", Item...]` (a
    list), `["s", Text]` (a string), `["f", "inf"]` (a float that is not finite), `["v", Name]`
    (a variable)."""
    try:
        return _term_value(data)
    except RecursionError:                  # a deep term (input terms nest up to 1,000 levels)
        return with_room_for_depth(lambda: _term_value(data))


def _term_value(data) -> Value:
    if type(data) is not list:
        return data                                     # an atom or a number
    tag = data[0]
    if tag == "c":
        return Term(data[1], tuple([_term_value(arg) for arg in data[2:]]))
    if tag == "l":
        return [_term_value(item) for item in data[1:]]
    if tag == "s":
        return String(data[1])
    if tag == "f":
        return float(data[1])
    if tag == "v":
        return Variable(data[1])
    raise ValueError(f"unknown term data {data!r}")


# ---- reading term text ---------------------------------------------------------------------

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
    """The tokenizer does not handle this text; SWI-Prolog's reader will."""


def read_term(text: str) -> Value:
    """Read one ground term from `text` (no final full stop needed) into the value model.
    The syntax writeq writes for data (compounds, lists, quoted and plain atoms, strings,
    numbers; a partial list `[a|t]` as the cells `Term("[|]", ("a", "t"))`, as the runtime's
    data gives it) is read here; anything else (operators such as `a-b` or `0:'|'`, character
    codes) by SWI-Prolog's reader (`ground_canonical`: read_term from a string, never pasted
    into a goal), whose write_canonical text is then read here. Raises ValueError when `text`
    is not one ground term."""
    try:
        return _read_tokens(text)
    except _Unsupported:
        pass
    except RecursionError:                  # a deep term (input terms nest up to 1,000 levels)
        return with_room_for_depth(lambda: read_term(text))
    canonical = ground_canonical(text)
    try:
        return _read_tokens(canonical)
    except _Unsupported as error:
        raise ValueError(str(error) or f"not a data term: {text[:60]}") from None


def _read_tokens(text: str) -> Value:
    tokens = _tokens(text)
    value, position = _parse(tokens, 0)
    if position != len(tokens):
        raise _Unsupported
    return value


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
            args, i, end = _items(tokens, i + 2, ")")
            if end != ")":
                raise _Unsupported
            return Term(value, tuple(args)), i + 1
        if i + 1 < len(tokens) and tokens[i + 1][0] not in (",", ")", "]", "|"):
            raise _Unsupported            # an operator term such as a-b or - 1
        return value, i + 1
    if kind == "[]":
        return [], i + 1
    if kind == "{}":
        if i + 1 < len(tokens) and tokens[i + 1][0] == "(":   # {}(Args): a curly term, written canonically
            tokens[i] = ("atom", "{}")
            return _parse(tokens, i)
        return "{}", i + 1
    if kind == "[":
        items, i, end = _items(tokens, i + 1, "]")
        if end == "]":
            return items, i + 1
        tail, i = _parse(tokens, i + 1)            # after `|`: a partial list, '[|]'(Head, Tail) cells
        if i >= len(tokens) or tokens[i][0] != "]":
            raise _Unsupported
        if isinstance(tail, list):
            return items + tail, i + 1
        for item in reversed(items):
            tail = Term("[|]", (item, tail))
        return tail, i + 1
    raise _Unsupported


def _items(tokens, i, close):
    """The comma-separated terms from token i up to `close` (or, in a list, `|`): the items,
    the index of the token that ended them and that token's kind."""
    items = []
    while True:
        item, i = _parse(tokens, i)
        items.append(item)
        if i >= len(tokens):
            raise _Unsupported
        kind = tokens[i][0]
        if kind == ",":
            i += 1
        elif kind == close or (kind == "|" and close == "]"):
            return items, i, kind
        else:
            raise _Unsupported


# ---- writing term text ---------------------------------------------------------------------

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


def write_term(value: Value) -> str:
    """Prolog text of a value (the inverse of read_term; `True`/`False` are written as the
    atoms true and false, a `Variable` as its name)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return float_text(value)
    if isinstance(value, String):
        return '"' + _STRING_CONTROL.sub(_escape, value) + '"'
    if isinstance(value, str):
        return atom_text(value)
    if isinstance(value, list):
        return "[" + ",".join(write_term(item) for item in value) + "]"
    if isinstance(value, Term):
        return atom_text(value.name) + "(" + ",".join(write_term(arg) for arg in value.args) + ")"
    if isinstance(value, Variable):
        return value.name
    raise TypeError(f"not a term value: {value!r}")


_EPOCH = _dt.datetime(1970, 1, 1, tzinfo=_dt.timezone.utc)


def time_value(value: Time, what: str = "a time") -> Union[int, float, List[int]]:
    """`value` in a form the runtime's check of input times reads: a number, or `[secs, nsecs]`
    for stamps, datetimes and ROS time messages. Raises TypeError for values that are no time
    at all (`None`, `True`, text); whether a number or stamp is valid (finite, nanoseconds in
    range) is for that check to say."""
    if isinstance(value, bool) or value is None or isinstance(value, (str, bytes)):
        raise TypeError(f"{what} must be seconds, [secs, nsecs] or a datetime, not {value!r}")
    if isinstance(value, (int, float)):
        if value != value:
            raise ValueError(f"{what} must be a finite number, not {value!r}")
        return value                    # infinities: the runtime's check refuses them
    if isinstance(value, _dt.datetime):
        aware = value if value.tzinfo is not None else value.replace(tzinfo=_dt.timezone.utc)
        delta = aware - _EPOCH
        return [delta.days * 86400 + delta.seconds, delta.microseconds * 1000]
    for secs, nsecs in (("sec", "nanosec"), ("secs", "nsecs")):
        if hasattr(value, secs) and hasattr(value, nsecs):
            return [getattr(value, secs), getattr(value, nsecs)]
    if isinstance(value, (list, tuple)):
        if all(isinstance(v, (int, float, str)) and not isinstance(v, bool) and v == v for v in value):
            return list(value)          # the runtime's check says whether it is [secs, nsecs]
        raise TypeError(f"{what} as a list must be [secs, nsecs], not {value!r}")
    raise TypeError(f"{what} must be seconds, [secs, nsecs] or a datetime, not {value!r}")
