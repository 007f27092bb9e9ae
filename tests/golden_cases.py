"""The golden cases: one folder per case in `tests/golden/<case>/`, one layout, one switch.

A case is an event program or a definite program for active queries, told apart by the name of
its program:

    program.rtl       an event program, run on `events.jsonl` (with the options of `options`,
                      one per line, if present); `expected.jsonl` holds the lines the run prints
                      (through standalone `swipl` and through the Python driver alike)
    program.pl        a definite program for active queries: `queries.txt` (one goal a line, ids
                      q1, q2, ...), `updates.txt` (`+fact.`, `-fact.`, `?` checkpoints),
                      `modes.txt` (the transformations that terminate on it); `expected.txt`
                      holds each query's answers at every checkpoint, made by SWI-Prolog's own
                      tabling (never by our code)

Every case also holds the generated Prolog it compiles to, so a change of the compiler's
output shows in the diff: `compiled.pl` for an event program, `compiled.<mode>.pl` for each
mode of `modes.txt` of an active-query program.

The one switch: `pytest --update-golden tests/test_golden.py tests/test_aq_golden.py` rewrites
every expectation (outputs from the standalone run and from SWI tabling, generated Prolog from
the compiler); review the diff before committing. Without it a case with a missing expectation
fails.
"""
from __future__ import annotations

from pathlib import Path
from typing import List

from retalisc.compiler import AqOptions, compile_source
from retalisc.frontend.terms import quote_atom
from retalisc.runtime_location import runtime_dir

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden"


def event_cases() -> List[Path]:
    """The folders of the event-program cases."""
    return [folder for folder in sorted(GOLDEN.iterdir()) if (folder / "program.rtl").exists()]


def aq_cases() -> List[Path]:
    """The folders of the active-query cases."""
    return [folder for folder in sorted(GOLDEN.iterdir()) if (folder / "program.pl").exists()]


def modes(case: Path) -> List[str]:
    """The active-query transformations that terminate on a case (its `modes.txt`)."""
    return (case / "modes.txt").read_text().split()


#: What stands for the runtime directory the generated Prolog was compiled against (the
#: checkout's `prolog_runtime/`, a different path on every machine) in the expectation files.
RUNTIME_PLACEHOLDER = "'<prolog_runtime>'"


def _portable(prolog: str) -> str:
    return prolog.replace(quote_atom(str(runtime_dir())), RUNTIME_PLACEHOLDER)


def compiled_event_program(case: Path) -> str:
    """The generated Prolog of an event case, compiled as `swipl program.pl` runs it (file
    names relative to the checkout, the runtime directory RUNTIME_PLACEHOLDER)."""
    path = case / "program.rtl"
    return _portable(compile_source(path.read_text(encoding="utf-8"), str(path.relative_to(ROOT)),
                                    output_name="program.pl").prolog)


def compiled_aq_program(case: Path, mode: str) -> str:
    """The generated Prolog of an active-query case under one transformation."""
    path = case / "program.pl"
    return _portable(compile_source(path.read_text(encoding="utf-8"), str(path.relative_to(ROOT)),
                                    active_queries=AqOptions(mode)).prolog)


def compiled_files(case: Path) -> List[tuple]:
    """(expectation file, generated Prolog) of a case."""
    if (case / "program.rtl").exists():
        return [(case / "compiled.pl", compiled_event_program(case))]
    return [(case / f"compiled.{mode}.pl", compiled_aq_program(case, mode)) for mode in modes(case)]


def check_expected(path: Path, actual: str, update: bool) -> None:
    """`actual` is what `path` expects; with the switch (`--update-golden`) `path` is rewritten."""
    if update:
        path.write_text(actual)
    assert path.exists(), f"{path} is missing: run pytest --update-golden and review the diff"
    expected = path.read_text()
    assert actual == expected, f"{path} differs (pytest --update-golden rewrites it; review the diff)"
