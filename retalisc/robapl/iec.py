"""An information engineering component (thesis 7.3.1) for an agent: a Retalis program whose
derived events join the agent's event base, so that node conditions can be complex events
(`start: event(fire_alarm(S, T))`) detected by ELE rules.

This slice runs the IEC ahead of the agent on the agent's input events, by the one event road
(a LineSource over the event file, the FeedLoop, a sink that keeps the derived events), as the
thesis's IEC runs in a thread of its own beside the deliberation cycle. Each derived event enters
the event base at its end time, after the input events of that time. What the IEC does not see
yet: the events the agent's own actions emit, and the nodes' status, start and end times in its
knowledge base (the thesis's second half of 7.3.1)."""
from __future__ import annotations

import io
from pathlib import Path
from typing import List, Tuple

from .terms import EventSyntaxError, Term, parse_event_term


class IECStopped(Exception):
    """The IEC's run ended with an error (the loop's message)."""


def derived_events(program: Path, events_file: Path) -> Tuple[List[Tuple[float, Term]], List[str]]:
    """The events `program` derives from `events_file`: (end time, term), in the order they were
    derived; and the lines of what could not be read as an agent event."""
    from ..driver.engine import Engine
    from ..driver.feed import FeedLoop, LineSource, Sink, Sinks, file_batches

    class Derived(Sink):
        out_name = "the IEC's events"

        def __init__(self):
            self.events: List[Tuple[float, Term]] = []
            self.bad: List[str] = []

        def write(self, produced) -> None:
            for output in produced:
                if output.op != "add" or output.input or output.consumer:
                    continue
                try:
                    self.events.append((float(output.end), parse_event_term(output.event)))
                except EventSyntaxError as error:
                    self.bad.append(f"{program}: derived event {output.event}: {error}")

    engine = Engine.load(program)
    sink = Derived()
    log = io.StringIO()
    with open(events_file, "rb") as stream:
        status = FeedLoop(engine, LineSource(str(events_file), file_batches(stream, 1000)), Sinks([sink]),
                          signals=False, log=log).run()
    if status != 0:
        raise IECStopped(f"{program}: the IEC stopped with status {status}: {log.getvalue().strip()}")
    # the loop's own lines (rejected event lines, the summary), as `retalisc run` writes them
    return sink.events, sink.bad + log.getvalue().splitlines()
