"""ROS 1 messages handed to the runtime as their bytes: the runtime builds the event term.

The text conversion (messages.py) decodes a message with rosbags, writes its term as text
and the runtime parses that text: for a tf message of 30 transforms, about 7 KB written and
read again, most of the input cost of the NAO application (docs/nao_benchmark). For ROS 1
data this module takes a shorter road: it describes each message type once as a *schema*
(the wire layout and the term to build, prolog_runtime/c/rtl_ros1.c) and registers it with
the runtime; then each message goes to the runtime as its serialized bytes
(`engine.Ros1Bytes`) and the C helper builds the same term the text conversion gives. The
time the message carries is read from the bytes too (the header stamp, or a TFMessage's first
transform's, when its position is fixed), as `MessageConverter.stamp_ns` gives it.

ROS 2 messages (`cdr=True`: the live ROS 2 and Zenoh nodes, whose messages are CDR) take the
same road: the schema says `cdr(...)` and the helper reads the bytes with CDR's alignment;
the stamp is read when the header is the type's first field (or its stamped list's items').

A type takes the text road when the schema cannot say it (a base type the helper does not
read, a header that is not at a fixed place, a ROS 1 header without `seq` in the store),
when the runtime has no C helper, and message by message when the helper refuses the bytes
(not one message of the type, a string that is not UTF-8, a float that is not finite): the
caller then converts that message with MessageConverter, which reports what is wrong.
"""
from __future__ import annotations

import struct
from typing import Callable, Dict, List, Optional, Tuple

from ..driver.values import atom_text
from .messages import (ARRAY, BASE, HEADER_TYPE, NAME, SEQUENCE, TIME_TYPES, Convention, _fields, has_header,
                       stamped_list, static_tf_wrapper, topic_functor, type_functor)
from ..driver.engine import Ros1Bytes

_BASES = {"float32": ("f32", 4), "float64": ("f64", 8), "int8": ("i8", 1), "byte": ("i8", 1),
          "uint8": ("u8", 1), "char": ("u8", 1), "int16": ("i16", 2), "uint16": ("u16", 2),
          "int32": ("i32", 4), "uint32": ("u32", 4), "int64": ("i64", 8), "uint64": ("u64", 8),
          "bool": ("bool", 1)}
_STAMP_FORMATS = {("int32", "uint32"): "<iI", ("uint32", "uint32"): "<II", ("int32", "int32"): "<ii"}


class _NoSchema(Exception):
    """The type cannot be described by a schema; its messages take the text road."""


class Ros1Terms:
    """The schemas of one type store's messages, registered with `engine`. `event(...)` is
    `(Ros1Bytes, seconds)` for a message, or None when its type takes the text road."""

    def __init__(self, engine, typestore, convention: Convention = Convention(), cdr: bool = False):
        self.engine = engine
        self.cdr = cdr              # the bytes are CDR (ROS 2), the types those of `typestore`
        self.typestore = typestore
        self.convention = convention
        self._string = "ps" if convention.plain_strings else "rs"
        self._types: Dict[Tuple[str, str], Optional[Tuple[int, Optional[Callable[[bytes], int]]]]] = {}
        self._ros1_bytes = None

    def event(self, raw, msgtype: str, topic: str, record_ns: int, record_stamp: bool = False):
        """(Ros1Bytes, time in seconds) of the message `raw` (its ROS 1 bytes) recorded on
        `topic` at `record_ns`; None when the type takes the text road. The time is the one
        the message carries (stamp_ns) unless `record_stamp` (or it carries none, or zero):
        then `record_ns`."""
        key = (msgtype, topic if self.convention.wrap_topic or static_tf_wrapper(topic, msgtype, self.convention) else "")
        entry = self._types.get(key, False)
        if entry is False:
            entry = self._types[key] = self._register(msgtype, topic)
        if entry is None:
            return None
        handle, stamp = entry
        data = bytes(raw)
        stamp_ns = 0
        if stamp is not None and not record_stamp:
            try:
                stamp_ns = stamp(data)
            except struct.error:            # too short: the text road says what is wrong
                return None
        return self._ros1_bytes(handle, data), (stamp_ns or record_ns) / 1_000_000_000

    def bytes_types(self) -> List[str]:
        """The message types (with their topic when topics are wrapped) that took the bytes
        road so far."""
        return sorted(msgtype + (f" on {topic}" if topic else "")
                      for (msgtype, topic), entry in self._types.items() if entry is not None)

    # ---- schemas ----------------------------------------------------------------------------

    def schema(self, msgtype: str, topic: str = "") -> str:
        """The schema text of `msgtype` (wrapped in the topic's functor when the convention
        wraps topics). Raises _NoSchema when the type cannot be described."""
        text = self._message(msgtype)
        if self.convention.wrap_topic:
            text = f"w({atom_text(topic_functor(topic))},{text})"
        elif static_tf_wrapper(topic, msgtype, self.convention):
            text = f"w({static_tf_wrapper(topic, msgtype, self.convention)},{text})"
        return f"cdr({text})" if self.cdr else text

    def _register(self, msgtype: str, topic: str):
        self._ros1_bytes = Ros1Bytes
        try:
            text = self.schema(msgtype, topic)
            stamp = self._stamp_reader(msgtype)
        except (_NoSchema, KeyError):
            return None
        handle = self.engine.ros1_schema(text)
        if handle is None:
            return None
        return handle, stamp

    def _message(self, msgtype: str) -> str:
        if msgtype in TIME_TYPES:
            fields = dict(_fields(self.typestore, msgtype))
            if list(fields) != ["sec", "nanosec"]:
                raise _NoSchema(msgtype)
            return "tl([" + ",".join(self._value(fields[name]) for name in ("sec", "nanosec")) + "])"
        fields = _fields(self.typestore, msgtype)
        if msgtype == HEADER_TYPE and not self.cdr and (not fields or fields[0][0] != "seq"):
            raise _NoSchema("a ROS 1 header has seq")       # rosbags skips it: the text road
        return f"m({atom_text(type_functor(msgtype))},[" + ",".join(self._value(desc) for _, desc in fields) + "])"

    def _value(self, desc) -> str:
        kind, detail = desc
        if kind == BASE:
            return self._base(detail[0])
        if kind == NAME:
            return self._message(detail)
        if kind == ARRAY:
            sub, size = detail
            return f"a({int(size)},{self._value(sub)})"
        if kind == SEQUENCE:
            return f"q({self._value(detail[0])})"
        raise _NoSchema(str(desc))

    def _base(self, base: str) -> str:
        if base in ("string", "wstring"):
            if base == "wstring":
                raise _NoSchema(base)
            return self._string
        try:
            return _BASES[base][0]
        except KeyError:
            raise _NoSchema(base) from None

    # ---- the stamp ----------------------------------------------------------------------------

    def _stamp_reader(self, msgtype: str) -> Optional[Callable[[bytes], int]]:
        """A function from the bytes to the time the message carries in ns, as
        MessageConverter.stamp_ns gives it (`header.stamp`, or the first item's of a stamped
        list: a TFMessage's first transform; 0 for an empty list); None for a type that
        carries no time. Raises _NoSchema when the stamp is not at a fixed offset."""
        if self.cdr:
            return self._cdr_stamp_reader(msgtype)
        offset = self._header_stamp_offset(msgtype)
        if offset is None:
            items = stamped_list(self.typestore, msgtype)
            if items is None:
                return None
            item_offset = self._header_stamp_offset(dict(_fields(self.typestore, msgtype))[items][1][0][1])
            first = 4 + item_offset                 # after the list's length (uint32)
        time_fields = _fields(self.typestore, "builtin_interfaces/msg/Time")
        layout = tuple(desc[1][0] if desc[0] == BASE else None for _, desc in time_fields)
        if [name for name, _ in time_fields] != ["sec", "nanosec"] or layout not in _STAMP_FORMATS:
            raise _NoSchema("the stamp")
        unpack = struct.Struct(_STAMP_FORMATS[layout]).unpack_from

        if offset is not None:
            def stamp(data: bytes, unpack=unpack, offset=offset) -> int:
                sec, nanosec = unpack(data, offset)
                return sec * 1_000_000_000 + nanosec
        else:
            def stamp(data: bytes, unpack=unpack, first=first) -> int:
                if not int.from_bytes(data[:4], "little"):
                    return 0
                sec, nanosec = unpack(data, first)
                return sec * 1_000_000_000 + nanosec

        return stamp

    def _cdr_stamp_reader(self, msgtype: str) -> Optional[Callable[[bytes], int]]:
        """As _stamp_reader, for CDR bytes: the header must be the first field (of the type,
        or of its stamped list's items) and its stamp the header's first, at the payload's
        start (4: after the encapsulation header) or after the list's count (8)."""
        def header_first(name: str) -> bool:
            fields = _fields(self.typestore, name)
            if not fields or fields[0] != ("header", (NAME, HEADER_TYPE)):
                raise _NoSchema("the header is not the first field")
            header = _fields(self.typestore, HEADER_TYPE)
            if not header or header[0][0] != "stamp":
                raise _NoSchema("the stamp is not the header's first field")
            return True

        time_fields = _fields(self.typestore, "builtin_interfaces/msg/Time")
        layout = tuple(desc[1][0] if desc[0] == BASE else None for _, desc in time_fields)
        if [name for name, _ in time_fields] != ["sec", "nanosec"] or layout not in _STAMP_FORMATS:
            raise _NoSchema("the stamp")
        unpack = struct.Struct(_STAMP_FORMATS[layout]).unpack_from
        if has_header(self.typestore, msgtype):
            header_first(msgtype)

            def stamp(data: bytes, unpack=unpack) -> int:
                sec, nanosec = unpack(data, 4)
                return sec * 1_000_000_000 + nanosec
            return stamp
        items = stamped_list(self.typestore, msgtype)
        if items is None:
            return None
        fields = _fields(self.typestore, msgtype)
        if fields[0][0] != items:
            raise _NoSchema("the stamped list is not the first field")
        header_first(dict(fields)[items][1][0][1])

        def stamp(data: bytes, unpack=unpack) -> int:
            if not int.from_bytes(data[4:8], "little"):
                return 0
            sec, nanosec = unpack(data, 8)
            return sec * 1_000_000_000 + nanosec
        return stamp

    def _header_stamp_offset(self, msgtype: str) -> Optional[int]:
        """The offset of `header.stamp` in the bytes of a `msgtype` message; None when it has
        no header. Raises _NoSchema when the offset is not fixed."""
        fields = _fields(self.typestore, msgtype)
        if not has_header(self.typestore, msgtype):
            return None
        offset = 0
        for name, desc in fields:
            if name == "header" and desc == (NAME, HEADER_TYPE):
                break
            offset += self._fixed_size(desc)
        for name, desc in _fields(self.typestore, HEADER_TYPE):
            if name == "stamp":
                break
            offset += self._fixed_size(desc)
        return offset

    def _fixed_size(self, desc) -> int:
        kind, detail = desc
        if kind == BASE and detail[0] in _BASES:
            return _BASES[detail[0]][1]
        if kind == NAME:
            return sum(self._fixed_size(d) for _, d in _fields(self.typestore, detail))
        if kind == ARRAY:
            return int(detail[1]) * self._fixed_size(detail[0])
        raise _NoSchema("not a fixed size")
