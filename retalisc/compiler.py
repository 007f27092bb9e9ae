"""Compiling a Retalis program: frontend, passes, backend, in that order."""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, List, Optional

from .backends.prolog.render import render_program
from .frontend.program import parse_program
from .passes.pipeline import run_pipeline
from .passes.unit import Unit


@dataclass
class CompileResult:
    prolog: str
    unit: Unit
    warnings: List[str]


def module_name(path: str) -> str:
    stem = re.sub(r"[^A-Za-z0-9_]", "_", Path(path).stem) or "program"
    return f"rtl_prog_{stem}"


def compile_source(text: str, file: str, output_name: str = "PROGRAM.pl", dump_after: Optional[str] = None,
                   dump: Callable[[str], None] = print, module: Optional[str] = None) -> CompileResult:
    """Compile program text. Raises RetalisError (with a source location) on bad programs."""
    program = parse_program(text, file)
    unit = run_pipeline(Unit(program, module or module_name(file)), dump_after, dump)
    return CompileResult(render_program(unit, output_name), unit, list(unit.warnings))


def compile_file(path: str, **kwargs) -> CompileResult:
    return compile_source(Path(path).read_text(encoding="utf-8"), str(path), **kwargs)
