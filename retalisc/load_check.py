"""`retalisc check` loads what only SWI-Prolog can judge: a program with a directive that loads
files (`:- ensure_loaded(F)`, `use_module`, `consult`, ...) compiles to Prolog whose load
depends on which files exist and what they define. For such a program `check` loads the
compiled program in `swipl` (`prolog_runtime/rtl_load_check.pl`), read as if it were the file
`PROGRAM.pl` next to the source (where relative file names are looked for when the program is
compiled next to it), and each error SWI-Prolog reports while loading it is an error of
`check` at the clause it came from. Everything else that loading would refuse is checked by
the passes (`passes/loadable.py`), without starting `swipl` (a load costs 0.1 to 0.3 s).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import List, Optional

from .frontend.errors import RetalisSemanticError
from .backends.prolog.render import copied_clause_lines
from .frontend.program import Directive
from .frontend.terms import Span
from .passes.loadable import _loads_code
from .runtime_location import runtime_dir

#: Seconds a load may take (its directives run: the program is trusted, but may loop).
LOAD_TIMEOUT = 120


def needs_load(unit) -> bool:
    """Whether the program has a directive that loads files (only a load can judge it)."""
    return any(isinstance(c, Directive) and _loads_code(c.goal) for c in unit.program.clauses)


def load_error(result, program: str) -> Optional[RetalisSemanticError]:
    """The first error SWI-Prolog reports while loading the compiled program of `program`
    (a CompileResult), located at the clause it came from (at the first directive that loads
    files when the message names no copied clause); None when it loads, when it loads no
    files (nothing to learn) or when there is no `swipl` on the PATH."""
    unit = result.unit
    swipl = shutil.which("swipl")
    if swipl is None or not hasattr(unit, "program") or not needs_load(unit):
        return None
    source = Path(program).resolve()
    as_file = str(source.with_suffix(".pl"))
    with tempfile.TemporaryDirectory(prefix="retalisc-check-") as directory:
        text_file = os.path.join(directory, "program.text")
        Path(text_file).write_text(result.prolog, encoding="utf-8")
        goal = "rtl_load_check:rtl_load_check(TextFile, Id)"
        command = [swipl, "--no-packs", "-f", "none", "-g",
                   f"current_prolog_flag(argv, [TextFile, Id|_]), {goal}", "-t", "halt",
                   str(runtime_dir() / "rtl_load_check.pl"), "--", text_file, as_file]
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=LOAD_TIMEOUT,
                                  stdin=subprocess.DEVNULL, cwd=directory)
        except subprocess.TimeoutExpired:
            return RetalisSemanticError(f"loading the compiled program did not end within {LOAD_TIMEOUT} s",
                                        _first_loader(unit))
    problems = [line.split("\t", 1) for line in done.stdout.splitlines() if "\t" in line]
    if not problems:
        return None
    line_text, message = problems[0]
    line = int(line_text) if line_text.isdigit() else 0
    span = next((clause.span for first, last, clause in copied_clause_lines(unit, result.prolog)
                 if first <= line <= last), None) or _first_loader(unit)
    return RetalisSemanticError(f"the compiled program does not load: {message}", span)


def _first_loader(unit) -> Span:
    spans: List[Span] = [c.span for c in unit.program.clauses if isinstance(c, Directive) and _loads_code(c.goal)]
    return spans[0]
