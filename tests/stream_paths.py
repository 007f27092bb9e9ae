"""Running one program over one event file on both paths users have:
`retalisc run PROGRAM --events EVENTS [OPTIONS]` (the Python driver) and
`retalisc compile PROGRAM -o OUT.pl` then `swipl OUT.pl [OPTIONS] EVENTS` (no Python).

Options are given in the `retalisc run` spelling (`--max-steps`, `100`); the standalone path
gets them as `--max-steps=100`, as `swipl OUT.pl` expects."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import List, Sequence

import click

from retalisc.compiler import compile_source

PATHS = ["run", "swipl"]
VALUED = {"--max-steps", "--action-output", "--max-delay", "--consumer-dir", "--batch-size"}


@dataclass
class Result:
    returncode: int
    stdout: str
    stderr: str
    events_file: Path

    @property
    def lines(self) -> List[dict]:
        """The output JSON Lines (each line must be valid JSON)."""
        return [json.loads(line) for line in self.stdout.splitlines()]

    @property
    def events(self) -> List[str]:
        return [line["event"] for line in self.lines]

    def location(self, line: int) -> str:
        return f"{self.events_file}:{line}:"


def swipl_options(options: Sequence[str]) -> List[str]:
    out, items, i = [], list(options), 0
    while i < len(items):
        option = items[i]
        if option == "--batch-size":             # the standalone path reads line by line
            i += 2
        elif option in VALUED:
            out.append(f"{option}={items[i + 1]}")
            i += 2
        else:
            out.append(option)
            i += 1
    return out


def run_path(path: str, tmp_path: Path, program: str, events: str, *options: str, stdin: bool = False,
             timeout: float = 60, capfd=None) -> Result:
    """Run `program` (source text) over `events` (JSON Lines text) on `path` ("run" or "swipl").
    With pytest's `capfd`, `retalisc run` runs in this process (the same code, without the
    start-up of a Python process; standard output and error are captured at the file
    descriptors, where the embedded Prolog writes too)."""
    source = tmp_path / f"program_{tmp_path.name}.rtl"           # module names stay unique
    source.write_bytes(program.encode("utf-8"))
    events_file = tmp_path / "events.jsonl"
    events_file.write_bytes(events.encode("utf-8"))
    name = "-" if stdin else str(events_file)
    if path == "run" and capfd is not None and not stdin:
        return _run_in_process(source, events_file, options, capfd)
    if path == "run":
        command = [sys.executable, "-m", "retalisc", "run", str(source), "--events", name, *options]
    else:
        compiled = tmp_path / "program.pl"
        compiled.write_text(compile_source(program.lstrip("\ufeff"), str(source), output_name="program.pl").prolog,
                            encoding="utf-8")
        command = [shutil.which("swipl") or "swipl", str(compiled), *swipl_options(options), name]
    run = subprocess.run(command, input=events.encode("utf-8") if stdin else None, capture_output=True,
                         timeout=timeout, cwd=tmp_path)
    return Result(run.returncode, run.stdout.decode("utf-8"), run.stderr.decode("utf-8"),
                  Path("<stdin>") if stdin else events_file)


def _run_in_process(source: Path, events_file: Path, options, capfd) -> Result:
    from retalisc.cli import main

    capfd.readouterr()
    try:
        main.main(["run", str(source), "--events", str(events_file), *options], standalone_mode=False)
        code = 0
    except SystemExit as exit:
        code = exit.code if isinstance(exit.code, int) else 1
    except click.exceptions.Exit as exit:
        code = exit.exit_code
    except click.ClickException as error:
        error.show()
        code = error.exit_code
    sys.stdout.flush()
    sys.stderr.flush()
    captured = capfd.readouterr()
    return Result(code, captured.out, captured.err, events_file)


def jsonl(*items) -> str:
    """Event lines: (event, t) or (event, t, op) tuples, dicts, or raw strings (bad lines)."""
    out = []
    for item in items:
        if isinstance(item, str):
            out.append(item)
        elif isinstance(item, dict):
            out.append(json.dumps(item, ensure_ascii=False))
        else:
            line = {"event": item[0], "t": item[1]}
            if len(item) > 2:
                line["op"] = item[2]
            out.append(json.dumps(line, ensure_ascii=False))
    return "".join(line + "\n" for line in out)
