"""`retalisc plot`: a timeline picture of event JSON Lines (retalisc/robot_io/plot.py)."""
from __future__ import annotations

import sys

import click


@click.command("plot")
@click.argument("files", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="The image to write (PNG, SVG or PDF, from its suffix).")
@click.option("--title", default=None, help="Title of the picture (default: the file names).")
@click.option("--types", default=None, metavar="WORD1,WORD2",
              help="Only the rows whose label contains one of these words.")
@click.option("--max-rows", type=click.IntRange(1), default=40, show_default=True,
              help="Draw at most this many rows (the first ones in time).")
def plot_command(files, output: str, title, types, max_rows: int) -> None:
    """Draw the events of FILES (the output of `retalisc run`, with --echo-input to include
    the input, or event files) on one time axis: one row per event type and per consumer,
    atomic events as ticks, intervals as bars."""
    from ..robot_io import MissingDependency
    from ..robot_io.plot import PlotError, plot_timeline

    try:
        rows, events = plot_timeline(list(files), output, title=title, max_rows=max_rows,
                                     types=[t.strip() for t in types.split(",") if t.strip()] if types else None)
    except (PlotError, MissingDependency) as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(2 if isinstance(error, PlotError) else 1)
    click.echo(f"{output}: {rows} rows, {events:,} events", err=True)


COMMANDS = [plot_command]
