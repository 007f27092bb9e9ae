"""ROS messages as Retalis events and back (thesis 2.2, Listing 2.3; docs/robot_io.md).

The convention is the one of the 2015 Retalis release, which its programs expect, except
for strings:

- a message is a compound term whose functor is its type with `/` spelled `__0__`
  (`geometry_msgs/PoseStamped` -> `geometry_msgs__0__PoseStamped`; ROS 2's
  `tf2_msgs/msg/TFMessage` -> `tf2_msgs__0__TFMessage`: the `msg` level is dropped) and whose
  arguments are its fields in order; a message without fields is an atom;
- nested messages are such terms, arrays are lists, `time` and `duration` (ROS 2:
  builtin_interfaces Time and Duration) are `[Sec, NSec]`;
- integers and floats are numbers (non-finite floats are 1.0Inf, -1.0Inf, 1.5NaN), bools are
  the atoms `true` and `false`;
- a string is an atom holding its text: frame id `odom` is the atom `odom`, `/odom` is
  `'/odom'`. Without `plain_strings` (a program that says `:- ros_strings(quoted).`, or
  reads its rules with `compile_event_file`), the atom holds the text between double
  quotes, as the release wrote it: `'"odom"'`.

With `wrap_topic`, the term is wrapped in the topic name (the thesis's `topic(Msg)`): `/tf`
gives `tf(tf2_msgs__0__TFMessage(...))`, `/arm/status` gives `arm__0__status(...)` (leading
slash dropped, the others spelled `__0__`). Without it, a tf message on `/tf_static` is still
wrapped, as `tf_static(tf2_msgs__0__TFMessage(...))`: the topic is what tells static
transforms from dynamic ones (tf2's rule), and the runtime's tf library reads it from there.

An event is stamped by one clock rule (`EventClock`, docs/robot_io.md "Time"): the time the
message carries (its `header.stamp`; without a header of its own, the header stamp of the
first item of its first field when that is a list of stamped messages: a `TFMessage`'s first
transform), else the latest `/clock` of the run, else its arrival on the run's clock; a
stamp of zero is not set.

Every message type of a rosbags type store works, custom types defined in a bag included:
the converter of a type is generated as Python source from its definition the first time a
message of that type is converted, compiled, and cached (`MessageConverter.source` shows
it). `generated=False` walks the definitions for every message instead (several times
slower; kept as the reference the generated code is tested against).

Back from terms to messages (`MessageConverter.message`) reads the same convention; a
header term with or without the ROS 1 `seq` fits both ROS 1 and ROS 2 headers, a time may
also be a number of seconds, and a string field accepts an atom (with or without the
release's double quotes) or a Prolog string.
"""
from __future__ import annotations

import keyword
import math
import re
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional, Tuple

from ..driver.values import String, Term, Value, atom_text, float_text, is_atom, quote_atom, read_term, write_term

# rosbags' Nodetype values (rosbags.typesys.base.Nodetype), fixed by its message model.
BASE, NAME, ARRAY, SEQUENCE = 1, 2, 3, 4

TIME_TYPES = ("builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration")
HEADER_TYPE = "std_msgs/msg/Header"
_EMPTY_FIELD = "structure_needs_at_least_one_member"    # rosbags' field of a message without fields
_FLOATS = ("float32", "float64")
_STRINGS = ("string", "wstring")


class ConversionError(ValueError):
    """A term that is not a message of the expected type, or a message that cannot be
    converted; the message says where (field path) and why."""


@dataclass(frozen=True)
class Convention:
    """How messages are written as terms (see the module docstring)."""

    plain_strings: bool = True
    wrap_topic: bool = False

    @classmethod
    def of_program(cls, engine, plain_strings: bool = False, wrap_topic: bool = False) -> "Convention":
        """The convention for `engine`'s program: its strings as it says (Engine.ros_strings),
        plain whatever it says with `plain_strings` (the --plain-strings flag)."""
        ros_strings = getattr(engine, "ros_strings", "plain")
        return cls(plain_strings=plain_strings or ros_strings == "plain", wrap_topic=wrap_topic)


def type_functor(msgtype: str) -> str:
    """`pkg/msg/Type` or `pkg/Type` -> `pkg__0__Type`."""
    parts = msgtype.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        parts = [parts[0], parts[2]]
    return "__0__".join(parts)


def topic_functor(topic: str) -> str:
    """The functor of `--wrap-topic`: `/tf` -> `tf`, `/arm/status` -> `arm__0__status`."""
    return "__0__".join(part for part in topic.split("/") if part) or "topic"


TF_MESSAGE_TYPES = ("tf2_msgs__0__TFMessage", "tf__0__tfMessage")


def static_tf_wrapper(topic: str, msgtype: str, convention: Convention) -> Optional[str]:
    """`tf_static` for a tf message on a static tf topic (`/tf_static`, `/ns/tf_static`) when
    the convention does not wrap topics anyway: the event is then `tf_static(Msg)`, which the
    runtime's tf library (prolog_runtime/rtl_tf.pl) takes as static links; None otherwise."""
    if convention.wrap_topic or topic.rstrip("/").rsplit("/", 1)[-1] != "tf_static":
        return None
    return "tf_static" if type_functor(msgtype) in TF_MESSAGE_TYPES else None


def _fields(typestore, msgtype: str) -> List[Tuple[str, tuple]]:
    try:
        _, fields = typestore.fielddefs[msgtype]
    except KeyError:
        raise ConversionError(f"unknown message type {msgtype}") from None
    return [(name, desc) for name, desc in fields if name != _EMPTY_FIELD]


# ---- strings ---------------------------------------------------------------------------

def release_string(text: str) -> str:
    """A string field in the release's form: the atom holding `"text"`."""
    if text.isprintable() and "'" not in text and "\\" not in text:
        return "'\"" + text + "\"'"
    return quote_atom('"' + text + '"')


def plain_string(text: str) -> str:
    """A string field as the atom of its text, written as writeq writes it (`odom`, `'/odom'`)."""
    return atom_text(text)


def _float_list(values) -> str:
    return "[" + ",".join(map(float_text, _items(values))) + "]"


def _int_list(values) -> str:
    return "[" + ",".join(map(str, _items(values))) + "]"


def _bool_list(values) -> str:
    return "[" + ",".join("true" if v else "false" for v in _items(values)) + "]"


def _items(values):
    return values.tolist() if hasattr(values, "tolist") else values


# ---- the converter ---------------------------------------------------------------------

class MessageConverter:
    """Converts the messages of one rosbags type store to event terms and back.

    `term(msg, msgtype)` is the term text; `event(msg, msgtype, topic, record_ns)` is the
    event text with its time in seconds; `message(term_or_text)` is (msgtype, msg)."""

    def __init__(self, typestore, convention: Convention = Convention(), generated: bool = True):
        self.typestore = typestore
        self.convention = convention
        self.generated = generated
        self._string = plain_string if convention.plain_strings else release_string
        self._term_functions: Dict[str, Callable[[Any], str]] = {}
        self._stamp_functions: Dict[str, Callable[[Any], int]] = {}
        self._sources: Dict[str, str] = {}
        self._functor_types: Optional[Dict[str, List[str]]] = None

    # -- messages to terms --

    def term(self, msg, msgtype: str) -> str:
        """The term text of `msg` (of type `msgtype`), not wrapped in its topic."""
        function = self._term_functions.get(msgtype)
        if function is None:
            function = self._term_function(msgtype)
        return function(msg)

    def term_function(self, msgtype: str) -> Callable[[Any], str]:
        """The cached function from a message of `msgtype` to its term text."""
        return self._term_functions.get(msgtype) or self._term_function(msgtype)

    def event(self, msg, msgtype: str, topic: str, record_ns: int) -> Tuple[str, float]:
        """(event text, time in seconds) of a message recorded on `topic` at `record_ns`."""
        text = self.term(msg, msgtype)
        if self.convention.wrap_topic:
            text = f"{atom_text(topic_functor(topic))}({text})"
        elif static_tf_wrapper(topic, msgtype, self.convention):
            text = f"tf_static({text})"
        stamp = self.stamp_ns(msg, msgtype)
        return text, (stamp or record_ns) / 1_000_000_000     # int / int: correctly rounded

    def stamp_ns(self, msg, msgtype: str) -> int:
        """The time `msg` carries in nanoseconds (`stamped_list` says where), 0 when none."""
        function = self._stamp_functions.get(msgtype)
        if function is None:
            if has_header(self.typestore, msgtype):
                function = _header_stamp
            else:
                items = stamped_list(self.typestore, msgtype)
                function = _no_stamp if items is None else _first_item_stamp(items)
            self._stamp_functions[msgtype] = function
        return function(msg)

    def _term_function(self, msgtype: str) -> Callable[[Any], str]:
        if self.generated and _identifiers_only(self.typestore, msgtype):
            source = self.source(msgtype)
            namespace = {"q": self._string, "fl": float_text, "fls": _float_list, "ints": _int_list,
                         "bools": _bool_list}
            exec(compile(source, f"<converter {msgtype}>", "exec"), namespace)  # noqa: S102 - our own generated code
            fast, safe = namespace["convert"], namespace["convert_safe"]

            def function(msg, fast=fast, safe=safe):
                text = fast(msg)
                # repr() writes non-finite floats as inf/nan; strings are always quoted, so
                # these letters outside quotes can only come from floats: redo it safely.
                if "inf" in text or "nan" in text:
                    return safe(msg)
                return text
        else:
            def function(msg):
                return self._generic(msg, msgtype)
        self._term_functions[msgtype] = function
        return function

    # generic introspection (the reference)

    def _generic(self, msg, msgtype: str) -> str:
        if msgtype in TIME_TYPES:
            return f"[{msg.sec},{msg.nanosec}]"
        fields = _fields(self.typestore, msgtype)
        functor = atom_text(type_functor(msgtype))
        if not fields:
            return functor
        return functor + "(" + ",".join(self._generic_value(getattr(msg, name), desc)
                                        for name, desc in fields) + ")"

    def _generic_value(self, value, desc) -> str:
        kind, detail = desc
        if kind == BASE:
            base = detail[0]
            if base in _STRINGS:
                return self._string(value)
            if base in _FLOATS:
                return float_text(value)
            if base == "bool":
                return "true" if value else "false"
            return str(value)
        if kind == NAME:
            return self._generic(value, detail)
        sub = detail[0]
        if sub[0] == BASE and sub[1][0] not in _STRINGS:
            value = _items(value)
        return "[" + ",".join(self._generic_value(item, sub) for item in value) + "]"

    # generated code

    def source(self, msgtype: str) -> str:
        """The Python source of the converter generated for `msgtype`: two functions,
        `convert` (floats written with repr) and `convert_safe` (non-finite floats too),
        plus one function per message type that occurs in a list."""
        source = self._sources.get(msgtype)
        if source is None:
            source = _Generator(self.typestore).module(msgtype)
            self._sources[msgtype] = source
        return source

    # -- terms to messages --

    def message(self, term, msgtype: Optional[str] = None) -> Tuple[str, Any]:
        """(msgtype, msg) of an event term: its value (retalisc.driver.values, as `OutputEvent.term`
        gives it) or its text (a `str` that is not a `String` is read as text: a message type's
        atom, an identifier, is its own text). Without `msgtype`, the type is
        found from the functor (`pkg__0__Type`), unwrapping a topic wrapper first when the
        convention wraps topics. Raises ConversionError saying which field is wrong."""
        if is_atom(term):
            try:
                term = read_term(term)
            except ValueError as error:
                raise ConversionError(str(error)) from None
        if msgtype is None:
            msgtype = self.message_type(term)
            if msgtype is None:
                # a known functor with the wrong arguments: say what is wrong with them
                msgtype = self._type_of(term, by_name_only=True)
            if msgtype is None:
                raise ConversionError(f"{_describe(term)} is not a message of a known type")
            if self.convention.wrap_topic and type_functor(msgtype) != _functor(term):
                term = term.args[0]
        return msgtype, self._message(term, msgtype, type_functor(msgtype))

    def message_type(self, term: Value) -> Optional[str]:
        """The message type whose terms look like `term` (functor and number of fields), or
        that of the term a topic wrapper holds when the convention wraps topics; None when
        there is none."""
        found = self._type_of(term)
        if found is None and self.convention.wrap_topic and isinstance(term, Term) and len(term.args) == 1:
            found = self._type_of(term.args[0])
        return found

    def _type_of(self, term: Value, by_name_only: bool = False) -> Optional[str]:
        if self._functor_types is None:
            index: Dict[str, List[str]] = {}
            for name in sorted(self.typestore.fielddefs):
                index.setdefault(type_functor(name), []).append(name)
            self._functor_types = index
        functor = _functor(term)
        if functor is None:
            return None
        arity = len(term.args) if isinstance(term, Term) else 0
        for msgtype in self._functor_types.get(functor, []):
            if msgtype in TIME_TYPES:
                continue
            fields = len(_fields(self.typestore, msgtype))
            if by_name_only or fields == arity or (msgtype == HEADER_TYPE and abs(fields - arity) == 1):
                return msgtype
        return None

    def _message(self, term: Value, msgtype: str, path: str):
        fields = _fields(self.typestore, msgtype)
        functor = type_functor(msgtype)
        cls = self.typestore.types[msgtype]
        if not fields:
            if not ((is_atom(term) and term == functor) or (isinstance(term, Term) and term.name == functor
                                              and not term.args)):
                raise ConversionError(f"{path}: expected {functor}, not {_describe(term)}")
            return cls(**{name: 0 for name, _ in self.typestore.fielddefs[msgtype][1]})
        if not isinstance(term, Term) or term.name != functor:
            raise ConversionError(f"{path}: expected a {functor}(...) term, not {_describe(term)}")
        args = list(term.args)
        if msgtype == HEADER_TYPE:
            names = [name for name, _ in fields]
            if names[0] == "seq" and len(args) == len(fields) - 1:
                args.insert(0, 0)                  # a ROS 2 header for a ROS 1 message
            elif names[0] != "seq" and len(args) == len(fields) + 1:
                args.pop(0)                        # a ROS 1 header (with seq) for a ROS 2 message
        if len(args) != len(fields):
            raise ConversionError(f"{path}: {functor} has {len(fields)} fields "
                                  f"({', '.join(name for name, _ in fields)}), the term {len(args)}")
        values = {name: self._value(arg, desc, f"{path}.{name}")
                  for (name, desc), arg in zip(fields, args)}
        return cls(**values)

    def _value(self, term: Value, desc, path: str):
        kind, detail = desc
        if kind == BASE:
            return self._base_value(term, detail[0], path)
        if kind == NAME:
            if detail in TIME_TYPES:
                return self._time(term, detail, path)
            return self._message(term, detail, path)
        if not isinstance(term, list):
            raise ConversionError(f"{path}: expected a list, not {_describe(term)}")
        sub, size = detail
        if kind == ARRAY and size and len(term) != size:
            raise ConversionError(f"{path}: expected a list of {size} elements, not {len(term)}")
        items = [self._value(item, sub, f"{path}[{i}]") for i, item in enumerate(term)]
        if sub[0] == BASE and sub[1][0] not in _STRINGS:
            import numpy    # optional: comes with rosbags, for arrays of numbers
            return numpy.array(items, dtype=_numpy_type(sub[1][0]))
        return items

    def _base_value(self, term: Value, base: str, path: str):
        if base in _STRINGS:
            if isinstance(term, String):
                return str(term)
            if is_atom(term):
                name = term
                if not self.convention.plain_strings and len(name) >= 2 and name[0] == '"' and name[-1] == '"':
                    return name[1:-1]
                return name
            if isinstance(term, list) and not term:
                return ""                           # the atom '[]' printed by a program as []
            raise ConversionError(f"{path}: expected a string (atom), not {_describe(term)}")
        if base == "bool":
            if (is_atom(term) and term == "true") or (not isinstance(term, str) and term == 1):
                return True
            if (is_atom(term) and term == "false") or (not isinstance(term, str) and term == 0):
                return False
            raise ConversionError(f"{path}: expected true or false, not {_describe(term)}")
        if base in _FLOATS:
            if isinstance(term, (int, float)) and not isinstance(term, bool):
                return float(term)
            raise ConversionError(f"{path}: expected a number, not {_describe(term)}")
        if isinstance(term, int) and not isinstance(term, bool):
            low, high = _int_range(base)
            if not low <= term <= high:
                raise ConversionError(f"{path}: {term} is out of the range of {base}")
            return term
        raise ConversionError(f"{path}: expected an integer ({base}), not {_describe(term)}")

    def _time(self, term: Value, msgtype: str, path: str):
        sec, nanosec = time_parts(term, path)
        return self.typestore.types[msgtype](sec=sec, nanosec=nanosec)

    def base_value(self, term: Value, base: str) -> Any:
        """The Python value of a field of ROS type `base` (a ROS primitive) given as `term`;
        ConversionError when it is not one."""
        return self._base_value(term, base, "")


def time_parts(term: Value, path: str = "") -> Tuple[int, int]:
    """(sec, nanosec) of a time term: `[Sec, NSec]` or a number of seconds."""
    if isinstance(term, list) and len(term) == 2 and all(isinstance(v, int) for v in term):
        sec, nanosec = term
    elif isinstance(term, (int, float)) and not isinstance(term, bool) and math.isfinite(term):
        total = round(term * 1_000_000_000)
        sec, nanosec = divmod(total, 1_000_000_000)
    else:
        raise ConversionError(f"{path}: expected a time [Sec, NSec] or seconds, not {_describe(term)}")
    if not 0 <= nanosec < 1_000_000_000:
        raise ConversionError(f"{path}: nanoseconds {nanosec} outside [0, 1e9)")
    return sec, nanosec


_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def _identifiers_only(typestore, msgtype: str, seen: Optional[set] = None) -> bool:
    """Whether every field name of `msgtype` (and of the types it holds) is a plain Python
    identifier, as ROS allows: the generated code names fields as attributes, and the
    definitions may come from a bag; otherwise the generic walk (getattr) converts it."""
    seen = set() if seen is None else seen
    if msgtype in seen or msgtype in TIME_TYPES:
        return True
    seen.add(msgtype)
    for name, desc in _fields(typestore, msgtype):
        if not _IDENTIFIER.match(name) or keyword.iskeyword(name):
            return False
        kind, detail = desc
        element = detail if kind == NAME else (detail[0][1] if kind in (ARRAY, SEQUENCE) and detail[0][0] == NAME else None)
        if element is not None and not _identifiers_only(typestore, element, seen):
            return False
    return True


def _header_stamp(msg) -> int:
    stamp = msg.header.stamp
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def has_header(typestore, msgtype: str) -> bool:
    """Whether `msgtype` has a top-level `header` (std_msgs/Header)."""
    return any(name == "header" and desc == (NAME, HEADER_TYPE) for name, desc in _fields(typestore, msgtype))


def stamped_list(typestore, msgtype: str) -> Optional[str]:
    """For a type without a header: the name of its first field when that is a list of
    messages with a header (a TFMessage's `transforms`), whose first item's stamp is the time
    the message carries; else None."""
    fields = _fields(typestore, msgtype)
    if not fields:
        return None
    name, (kind, detail) = fields[0]
    if kind != SEQUENCE:
        return None
    item = detail[0]
    return name if item[0] == NAME and has_header(typestore, item[1]) else None


def _first_item_stamp(field_name: str) -> Callable[[Any], int]:
    def stamp(msg) -> int:
        items = getattr(msg, field_name)
        return _header_stamp(items[0]) if len(items) else 0

    return stamp


def _no_stamp(msg) -> int:
    return 0


CLOCK_TOPIC = "/clock"          # rosgraph_msgs/Clock: a simulation's time

CLOCK_JUMP = 3600.0
"""A step of the event clock larger than this many seconds (an hour, either way) between two
messages is warned about, once a run: two clocks are mixed (sim time and wall time)."""


class EventClock:
    """The one clock of a run (docs/robot_io.md, "Time"). `time(carried, arrival_ns, topic,
    where)` is the time in seconds of a message that carries the time `carried` (seconds, 0:
    none) and arrived at `arrival_ns` (its record time): the carried time; else the latest
    `/clock` seen (`clock`); else the arrival on the run's clock: the arrival itself, or, when
    the messages carry another clock (the last one that carried a time was more than
    CLOCK_JUMP away from its arrival: sim time recorded on the wall clock), the arrival
    shifted by that difference. With `record` (`--stamp record`) every message is at its
    arrival. A step of more than CLOCK_JUMP seconds goes to `warn(text)`, once."""

    def __init__(self, warn: Callable[[str], None], record: bool = False):
        self.warn = warn
        self.record = record
        self.clock_time: Optional[float] = None     # the latest /clock
        self.offset: Optional[float] = None         # carried - arrival, of the last message carrying a time
        self.last: Optional[float] = None
        self.warned = False

    def clock(self, seconds: float) -> None:
        """A `/clock` message: the time of the messages that carry none, from now on."""
        if seconds:
            self.clock_time = seconds

    def time(self, carried: float, arrival_ns: int, topic: str, where: str) -> float:
        arrival = arrival_ns / 1_000_000_000
        if self.record:
            time = arrival
        elif carried:
            time = carried
            self.offset = carried - arrival
        elif self.clock_time is not None:
            time = self.clock_time
        elif self.offset is not None and abs(self.offset) > CLOCK_JUMP:
            time = arrival + self.offset        # the messages carry another clock (sim time)
        else:
            time = arrival
        if self.last is not None and abs(time - self.last) > CLOCK_JUMP and not self.warned:
            self.warned = True
            self.warn(f"{where}: warning: the event clock jumps from {self.last:.9f} s to {time:.9f} s "
                      f"on {topic}: two clocks are mixed (header stamps and record times?); --stamp record "
                      f"puts every message on the record clock")
        self.last = time
        return time


def _functor(term: Value) -> Optional[str]:
    if isinstance(term, Term):
        return term.name
    if is_atom(term):
        return term
    return None


def _describe(term: Value) -> str:
    text = write_term(term)
    return text if len(text) <= 60 else text[:57] + "..."


def _literal(text: str) -> str:
    """`text` as literal characters of a single-quoted f-string."""
    return text.replace("\\", "\\\\").replace("'", "\\'").replace("{", "{{").replace("}", "}}")


def _numpy_type(base: str) -> str:
    return {"bool": "bool_", "char": "uint8", "byte": "uint8", "octet": "uint8"}.get(base, base)


def _int_range(base: str) -> Tuple[int, int]:
    if base in ("char", "byte", "octet"):
        return 0, 255
    bits = int("".join(c for c in base if c.isdigit()) or 64)
    if base.startswith("u"):
        return 0, 2 ** bits - 1
    return -2 ** (bits - 1), 2 ** (bits - 1) - 1


class _Generator:
    """Python source of the converter of one message type: the term text is one f-string per
    message type, fields inlined down to the lists of messages, which get a function each."""

    def __init__(self, typestore):
        self.typestore = typestore
        self.functions: Dict[str, str] = {}     # msgtype -> function name (list element types)
        self.order: List[str] = []

    def module(self, msgtype: str) -> str:
        lines = ["# generated by retalisc.robot_io.messages for " + msgtype]
        for safe in (False, True):
            self.functions, self.order = {}, []
            suffix = "_safe" if safe else ""
            body = self.message_expr("m", msgtype, safe)
            lines += ["", f"def convert{suffix}(m):", f"    return {body}"]
            done = set()
            while len(done) < len(self.order):
                for element in list(self.order):
                    if element in done:
                        continue
                    done.add(element)
                    name = self.functions[element]
                    body = self.message_expr("m", element, safe)
                    lines += ["", f"def {name}{suffix}(m):", f"    return {body}"]
        return "\n".join(lines) + "\n"

    def message_expr(self, var: str, msgtype: str, safe: bool) -> str:
        parts = self.message_parts(var, msgtype, safe)
        return "f'" + "".join(parts) + "'"

    def message_parts(self, var: str, msgtype: str, safe: bool) -> List[str]:
        if msgtype in TIME_TYPES:
            return ["[", "{" + var + ".sec}", ",", "{" + var + ".nanosec}", "]"]
        fields = _fields(self.typestore, msgtype)
        functor = _literal(atom_text(type_functor(msgtype)))
        if not fields:
            return [functor]
        parts = [functor, "("]
        for i, (name, desc) in enumerate(fields):
            if i:
                parts.append(",")
            parts += self.value_parts(f"{var}.{name}", desc, safe)
        parts.append(")")
        return parts

    def value_parts(self, expr: str, desc, safe: bool) -> List[str]:
        kind, detail = desc
        suffix = "_safe" if safe else ""
        if kind == BASE:
            base = detail[0]
            if base in _STRINGS:
                return ["{q(" + expr + ")}"]
            if base in _FLOATS:
                return ["{fl(" + expr + ")}" if safe else "{" + expr + "!r}"]
            if base == "bool":
                return ['{"true" if ' + expr + ' else "false"}']
            return ["{" + expr + "}"]
        if kind == NAME:
            return self.message_parts(expr, detail, safe)
        sub = detail[0]
        if sub[0] == BASE:
            base = sub[1][0]
            if base in _STRINGS:
                return ['[{",".join(map(q, ' + expr + '))}]']
            if base in _FLOATS:
                return ["{fls(" + expr + ")}"]
            if base == "bool":
                return ["{bools(" + expr + ")}"]
            return ["{ints(" + expr + ")}"]
        if sub[0] == NAME:
            element = sub[1]
            name = self.functions.get(element)
            if name is None:
                name = self.functions[element] = f"element_{len(self.functions) + 1}"
                self.order.append(element)
            return ['[{",".join(map(' + name + suffix + ', ' + expr + '))}]']
        # a list of lists cannot be declared in ROS message files; rosbags' model has none
        raise ConversionError(f"nested arrays are not message fields: {desc}")
