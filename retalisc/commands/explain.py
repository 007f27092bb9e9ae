"""`retalisc explain`: how a derived event came about, or why a pattern was not detected."""
from __future__ import annotations

import sys
from typing import Optional

import click

from .compile import compile_or_exit
from .options import Seconds


@click.command("explain", epilog="""\b
Examples:
  retalisc explain fire_alarm.rtl --events events.jsonl 'fire_alarm(smoke_1, T)'
  retalisc explain fire_alarm.rtl --events events.jsonl --why-not 'fire_alarm(smoke_2, _)'""")
@click.argument("program", type=click.Path(exists=True, dir_okay=False))
@click.argument("event", required=False)
@click.option("--events", "events", required=True, type=click.Path(exists=True, dir_okay=False),
              help="The event JSON Lines file to run the program over.")
@click.option("--why-not", "why_not", metavar="PATTERN",
              help="Say, for each rule that could derive PATTERN, how far its pattern got over the events: "
                   "the matches of each part and where matching stops.")
@click.option("--max-delay", type=Seconds(), default=None, help="As for retalisc run.")
@click.option("--limit", type=click.IntRange(1), default=5, show_default=True,
              help="Explain at most this many derived events that match EVENT.")
def explain_command(program: str, event: Optional[str], events: str, why_not: Optional[str], max_delay,
                    limit: int) -> None:
    """Run PROGRAM over --events and explain EVENT (a derived event, variables allowed): the
    rule that derived it and the events of the match, each with its input line, recursively.

    With --why-not PATTERN instead: per rule whose head fits PATTERN, the number of matches of
    each part of its pattern, outermost first, and the part where matching stops (the
    condition, relation or window that rejected what its operands matched, or an event that
    never came)."""
    from ..compiler import unique_module_name
    from ..driver.bridge import PrologError
    from ..driver.explain import Explainer

    if (event is None) == (why_not is None):
        raise click.UsageError("give an EVENT to explain or --why-not PATTERN (one of them)")
    result = compile_or_exit(program, module=unique_module_name(program))
    explainer = Explainer(result)
    if max_delay is not None:
        explainer.engine.set_flag("max_delay", repr(max_delay))
    explainer.feed_file(events)
    for rejection in explainer.rejections:
        click.echo(f"{events}:{rejection.line}: {rejection.kind}: {rejection.reason}", err=True)
    try:
        text = explainer.why_not(why_not) if why_not is not None else explainer.explain(event, limit)
    except PrologError as error:
        message = " ".join(str(error).split())
        click.echo(f"retalisc explain: error: {why_not if why_not is not None else event!r}: {message}", err=True)
        sys.exit(2)
    click.echo(text.rstrip("\n"))


COMMANDS = [explain_command]
