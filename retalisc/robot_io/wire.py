"""Event terms straight to serialized messages: CDR (ROS 2, little-endian, with its 4-byte
encapsulation header) or ROS 1 bytes, written from the term's data (`OutputEvent.term`) by a
writer compiled once per message type, without building a rosbags message object per output.

`MessageWriter.write(term, msgtype)` gives the same bytes as `MessageConverter.message`
followed by rosbags' `serialize_cdr`/`serialize_ros1` (tests/test_robot_io_wire.py checks it
against rosbags for generated values) and accepts the same terms: the values of the fields
are checked by the converter's own rules (`MessageConverter.base_value`, `time_parts`). A term
the writer refuses goes through the converter, which raises the ConversionError that says
which field is wrong; a type with a field the writer does not know (wstring) is written by
rosbags.
"""
from __future__ import annotations

import math
import struct
from typing import Callable, Dict, List, Optional

from ..driver.values import Term, is_atom
from .messages import (ARRAY, BASE, HEADER_TYPE, NAME, SEQUENCE, TIME_TYPES, ConversionError, MessageConverter,
                       time_parts, type_functor)

CDR_HEADER = b"\x00\x01\x00\x00"        # CDR_LE encapsulation
_EMPTY_FIELD = "structure_needs_at_least_one_member"
_FORMATS = {"bool": "?", "int8": "b", "uint8": "B", "byte": "B", "char": "B", "octet": "B",
            "int16": "h", "uint16": "H", "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q",
            "float32": "f", "float64": "d"}
_COUNT = struct.Struct("<I")
_FLOAT32 = struct.Struct("<f")

Writer = Callable[[object, bytearray], None]


class Unsupported(Exception):
    """A field type the writer does not write (rosbags does)."""


class MessageWriter:
    """Writes event terms as serialized messages of one type store (`wire`: "cdr" or "ros1")."""

    def __init__(self, converter: MessageConverter, wire: str):
        if wire not in ("cdr", "ros1"):
            raise ValueError(f"unknown wire {wire!r}")
        self.converter = converter
        self.typestore = converter.typestore
        self.cdr = wire == "cdr"
        self._writers: Dict[str, Optional[Writer]] = {}

    def write(self, term, msgtype: str) -> bytes:
        """The serialized message of type `msgtype` (a store name) given as `term`."""
        writer = self._writers.get(msgtype, False)
        if writer is False:
            writer = self._writers[msgtype] = self._top(msgtype)
        if writer is not None:
            out = bytearray(CDR_HEADER) if self.cdr else bytearray()
            try:
                writer(term, out)
                return bytes(out)
            except (ConversionError, TypeError, ValueError, AttributeError, struct.error):
                pass            # the converter says what is wrong (or rosbags writes it)
        _, msg = self.converter.message(term, msgtype)
        data = self.typestore.serialize_cdr(msg, msgtype) if self.cdr else self.typestore.serialize_ros1(msg, msgtype)
        return bytes(data)

    def _top(self, msgtype: str) -> Optional[Writer]:
        try:
            return self._message(msgtype, {})
        except (Unsupported, KeyError):
            return None

    # -- compiling --

    def _align(self, size: int) -> Callable[[bytearray], None]:
        if not self.cdr or size == 1:
            return _no_align
        mask = size - 1

        def align(out: bytearray) -> None:
            pad = -(len(out) - 4) & mask
            if pad:
                out += bytes(pad)
        return align

    def _message(self, msgtype: str, done: Dict[str, Writer]) -> Writer:
        if msgtype in done:
            return done[msgtype]
        slot: List[Writer] = []
        done[msgtype] = lambda term, out: slot[0](term, out)      # a type that holds itself
        raw = self.typestore.fielddefs[msgtype][1]
        fields = [(name, desc) for name, desc in raw if name != _EMPTY_FIELD]
        functor = type_functor(msgtype)
        if not fields:
            empty = bool(raw) and self.cdr        # rosbags' placeholder field: one uint8 in CDR

            def write_empty(term, out: bytearray) -> None:
                if not (term == functor if is_atom(term) else isinstance(term, Term) and term.name == functor
                        and not term.args):
                    raise ConversionError(functor)
                if empty:
                    out.append(0)
            slot.append(write_empty)
            return write_empty
        writers = [self._field(desc, done) for _, desc in fields]
        count = len(fields)
        names = [name for name, _ in fields]
        header_seq = msgtype == HEADER_TYPE and names[0] == "seq"
        header_plain = msgtype == HEADER_TYPE and names[0] != "seq"

        def write_message(term, out: bytearray) -> None:
            if not isinstance(term, Term) or term.name != functor:
                raise ConversionError(functor)
            args = term.args
            if len(args) != count:
                if header_seq and len(args) == count - 1:
                    args = (0, *args)
                elif header_plain and len(args) == count + 1:
                    args = args[1:]
                else:
                    raise ConversionError(functor)
            for writer, arg in zip(writers, args):
                writer(arg, out)
        slot.append(write_message)
        return write_message

    def _field(self, desc, done: Dict[str, Writer]) -> Writer:
        kind, detail = desc
        if kind == BASE:
            return self._base(detail[0])
        if kind == NAME:
            return self._time(detail) if detail in TIME_TYPES else self._message(detail, done)
        if kind not in (ARRAY, SEQUENCE):
            raise Unsupported(kind)
        sub, size = detail
        fixed = size if kind == ARRAY else 0
        count_align = self._align(4)
        if sub[0] == BASE and sub[1][0] in _FORMATS:
            base = sub[1][0]
            value = self.converter.base_value
            code = _FORMATS[base]
            align = self._align(struct.calcsize(code))
            finite32 = base == "float32"

            def write_numbers(term, out: bytearray) -> None:
                if not isinstance(term, list) or fixed and len(term) != fixed:
                    raise ConversionError("list")
                values = [value(item, base) for item in term]
                if finite32:
                    values = [_float32(v) for v in values]
                if not fixed:
                    count_align(out)
                    out += _COUNT.pack(len(values))
                if values:
                    align(out)
                    out += struct.pack(f"<{len(values)}{code}", *values)
            return write_numbers
        item_writer = self._field(sub, done)

        def write_items(term, out: bytearray) -> None:
            if not isinstance(term, list) or fixed and len(term) != fixed:
                raise ConversionError("list")
            if not fixed:
                count_align(out)
                out += _COUNT.pack(len(term))
            for item in term:
                item_writer(item, out)
        return write_items

    def _base(self, base: str) -> Writer:
        value = self.converter.base_value
        if base == "string":
            align = self._align(4)
            nul = b"\x00" if self.cdr else b""

            def write_string(term, out: bytearray) -> None:
                data = value(term, base).encode()
                align(out)
                out += _COUNT.pack(len(data) + len(nul))
                out += data
                out += nul
            return write_string
        code = _FORMATS.get(base)
        if code is None:
            raise Unsupported(base)
        packer = struct.Struct("<" + code)
        align = self._align(packer.size)
        pack = packer.pack
        def write_base(term, out: bytearray) -> None:
            number = value(term, base)
            align(out)
            out += pack(number)
        return write_base

    def _time(self, msgtype: str) -> Writer:
        fields = self.typestore.fielddefs[msgtype][1]
        codes = "".join(_FORMATS[desc[1][0]] for _, desc in fields)
        packer = struct.Struct("<" + codes)
        align = self._align(4)
        pack = packer.pack

        def write_time(term, out: bytearray) -> None:
            sec, nanosec = time_parts(term)
            align(out)
            out += pack(sec, nanosec)
        return write_time


def _no_align(out: bytearray) -> None:
    pass


def _float32(number: float) -> float:
    """An item of a float32 array as numpy's conversion (rosbags) takes it: beyond float32's
    range, infinite (a float32 field beyond it is an OverflowError, as in rosbags)."""
    try:
        _FLOAT32.pack(number)
    except OverflowError:
        return math.copysign(math.inf, number)
    return number
