"""Running an agent on event lines: JSON Lines `{"t": SECONDS, "event": "TERM"}` in, the trace
out (one JSON object per line: events, plans adopted, transitions, actions).

An event line is data: its term is read by `terms.parse_event_term` (atoms, numbers, strings,
compounds), never run. A bad line is reported with its line number and reason, counted, and the
stream goes on."""
from __future__ import annotations

import importlib.util
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional, Tuple

from .executor import Actions, Executor
from .syntax import Agent
from .terms import EventSyntaxError, Term, parse_event_term


@dataclass
class EventLines:
    events: List[Tuple[float, Term]] = field(default_factory=list)
    bad: List[str] = field(default_factory=list)


def read_event_lines(text: str, name: str = "<events>") -> EventLines:
    read = EventLines()
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            item = json.loads(line)
            if not isinstance(item, dict) or not isinstance(item.get("event"), str):
                raise ValueError('an event line is {"t": SECONDS, "event": "TERM"}')
            time = item.get("t", 0)
            if isinstance(time, bool) or not isinstance(time, (int, float)):
                raise ValueError('"t" is a number of seconds')
            read.events.append((float(time), parse_event_term(item["event"])))
        except (ValueError, EventSyntaxError) as error:
            read.bad.append(f"{name}:{number}: {error}")
    return read


def load_actions(path: Optional[str]) -> Actions:
    """The actions of a Python file defining `register(actions)` (the robot programmer's code,
    like a plan: not run-time input), or no actions."""
    actions = Actions()
    if path is not None:
        spec = importlib.util.spec_from_file_location(f"robapl_actions_{Path(path).stem}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        module.register(actions)
    return actions


def run_agent(agent: Agent, events: List[Tuple[float, Term]], actions: Actions, iec=None, conditions=None
              ) -> List[dict]:
    """The trace of `agent` on `events`; `iec` an `iec.SteppedIEC` driven in step with it,
    `conditions` a `conditions.ConditionSource` (default: resolution on the belief base)."""
    executor = Executor(agent, actions, iec=iec)
    if conditions is None and _marks_active_queries(agent):
        from .conditions_aq import ActiveQueryConditions
        executor.conditions = ActiveQueryConditions(agent, executor, only_marked=True)
    elif conditions is not None:
        executor.conditions = conditions(executor)
    return executor.run(events)


def _marks_active_queries(agent: Agent) -> bool:
    stack = [rule.plan for rule in agent.rules]
    while stack:
        spec = stack.pop()
        if spec.active_queries:
            return True
        stack.extend(spec.children)
    return False


def trace_lines(trace: List[dict]) -> str:
    return "".join(json.dumps(record, sort_keys=False) + "\n" for record in trace)
