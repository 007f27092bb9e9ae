"""The lines of an event input as the runtime reads them (prolog_runtime/rtl_lines.pl): the
input is cut at each newline byte, a line loses the carriage returns at its start and end
(one inside it stays), and each line is decoded as UTF-8 on its own, a line that is not
UTF-8 text being rejected with its line number. The Python loops of `retalisc run` read
bytes and hand each batch to the runtime as text when it is all UTF-8, else as its bytes,
which the runtime decodes line by line as its own loop does: so both loops see the same
lines, numbered alike, whatever the bytes (docs/runtime.md, "Event input")."""
from __future__ import annotations

from typing import List, Union


def batch_payload(lines: List[bytes]) -> Union[str, bytes]:
    """The lines (bytes, without their newlines) as one text for `Engine.feed_lines`: a `str`
    when every line is UTF-8 text, else `bytes` (decoded and checked by the runtime)."""
    data = b"\n".join(lines)
    if b"\r" in data:
        data = b"\n".join(line.strip(b"\r") for line in lines)
    if data.isascii():
        return data.decode("ascii")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data


def split_lines(data: bytes) -> List[bytes]:
    """The lines of `data` (newlines taken off; a last line without one included)."""
    lines = data.split(b"\n")
    if lines[-1] == b"":
        lines.pop()
    return lines
