"""The lines of an event input as the runtime reads them (prolog_runtime/rtl_lines.pl): the
input is cut at each newline byte, a line loses the carriage returns at its start and end
(one inside it stays), and each line is decoded as UTF-8 on its own, a line that is not
UTF-8 text being rejected with its line number. The Python loops of `retalisc run` read
bytes and hand each batch to the runtime as text when it is all UTF-8, else as its bytes,
which the runtime decodes line by line as its own loop does: so both loops see the same
lines, numbered alike, whatever the bytes (docs/runtime.md, "Event input").

A line may be at most the runtime's flag `max_line_bytes` long (docs/runtime.md, "Input
limits"): the readers here hold at most that much of a line, skip the rest of a longer one
to its newline, and pass a stand-in of `max_line_bytes + 1` bytes on, which the runtime
rejects as too long, with its line number, as its own loop does."""
from __future__ import annotations

from typing import IO, TYPE_CHECKING, Iterator, List, Optional, Tuple, Union

if TYPE_CHECKING:
    from .engine import Engine

SKIP_CHUNK = 1 << 16        # bytes read at once while skipping the rest of a line too long


def max_line_bytes(engine: "Engine") -> Optional[int]:
    """The runtime's limit on the length of an input line, in bytes (None: no limit)."""
    value = engine.flag("max_line_bytes")
    return None if value == "inf" else int(value)


def too_long_line(limit: int) -> bytes:
    """What goes on in place of a line longer than `limit` bytes: a line the runtime rejects
    as too long (its content is never read)."""
    return b"x" * (limit + 1)


def read_lines(stream: IO[bytes], limit: Optional[int]) -> Iterator[Tuple[bytes, int]]:
    """(line without its newline, bytes it took in `stream`) for each line of a binary
    stream; a line longer than `limit` bytes is `too_long_line(limit)`, at most `limit` + 1
    bytes of it held."""
    if limit is None:
        for raw in stream:
            yield (raw[:-1] if raw.endswith(b"\n") else raw), len(raw)
        return
    while True:
        raw = stream.readline(limit + 1)
        if not raw:
            return
        if raw.endswith(b"\n"):
            yield raw[:-1], len(raw)
        elif len(raw) <= limit:             # the last line, without a newline
            yield raw, len(raw)
        else:
            size = len(raw)
            while True:
                rest = stream.readline(SKIP_CHUNK)
                size += len(rest)
                if not rest or rest.endswith(b"\n"):
                    break
            yield too_long_line(limit), size


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
