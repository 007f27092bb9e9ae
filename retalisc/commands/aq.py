"""`retalisc aq PROGRAM.pl --script UPDATES.txt`: run active queries over an update script.

Compiles the definite program with the chosen transformation, loads it in this process (the
in-process bridge) and runs the script as a source of the feed loop (`feed.ScriptSource`, the
commands interpreted by `prolog_runtime/rtl_aq_script.pl`), printing one JSON object per
notification on standard output or to `--out FILE` (docs/active_queries.md). With `--state DIR`
the same loop runs with snapshots of the active queries in DIR (`recovery.Recovery`), so that a
run killed and started again ends with the same `--out` file as a run that never stopped
(docs/recovery.md). A compiled program also runs a script on its own in plain `swipl`
(`aq_script_main/1`).
"""
from __future__ import annotations

import sys
from pathlib import Path

import click

from ..compiler import AQ_MODES, AqOptions, compile_source
from ..frontend.errors import RetalisError
from .options import check_snapshot_options, output_directory, output_file, state_options


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


@click.command("aq", epilog="""\b
Example:
  retalisc aq tests/golden/program1/program.pl --script UPDATES.txt --mode tabled
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
@click.option("--out", "out", type=click.Path(dir_okay=False, allow_dash=True), default="-", show_default=True,
              help="Write the notifications to this file ('-' for standard output).")
@state_options(
    "Survive a crash: keep snapshots of the active queries in DIR; started again with the same "
    "DIR, the run goes on from the newest complete snapshot and the --out file ends byte-identical "
    "to that of a run that never stopped (docs/recovery.md). Needs --out FILE.",
    "With --state: a snapshot every N script commands (default 10000).",
    "With --state: a snapshot every S seconds at the latest (default 60; inf: only by "
    "--snapshot-every).")
def aq_command(program: str, script: str, mode: str, subsumption: bool, out: str, state, snapshot_every,
               snapshot_seconds) -> None:
    """Register active queries on PROGRAM (rules and initial facts) and run UPDATES.

    Prints JSON Lines {"query": Id, "op": "answer"|"add"|"delete", "answer": TEXT}: the answers at
    registration, then every change, in script order (sorted within one line). TEXT is the goal
    instance written with writeq.
    """
    check_snapshot_options(state, snapshot_every, snapshot_seconds)
    if state is not None:
        if out == "-":
            raise click.UsageError("--state needs --out FILE (standard output cannot be cut back after a crash)")
        output_directory(state, "--state")
    output_file(out, "--out")
    prolog = compile_program_or_exit(program, mode, subsumption)
    aq = _load_or_exit(program, prolog)
    if state is not None:
        sys.exit(_run_with_state(aq, script, out, state, snapshot_every, snapshot_seconds))
    from ..driver.active_queries import run_script

    sys.exit(run_script(aq, script, out, display_name=script))


def _load_or_exit(program: str, prolog: str):
    from ..driver.active_queries import ActiveQueries
    from ..driver.bridge import PrologError

    try:
        return ActiveQueries.from_compiled(prolog)
    except PrologError as error:
        click.echo(f"{program}: error: the program cannot be loaded: {error}", err=True)
        sys.exit(2)


def _run_with_state(aq, script, out, state, snapshot_every, snapshot_seconds) -> int:
    from ..driver import recovery

    try:
        return recovery.run_aq_recoverable(
            aq, script, out, state, display_name=script,
            snapshot_commands=snapshot_every or recovery.DEFAULT_AQ_SNAPSHOT_COMMANDS,
            snapshot_seconds=recovery.DEFAULT_SNAPSHOT_SECONDS if snapshot_seconds is None else snapshot_seconds)
    except recovery.RecoveryError as error:
        click.echo(f"error: --state {state}: {error}", err=True)
        return 2

COMMANDS = [aq_command]
