"""`retalisc query`: load events, then answer one SLR query (thesis 4.2.2, Def. 18)."""
from __future__ import annotations

import json
import sys

import click

from ..robot_io.options import bag_input_options, check_bag_input
from .compile import add_cli_memory, compile_or_exit
from .options import run_option
from ..run_options import engine_flags


@click.command("query", epilog="""\b
Examples:
  retalisc query examples/state_knowledge/state_knowledge.rtl --events examples/state_knowledge/events.jsonl \\
      'location(box, L)^14'
  retalisc query nao.rtl --events tf.jsonl --first 'prev(head_cam, tf(V, Q)^T, 12.5)'
  retalisc query nao.rtl --bag nao.bag --topics /tf 'prev(head_cam, tf(V, Q)^T, 12.5)'""")
@click.argument("program", type=click.Path(exists=True, dir_okay=False))
@click.argument("goal")
@click.option("--events", "events", type=click.Path(exists=True, allow_dash=True, dir_okay=False),
              help="Event JSON Lines file to process first ('-' for standard input).")
@click.option("--at", "at", type=float, default=None,
              help="Answer the query as of time Z: mem/2 sees the records that end at or before Z.")
@click.option("--first", is_flag=True, help="Print the first answer only.")
@run_option("max_delay", help="As for `retalisc run`.")
@click.option("--memory", "memories", multiple=True, metavar="'c_mem(Id, Event-Conds, N, L)'",
              help="Create (or delete, d_mem(Id)) a memory instance before the events. Repeatable.")
@bag_input_options
def query_command(program: str, goal: str, events, at, first: bool, max_delay, memories, **bag) -> None:
    """Process EVENTS (or the messages of a recording, --bag) with PROGRAM, then answer GOAL: one JSON object per answer mapping each
    variable of GOAL to its value (writeq text); `{}` for a goal without variables that
    succeeds; nothing when it fails (exit 0 either way). A goal that does not parse or that
    the sandbox refuses exits 2; a goal that raises an error exits 1.
    """
    from ..driver.engine import Engine, QueryError
    from ..driver.run import run_event_file

    if at is not None and at != at:
        raise click.BadParameter("must be a number", param_hint="--at")
    check_bag_input(events, bag)
    engine = Engine.from_compiled(compile_or_exit(program))
    for flag, value in engine_flags({"max_delay": max_delay}):      # retalisc/run_options.py
        engine.set_flag(flag, value)
    for request in memories:
        add_cli_memory(engine, request)
    if events:
        run_event_file(engine, events, out=None)
    elif bag["bag"] is not None:
        from ..robot_io.replay import replay_from_cli

        status = replay_from_cli(engine, None, bag, progress=False)
        if status:
            sys.exit(status)
    try:
        answers = [engine.query(goal, at)] if first else engine.query_all(goal, at)
    except QueryError as error:
        where = "query:" if error.kind == "syntax" else "query: error:"
        click.echo(f"{where}{error.message}" if error.kind == "syntax" else f"{where} {error.message}", err=True)
        click.echo(f"  {goal}", err=True)
        sys.exit(2 if error.kind in ("syntax", "unsafe") else 1)
    for answer in answers:
        if answer is not None:
            click.echo(json.dumps(answer, ensure_ascii=False))


COMMANDS = [query_command]
