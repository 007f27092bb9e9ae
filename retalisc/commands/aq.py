"""`retalisc aq PROGRAM.pl --script UPDATES.txt`: run active queries over an update script.

Compiles the definite program with the chosen transformation and runs the script in a plain
`swipl` process (`aq_script_main/1` of `prolog_runtime/rtl_aq.pl`), printing one JSON object
per notification on standard output (docs/active_queries.md).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import click

from ..compiler import AQ_MODES, AqOptions, compile_source
from ..frontend.errors import RetalisError


def _swipl() -> str:
    exe = os.environ.get("SWIPL") or shutil.which("swipl")
    if not exe:
        click.echo("error: swipl (SWI-Prolog) is not on PATH", err=True)
        sys.exit(1)
    return exe


def compile_program_or_exit(program: str, mode: str, subsumption: bool) -> str:
    try:
        text = Path(program).read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        click.echo(f"{program}: error: not a UTF-8 text file ({error.reason})", err=True)
        sys.exit(2)
    try:
        result = compile_source(text, program, active_queries=AqOptions(mode, subsumption))
    except RetalisError as error:
        click.echo(error.render(text), err=True)
        sys.exit(2)
    for note in result.warnings:
        click.echo(note, err=True)
    return result.prolog


def _prolog_atom(text: str) -> str:
    return "'" + text.replace("\\", "\\\\").replace("'", "\\'") + "'"


@click.command("aq", epilog="""\b
Example:
  retalisc aq tests/golden_aq/program1/program.pl --script UPDATES.txt --mode tabled
with UPDATES.txt:
  ?q1 a(X, Z).
  +d(4).
  -d(3).
  !q1.""")
@click.argument("program", type=click.Path(exists=True, dir_okay=False))
@click.option("--script", "script", required=True, type=click.Path(exists=True, dir_okay=False),
              help="Update script: `?Id Goal.` register, `+Fact.` assert, `-Fact.` retract, `!Id.` unregister.")
@click.option("--mode", type=click.Choice(AQ_MODES), default="tabled", show_default=True,
              help="Active-query transformation (thesis 6.4, 6.5, 6.6).")
@click.option("--subsumption", is_flag=True, help="Tabled mode: reuse the table of a subsuming sub-goal.")
def aq_command(program: str, script: str, mode: str, subsumption: bool) -> None:
    """Register active queries on PROGRAM (rules and initial facts) and run UPDATES.

    Prints JSON Lines {"query": Id, "op": "answer"|"add"|"delete", "answer": TEXT}: the answers at
    registration, then every change, in script order (sorted within one line). TEXT is the goal
    instance written with writeq.
    """
    prolog = compile_program_or_exit(program, mode, subsumption)
    with tempfile.TemporaryDirectory(prefix="retalisc_aq_") as tmp:
        out = Path(tmp) / "program.pl"
        out.write_text(prolog, encoding="utf-8")
        script_path = str(Path(script).resolve())
        cmd = [_swipl(), "--no-tty", "-q", "--no-packs", "-g", f"aq_script_main({_prolog_atom(script_path)})",
               "-t", "halt(1)", str(out)]
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    sys.stdout.write(proc.stdout)
    err = proc.stderr.replace(script_path, script)
    if err:
        sys.stderr.write(err)
    if proc.returncode not in (0, 1, 2):
        sys.exit(1)
    sys.exit(proc.returncode)


COMMANDS = [aq_command]
