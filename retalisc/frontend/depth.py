"""How deep a program's terms may nest, and running the compiler with room for that depth.

The reader, the passes and the writer walk terms recursively. A program may nest terms up to
`MAX_TERM_DEPTH` levels (400 brackets, a 1,500-step `seq` chain and SWI-Prolog all stay far
below); deeper clauses are a located "too deep" error (`parser.read_program`). So that
Python's recursion limit and the C stack hold at that depth, `with_room_for_depth` runs a
compilation in a thread with a large stack and a recursion limit to match.
"""
from __future__ import annotations

import sys
import threading
from typing import TYPE_CHECKING, Callable, TypeVar

from .terms import Compound, Term

if TYPE_CHECKING:
    from lark import Tree

#: The deepest nesting of terms (and of brackets) a program may have.
MAX_TERM_DEPTH = 10_000

# Python frames the compiler may stack per level of nesting, with a margin.
_FRAMES_PER_LEVEL = 12
_RECURSION_LIMIT = MAX_TERM_DEPTH * _FRAMES_PER_LEVEL + 2_000
_STACK_BYTES = 512 * 1024 * 1024      # reserved, not committed: only what is used is allocated

_lock = threading.Lock()
_active = 0
_saved_limit = 0

T = TypeVar("T")


def term_depth(term: Term) -> int:
    """Nesting depth of a term (an atom is 1), computed without recursion."""
    deepest = 0
    stack = [(term, 1)]
    while stack:
        t, depth = stack.pop()
        deepest = max(deepest, depth)
        if isinstance(t, Compound):
            stack.extend((a, depth + 1) for a in t.args)
    return deepest


def deepest_tree(tree: Tree):
    """(depth, node) of the deepest node of a lark tree, computed without recursion."""
    from lark import Tree   # lark only for a parse tree: the driver imports this module without it

    best = (0, tree)
    stack = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > best[0]:
            best = (depth, node)
        stack.extend((child, depth + 1) for child in node.children if isinstance(child, Tree))
    return best


def _start(target: Callable[[], None]):
    """Start `target` in a thread with a large stack (smaller ones if the system refuses)."""
    for size in (_STACK_BYTES, _STACK_BYTES // 8):
        with _lock:                         # stack_size is process-wide: set it for this thread only
            previous_size = threading.stack_size(size)
            try:
                thread = threading.Thread(target=target, name="retalisc-compile", daemon=True)
                thread.start()
                return thread
            except (RuntimeError, MemoryError):
                continue
            finally:
                threading.stack_size(previous_size)
    return None


def with_room_for_depth(function: Callable[[], T]) -> T:
    """Run `function()` in a thread with a stack and a recursion limit deep enough for terms
    nested `MAX_TERM_DEPTH` levels; return its result or raise its exception."""
    global _active, _saved_limit
    outcome: dict = {}

    def target() -> None:
        try:
            outcome["value"] = function()
        except BaseException as error:      # handed to the caller's thread below
            outcome["error"] = error

    with _lock:
        if _active == 0:
            _saved_limit = sys.getrecursionlimit()
            sys.setrecursionlimit(max(_saved_limit, _RECURSION_LIMIT))
        _active += 1
    try:
        thread = _start(target)
        if thread is None:                  # no thread could be made: run here, with the usual limit
            with _lock:
                sys.setrecursionlimit(_saved_limit)
            target()
        else:
            thread.join()
    finally:
        with _lock:
            _active -= 1
            if _active == 0:
                sys.setrecursionlimit(_saved_limit)
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]
