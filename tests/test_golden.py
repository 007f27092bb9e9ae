"""Golden tests: a folder per case with a program, an event stream and the expected output.

Each case runs twice, through standalone `swipl` on the compiled program and through the
Python driver; both must print exactly the expected lines. An `options` file holds options
for the run (`--allow-control` for the cases with control lines). `pytest --update-golden`
rewrites the expectations from the standalone run (review the diff before committing).
"""
import subprocess
from pathlib import Path

import pytest

from retalisc.compiler import compile_file
from retalisc.driver.engine import Engine

ROOT = Path(__file__).resolve().parent.parent


def _options(folder: Path):
    """Options of a case, one per line in its `options` file (`--allow-control`), as given to
    `swipl PROGRAM.pl`."""
    path = folder / "options"
    return path.read_text().split() if path.exists() else []


def _cases():
    cases = []
    for folder in sorted((ROOT / "tests" / "golden").iterdir()):
        if (folder / "program.rtl").exists():
            cases.append(pytest.param(folder / "program.rtl", folder, id=f"golden/{folder.name}"))
    for folder in sorted((ROOT / "examples").iterdir()):
        programs = sorted(folder.glob("*.rtl"))
        if programs and (folder / "events.jsonl").exists():
            cases.append(pytest.param(programs[0], folder, id=f"examples/{folder.name}"))
    return cases


@pytest.mark.parametrize("program, folder", _cases())
def test_standalone_swipl(program, folder, tmp_path, swipl, update_golden):
    compiled = tmp_path / "program.pl"
    compiled.write_text(compile_file(str(program), output_name="program.pl").prolog)
    run = subprocess.run([swipl, str(compiled), *_options(folder), str(folder / "events.jsonl")], capture_output=True,
                         text=True, cwd=tmp_path, timeout=120)
    assert run.returncode == 0, run.stderr
    expected = folder / "expected.jsonl"
    if update_golden:
        expected.write_text(run.stdout)
    assert run.stdout == expected.read_text()


@pytest.mark.parametrize("program, folder", _cases())
def test_python_driver(program, folder):
    engine = Engine.load(program)
    engine.set_flag("max_delay", "1.0")     # the default of a fresh process; flags are shared by its engines
    produced, _ = engine.feed_lines((folder / "events.jsonl").read_text().rstrip("\n"),
                                    allow_control="--allow-control" in _options(folder))
    produced += engine.end_of_input()
    expected = (folder / "expected.jsonl").read_text().splitlines()
    assert [e.line for e in produced] == expected
