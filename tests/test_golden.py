"""Golden tests of the event-program cases (the layout and the one switch, `pytest
--update-golden`, are described in tests/golden_cases.py): each case runs twice, through
standalone `swipl` on the compiled program and through the Python driver; both must print
exactly the expected lines. The examples with an event stream (`examples/<name>/events.jsonl`
and `expected.jsonl`) run the same way. Every golden case (active-query cases too) also
compares its generated Prolog with its `compiled*.pl` files.
"""
import subprocess
from pathlib import Path

import pytest

from golden_cases import GOLDEN, ROOT, check_expected, compiled_files, event_cases
from retalisc.compiler import compile_file
from retalisc.driver.engine import Engine


def _options(folder: Path):
    """Options of a case, one per line in its `options` file (`--allow-control`), as given to
    `swipl PROGRAM.pl`."""
    path = folder / "options"
    return path.read_text().split() if path.exists() else []


def _cases():
    cases = []
    for folder in event_cases():
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
    check_expected(folder / "expected.jsonl", run.stdout, update_golden)


@pytest.mark.parametrize("program, folder", _cases())
def test_python_driver(program, folder):
    engine = Engine.load(program)
    engine.set_flag("max_delay", "1.0")     # the default of a fresh process; flags are shared by its engines
    produced, _ = engine.feed_lines((folder / "events.jsonl").read_text().rstrip("\n"),
                                    allow_control="--allow-control" in _options(folder))
    produced += engine.end_of_input()
    expected = (folder / "expected.jsonl").read_text().splitlines()
    assert [e.line for e in produced] == expected


@pytest.mark.parametrize("case", sorted(GOLDEN.iterdir()), ids=lambda p: p.name)
def test_generated_prolog(case, update_golden):
    """The generated Prolog of every golden case is its `compiled*.pl`: a change of the
    compiler's output is seen (and reviewed) in the diff of these files."""
    files = compiled_files(case)
    assert files, f"{case} has no program"
    for path, prolog in files:
        check_expected(path, prolog, update_golden)
