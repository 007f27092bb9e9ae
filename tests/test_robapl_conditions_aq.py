"""Monitored conditions answered by active queries give the golden traces of the resolver
(retalisc/robapl/conditions_aq.py): the cases without an IEC of their own."""
from pathlib import Path

import pytest

from retalisc.robapl.conditions_aq import ActiveQueryConditions
from retalisc.robapl.runner import load_actions, read_event_lines, run_agent, trace_lines
from retalisc.robapl.syntax import load_agent

GOLDEN = Path(__file__).resolve().parent / "golden_robapl"
CASES = sorted(p for p in GOLDEN.iterdir() if (p / "agent.apl").exists() and not (p / "iec.rtl").exists()
               and "} <-" not in (p / "agent.apl").read_text() and "<- {" not in (p / "agent.apl").read_text())


@pytest.mark.parametrize("folder", CASES, ids=lambda p: p.name)
def test_active_query_conditions_give_the_golden_trace(folder):
    read = read_event_lines((folder / "events.jsonl").read_text())
    agent = load_agent(folder / "agent.apl")
    sources = []
    trace = run_agent(agent, read.events, load_actions(str(GOLDEN / "actions.py")),
                      conditions=lambda executor: sources.append(ActiveQueryConditions(agent, executor)) or sources[0])
    assert trace_lines(trace) == (folder / "trace.jsonl").read_text()
    # the monitored conditions the knowledge base can answer were registered and answered there
    assert bool(sources[0]._queries) == bool(sources[0].rules)
