"""Compiling Retalis programs: frontend, passes, backend, in that order, for every kind of program.

    kind                        frontend                     passes (passes/pipeline.py)  backend
    event program (.rtl)        frontend/program.py          EVENT_PIPELINE               render.py, program.pl.j2
    rules for a running program frontend/program.py          ADDED_RULES_PIPELINE         render.py, added_rules.pl.j2
    active queries (definite)   frontend/definite.py         ACTIVE_QUERY_PIPELINE        aq_backend.py, aq_program.j2

Commands, drivers and `runtime_rules.py` compile through this module only. Importing it is
cheap: the frontend, the passes and the backends (lark, jinja2) are imported by the first
compilation, so that a run that needs no compiler (a cached program, `compile_cache.py`)
does not load them.
"""
from __future__ import annotations

import itertools
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, List, Optional, Union

if TYPE_CHECKING:
    from .passes.unit import AqUnit, Unit

__all__ = ["AQ_MODES", "AqOptions", "CompileResult", "compile_added_rules", "compile_file", "compile_source",  # noqa: F822 (AQ_MODES: __getattr__)
           "module_name", "pass_names"]

RULE_PREFIX = re.compile(r"[a-z][A-Za-z0-9_]*")


@dataclass(frozen=True)
class AqOptions:
    """Compile a definite program for active queries (thesis chapter 6) instead of an event
    program: `mode` is one of `AQ_MODES`; `subsumption` lets tabled mode reuse the table of a
    subsuming sub-goal."""

    mode: str = "tabled"
    subsumption: bool = False


@dataclass
class CompileResult:
    prolog: str
    unit: Union[Unit, AqUnit]
    warnings: List[str]


def __getattr__(name: str):
    if name == "AQ_MODES":          # the active-query transformations, from the pass lists
        from .passes.pipeline import AQ_MODES
        return AQ_MODES
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def module_name(path: str) -> str:
    stem = re.sub(r"[^A-Za-z0-9_]", "_", Path(path).stem) or "program"
    return f"rtl_prog_{stem}"


_loaded_modules = itertools.count(1)


def unique_module_name(program_name: str) -> str:
    """A module name for the program no other program of this process has."""
    return f"{module_name(program_name)}_{next(_loaded_modules)}"


def compile_source(text: str, file: str, output_name: str = "PROGRAM.pl", dump_after: Optional[str] = None,
                   dump: Callable[[str], None] = print, module: Optional[str] = None,
                   active_queries: Optional[AqOptions] = None) -> CompileResult:
    """Compile program text: an event program, or with `active_queries` a definite program for
    active queries. With `dump_after`, hand the text of the unit after that pass to `dump`.
    Raises RetalisError (with a source location) on bad programs, ValueError for an unknown
    mode or a `dump_after` pass this compilation does not run. `retalisc check` and
    `retalisc compile` both come here: what one accepts, the other compiles."""
    from .frontend.depth import with_room_for_depth

    _check_dump_after(dump_after, active_queries)
    return with_room_for_depth(lambda: _compile(text, file, output_name, dump_after, dump, module, active_queries))


def _compile(text: str, file: str, output_name: str, dump_after: Optional[str], dump: Callable[[str], None],
             module: Optional[str], active_queries: Optional[AqOptions]) -> CompileResult:
    from .passes.pipeline import EVENT_PIPELINE, active_query_passes, run_pipeline

    if text.startswith("\ufeff"):
        text = text[1:]                     # a UTF-8 byte-order mark
    if active_queries is not None:
        from .backends.prolog.aq_backend import render_active_queries
        from .frontend.definite import read_definite_program
        from .passes.unit import AqUnit

        passes = active_query_passes(active_queries.mode)
        unit = AqUnit(read_definite_program(text, file), active_queries.mode, active_queries.subsumption)
        unit.warnings.extend(unit.program.notes)
        unit = run_pipeline(unit, passes, _dumper(dump_after, dump))
        return CompileResult(render_active_queries(unit), unit, list(unit.warnings))
    from .backends.prolog.render import render_program
    from .backends.prolog.reserved import target_predicates
    from .frontend.program import parse_program
    from .passes.unit import Unit

    unit = Unit(parse_program(text, file), module or module_name(file), target=target_predicates())
    unit.warnings.extend(unit.program.notes)
    unit = run_pipeline(unit, EVENT_PIPELINE, _dumper(dump_after, dump))
    return CompileResult(render_program(unit, output_name), unit, list(unit.warnings))


def compile_file(path: str, **kwargs) -> CompileResult:
    return compile_source(Path(path).read_text(encoding="utf-8"), str(path), **kwargs)


def compile_added_rules(text: str, module: str, prefix: str = "rt", file: str = "<rules>") -> CompileResult:
    """Compile event rules to add to the running program `module` (ETALIS `ins_event_rule`);
    unlabelled rules are named `<prefix>_<n>`. `prolog` is the text `retalisc/runtime_rules.py`
    describes. Raises RetalisError for anything but event rules and `event_rule_property/3`."""
    from .backends.prolog.render import render_added_rules
    from .backends.prolog.reserved import target_predicates
    from .frontend.depth import with_room_for_depth
    from .frontend.program import parse_program
    from .passes.pipeline import ADDED_RULES_PIPELINE, run_pipeline
    from .passes.unit import Unit

    if not RULE_PREFIX.fullmatch(prefix):
        raise ValueError(f"rule prefix {prefix!r} must match [a-z][A-Za-z0-9_]*")

    def compile_rules() -> CompileResult:
        unit = Unit(parse_program(text, file), module, rule_prefix=prefix, target=target_predicates())
        unit = run_pipeline(unit, ADDED_RULES_PIPELINE)
        return CompileResult(render_added_rules(unit), unit, list(unit.warnings))
    return with_room_for_depth(compile_rules)


def pass_names(active_queries: Optional[AqOptions] = None) -> List[str]:
    """The passes `compile_source` runs, in order, for an event program or with these options."""
    from .passes.pipeline import EVENT_PIPELINE, active_query_passes

    passes = EVENT_PIPELINE if active_queries is None else active_query_passes(active_queries.mode)
    return [p.name for p in passes]


def _check_dump_after(dump_after: Optional[str], active_queries: Optional[AqOptions]) -> None:
    names = pass_names(active_queries)
    if dump_after is not None and dump_after not in names:
        raise ValueError(f"pass {dump_after!r} does not run in this compilation (its passes: {', '.join(names)})")


def _dumper(dump_after: Optional[str], dump: Callable[[str], None]):
    if dump_after is None:
        return None

    from .backends.prolog.dump import dump_unit

    def after_pass(name: str, unit) -> None:
        if name == dump_after:
            dump(dump_unit(unit, name))
    return after_pass
