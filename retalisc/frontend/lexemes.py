"""The lexemes of Prolog text read as SWI-Prolog reads them (quoted items' escapes, numbers): shared
by the program parser (frontend/parser.py) and the readers of data terms (robot_io/data_terms.py),
which must not import lark (a live node or a replay reads data terms only)."""
from __future__ import annotations

import re


_ESCAPES = {"a": "\a", "b": "\b", "f": "\f", "n": "\n", "r": "\r", "t": "\t", "v": "\v",
            "\\": "\\", "'": "'", '"': '"', "`": "`", "e": "\x1b", "s": " ", "\n": ""}


class EscapeError(Exception):
    """A bad escape sequence at `offset` in the text between the quotes."""

    def __init__(self, message: str, offset: int):
        super().__init__(message)
        self.message = message
        self.offset = offset


def code_point(value: int, offset: int) -> str:
    if value > 0x10FFFF or 0xD800 <= value <= 0xDFFF:
        raise EscapeError(f"illegal character code {value:#x} in an escape sequence", offset)
    return chr(value)


def unescape(body: str, quote: str) -> str:
    """The text of a quoted item with its escape sequences replaced, as SWI-Prolog reads it.
    Raises EscapeError for an escape SWI-Prolog rejects (`\\q`, `\\u12`, ...)."""
    out = []
    i = 0
    while i < len(body):
        c = body[i]
        if c == quote and i + 1 < len(body) and body[i + 1] == quote:
            out.append(quote)
            i += 2
            continue
        if c == "\\":
            if i + 1 >= len(body):
                raise EscapeError("a quoted item cannot end with a single backslash", i)
            d = body[i + 1]
            if d in _ESCAPES:
                out.append(_ESCAPES[d])
                i += 2
                continue
            if d == "c":              # \c skips the layout that follows it
                i += 2
                while i < len(body) and body[i] in " \t\n\r":
                    i += 1
                continue
            if d == "x":
                m = re.match(r"x([0-9a-fA-F]+)\\?", body[i + 1:])
                if not m:
                    raise EscapeError("\\x must be followed by hexadecimal digits (\\xHH\\)", i)
                out.append(code_point(int(m.group(1), 16), i))
                i += 1 + m.end()
                continue
            if d in "uU":
                width = 4 if d == "u" else 8
                digits = body[i + 2:i + 2 + width]
                if not re.fullmatch(f"[0-9a-fA-F]{{{width}}}", digits):
                    raise EscapeError(f"\\{d} must be followed by {width} hexadecimal digits", i)
                out.append(code_point(int(digits, 16), i))
                i += 2 + width
                continue
            if d in "01234567":
                m = re.match(r"([0-7]+)\\?", body[i + 1:])
                out.append(code_point(int(m.group(1), 8), i))
                i += 1 + m.end()
                continue
            raise EscapeError(f"unknown escape sequence '\\{d}' in a quoted item (write '\\\\' for a backslash)",
                               i)
        out.append(c)
        i += 1
    return "".join(out)


def number(text: str):
    text = text.replace("_", "")
    if text.startswith(("0x", "0o", "0b")):
        return int(text[2:], {"x": 16, "o": 8, "b": 2}[text[1]])
    if text.endswith("Inf"):
        return float("inf")
    if text.endswith("NaN"):
        return float("nan")
    if "." in text or "e" in text or "E" in text:
        return float(text)
    return int(text)
