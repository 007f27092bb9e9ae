"""Prolog terms as Python values, and the time forms an Engine accepts.

An output event's term becomes plain Python data: an atom is a `str`, a number an `int` or
`float`, a string a `str`, a list a `list`, and a compound term a `Term` with a `name` and
a tuple of `args` in the same form (`fire_alarm(smoke_1, [1, 2.5])` is
`Term("fire_alarm", ("smoke_1", [1, 2.5]))`). A variable, which a derived event can only
carry when a rule leaves one unbound, is a `Variable`. The result of a synchronized query,
which comes among the outputs, is a `QueryAnswer`.

Times are given as event files give them: a number of seconds or a ROS stamp
`[secs, nsecs]`; from Python also a `datetime.datetime` (read as UTC when it has no time
zone, like ETALIS's `datime/7`) and a ROS time message (an object with `sec` and
`nanosec`, or `secs` and `nsecs`), both turned into `[secs, nsecs]` exactly. Whether a time
is valid is decided by the runtime's one check of input times (`rtl_input_interval/6` in
prolog_runtime/rtl_time.pl), the one the file reader uses.
"""
from __future__ import annotations

import datetime as _dt
import json
from dataclasses import dataclass
from typing import Any, Dict, List, Sequence, Tuple, Union

from ..frontend.depth import with_room_for_depth
from .bridge import Bridge, PrologError
from ..runtime_location import runtime_dir

__all__ = ["Term", "Variable", "Value", "QueryAnswer", "Time", "data_value", "ground_canonical", "parse_term",
           "time_value"]


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


Value = Union[str, int, float, list, Term, Variable]


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


_runtime_loaded = False


def parse_term(text: str) -> Value:
    """The Python value of a term written as Prolog text (as output lines carry it). The text
    is read by SWI-Prolog (`rtl_api_term_data/2`), so whatever the runtime writes reads back."""
    global _runtime_loaded
    bridge = Bridge()
    if not _runtime_loaded:
        if not bridge.once("current_predicate(rtl_api:rtl_api_term_data/2)"):    # constant text
            bridge.consult(str(runtime_dir() / "retalis.pl"))
        _runtime_loaded = True
    try:
        data = bridge.apply("rtl_api", "rtl_api_term_data", text)
    except PrologError as error:
        shown = text if len(text) <= 80 else text[:77] + "..."
        message = " ".join(str(error).split())
        raise ValueError(f"not a Prolog term: {shown!r} ({message})") from None
    try:
        return data_value(json.loads(data))
    except RecursionError:                  # a deep term (input terms nest up to 1,000 levels)
        return with_room_for_depth(lambda: data_value(json.loads(data)))


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


def data_value(data) -> Value:
    """The Python value of the JSON form of a term (see `rtl_api_term_data/2`)."""
    if not isinstance(data, list):
        return data                                     # a number
    tag = data[0]
    if tag == "a":
        return [] if data[1] == "[]" else data[1]
    if tag == "s":
        return data[1]
    if tag == "l":
        return [data_value(item) for item in data[1]]
    if tag == "c":
        return Term(data[1], tuple(data_value(arg) for arg in data[2]))
    if tag == "v":
        return Variable(data[1])
    if tag == "f":
        return float(data[1].replace("1.0Inf", "inf").replace("1.5NaN", "nan"))
    raise ValueError(f"unknown term data {data!r}")


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
