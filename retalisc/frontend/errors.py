"""Errors reported against a place in the program text."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

from .terms import Span


class RetalisError(Exception):
    """An error in a Retalis program, with the place it was found."""

    kind = "error"

    def __init__(self, message: str, span: Optional[Span] = None):
        super().__init__(message)
        self.message = message
        self.span = span

    def render(self, source_text: Optional[str] = None) -> str:
        """`file:line:col: message`, then the offending line with a caret under the column."""
        if self.span is None:
            return f"error: {self.message}"
        return render_at(self.span, self.kind, self.message, source_text)


def render_at(span: Span, kind: str, message: str, source_text: Optional[str] = None) -> str:
    """`file:line:col: kind: message`, then the line at `span` with a caret under the column
    (read from `span.file` unless `source_text` is given)."""
    head = f"{span}: {kind}: {message}"
    text = source_text
    if text is None:
        try:
            text = Path(span.file).read_text(encoding="utf-8", errors="replace")
        except OSError:
            text = None
    if text is not None and text.startswith("\ufeff"):
        text = text[1:]                 # a byte-order mark: columns count from after it
    if text is None:
        return head
    lines = text.splitlines()
    if not 1 <= span.line <= len(lines):
        return head
    line = lines[span.line - 1].replace("\t", " ")
    caret = " " * (max(span.column, 1) - 1) + "^"
    return f"{head}\n    {line}\n    {caret}"


class RetalisSyntaxError(RetalisError):
    kind = "syntax error"


class RetalisSemanticError(RetalisError):
    kind = "error"
