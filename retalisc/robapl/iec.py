"""An information engineering component (thesis 7.3.1) for an agent: a Retalis program run in
process, in step with the agent's macro steps (`Executor(iec=SteppedIEC...)`), whose derived
events join the agent's event base, so that node conditions can be complex events
(`start: event(visitor(P))`) detected by ELE rules.

After each macro step the IEC gets the step's event (an input event, an action's result, an
event an action emitted, a timer; not one it derived itself) and then the node status changes
of the step, as events `node_status(NodeId, State)` at the step's time: a node's start time is
the time of its `node_status(Id, executing)`, its end time that of `node_status(Id, finished)`
(or `iteration_ended`), and an SLR memory of the IEC program can keep them for its queries.
What it derives joins the event base at its end time, after the events already queued for that
time. Events are fed by the one event road (driver/feed.py's `feed_resilient`): a refused event
is a problem kept in `problems`, and the run goes on."""
from __future__ import annotations

from pathlib import Path
import re
from typing import List, Sequence, Tuple

from .terms import Atom, Compound, EventSyntaxError, Term, parse_event_term

_PLAIN_ATOM = re.compile(r"[a-z][A-Za-z0-9_]*\Z")


def event_text(term: Term) -> str:
    """`term` as the text of a Retalis event (atoms quoted when they need it): data on the
    event road, read by the runtime's event reader, never program text."""
    if isinstance(term, Atom):
        return atom_text(term.name)
    if isinstance(term, Compound):
        return f"{atom_text(term.functor)}({','.join(event_text(a) for a in term.args)})"
    if isinstance(term, str):
        return '"' + term.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(term, bool) or not isinstance(term, (int, float)):
        raise ValueError(f"not an event term: {term!r}")
    return repr(term)


def atom_text(name: str) -> str:
    if _PLAIN_ATOM.match(name):
        return name
    return "'" + name.replace("\\", "\\\\").replace("'", "\\'") + "'"


def is_derived(output) -> bool:
    """An output that is an event the program derived (not an input echoed, not a delivery)."""
    return output.op == "add" and not output.input and not output.consumer


class SteppedIEC:
    """A Retalis program run in process, in step with the agent's macro steps, fed by the one
    event road (driver/feed.py's `feed_resilient`). `problems` keeps what the runtime refused
    or failed on (an event is data: reported, and the run goes on)."""

    def __init__(self, engine, name: str = "the IEC"):
        self.engine = engine
        self.name = name
        self.problems: List[str] = []
        self.fed = 0

    @classmethod
    def load(cls, program: Path) -> "SteppedIEC":
        from ..driver.engine import Engine
        return cls(Engine.load(program), str(program))

    @classmethod
    def from_source(cls, text: str, name: str = "iec.rtl") -> "SteppedIEC":
        from ..driver.engine import Engine
        return cls(Engine.from_source(text, name), name)

    def step(self, time: float, events: Sequence[Term], changes: Sequence[Tuple[str, str]]
             ) -> List[Tuple[float, Term]]:
        """Feed the macro step's events then its status changes at `time`; the derived events
        (end time, term) in the order derived."""
        from ..driver.feed import feed_resilient

        items = [(event_text(e), time, e) for e in events]
        items += [(event_text(Compound("node_status", (Atom(path), Atom(state)))), time, (path, state))
                  for path, state in changes]
        if not items:
            return []
        produced: list = []

        def refuse(item):
            raise ValueError("the runtime refused the event's text")

        problems, fed = feed_resilient(self.engine, items, produced.extend, refuse, lambda item: self.name)
        self.fed += fed
        self.problems += [f"{p.where}: {p.kind}: {p.text}" for p in problems]
        derived: List[Tuple[float, Term]] = []
        for output in produced:
            if not is_derived(output):
                continue
            try:
                derived.append((float(output.end), parse_event_term(output.event)))
            except EventSyntaxError as error:
                self.problems.append(f"{self.name}: derived event {output.event}: {error}")
        return derived

    def close(self) -> None:
        self.engine.close()
