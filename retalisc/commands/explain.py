"""`retalisc explain`: how a derived event came about, or why a pattern was not detected."""
from __future__ import annotations

import json
import sys
from typing import Optional

import click

from ..robot_io.options import bag_input_options, check_bag_input
from .compile import compile_or_exit
from .options import run_option
from ..run_options import engine_flags


@click.command("explain", epilog="""\b
Examples:
  retalisc explain fire_alarm.rtl --events events.jsonl 'fire_alarm(smoke_1, T)'
  retalisc explain fire_alarm.rtl --events events.jsonl --why-not 'fire_alarm(smoke_2, _)'
  retalisc explain nao_markers.rtl --bag nao.bag --topics /tf,/ar_pose_marker 'seen_again(M, T)'""")
@click.argument("program", type=click.Path(exists=True, dir_okay=False))
@click.argument("event", required=False)
@click.option("--events", "events", type=click.Path(exists=True, dir_okay=False),
              help="The event JSON Lines file to run the program over. Or --bag.")
@click.option("--why-not", "why_not", metavar="PATTERN",
              help="Say, for each rule that could derive PATTERN, how far its pattern got over the events: "
                   "the matches of each part and where matching stops.")
@run_option("max_delay", help="As for retalisc run.")
@click.option("--limit", type=click.IntRange(1), default=5, show_default=True,
              help="Explain at most this many derived events that match EVENT.")
@bag_input_options
def explain_command(program: str, event: Optional[str], events: Optional[str], why_not: Optional[str], max_delay,
                    limit: int, **bag) -> None:
    """Run PROGRAM over --events (or the messages of a recording, --bag: each input is then
    named by its topic and number, `/tf#12`) and explain EVENT (a derived event, variables allowed): the
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
    check_bag_input(events, bag)
    if events is None and bag["bag"] is None:
        raise click.UsageError("give the input: --events FILE or --bag RECORDING (one of them)")
    result = compile_or_exit(program, module=unique_module_name(program))
    explainer = Explainer(result, log=sys.stderr)    # its problems reported as every road reports them
    for flag, value in engine_flags({"max_delay": max_delay}):      # retalisc/run_options.py
        explainer.engine.set_flag(flag, value)
    if events is not None:
        explainer.feed_file(events)
    else:
        _feed_recording(explainer, bag)
    try:
        text = explainer.why_not(why_not) if why_not is not None else explainer.explain(event, limit)
    except PrologError as error:
        message = " ".join(str(error).split())
        click.echo(f"retalisc explain: error: {why_not if why_not is not None else event!r}: {message}", err=True)
        sys.exit(2)
    click.echo(text.rstrip("\n"))


def _feed_recording(explainer, values: dict) -> None:
    """The messages of the recording of `values` (the --bag options) fed to `explainer` as
    event lines named `TOPIC#N`, converted as `retalisc run --bag` converts them."""
    from ..driver.feed import problem_text
    from ..robot_io import MissingDependency
    from ..robot_io.replay import BagOptions, ReplayStats, bag_events, open_recording

    options = BagOptions.from_cli(values)
    name = values["bag"]

    def report(topic: str, number: int, reason: str) -> None:
        click.echo(problem_text(name, f"{topic}#{number}", "rejected", reason), err=True)

    try:
        bag = open_recording(name, options)
    except MissingDependency as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(2)
    if bag is None:
        sys.exit(2)
    stats = ReplayStats()
    try:
        explainer.feed_placed(((json.dumps({"event": text, "t": seconds}), f"{record.topic}#{stats.messages}")
                              for text, seconds, record in bag_events(bag, options, stats, report)), name)
    finally:
        bag.__exit__(None, None, None)


COMMANDS = [explain_command]
