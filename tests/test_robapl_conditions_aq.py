"""Monitored conditions answered by active queries give the golden traces of the resolver
(retalisc/robapl/conditions_aq.py): the cases without an IEC of their own."""
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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


GOLDEN_AGENTS = [GOLDEN / name for name in ("pause_resume", "invariant", "finishing_fails", "resume_aborted",
                                            "ancestor_skips", "abstract_goals", "finishing_skips", "sequence")]


@st.composite
def scenarios(draw):
    folder = draw(st.sampled_from(GOLDEN_AGENTS))
    words = [term for _, term in read_event_lines((folder / "events.jsonl").read_text()).events]
    count = draw(st.integers(1, 10))
    times = sorted(draw(st.lists(st.integers(0, 60), min_size=count, max_size=count)))
    return folder, [(float(t), draw(st.sampled_from(words))) for t in times]


@settings(max_examples=25, deadline=None)
@given(scenarios())
def test_active_queries_and_the_resolver_give_the_same_trace(scenario):
    folder, events = scenario
    agent = load_agent(folder / "agent.apl")
    actions = str(GOLDEN / "actions.py")
    by_resolution = run_agent(agent, events, load_actions(actions))
    by_queries = run_agent(agent, events, load_actions(actions),
                           conditions=lambda executor: ActiveQueryConditions(agent, executor))
    assert trace_lines(by_queries) == trace_lines(by_resolution)


def test_a_condition_marked_with_a_question_mark_is_an_active_query():
    from retalisc.robapl.syntax import parse_agent
    folder = GOLDEN / "sequence"
    text = (folder / "agent.apl").read_text().replace("[start: finished(first)]", "[start: ? finished(first)]")
    assert text != (folder / "agent.apl").read_text()
    agent = parse_agent(text, str(folder / "agent.apl"))
    second = agent.rules[0].plan.children[1]
    assert second.active_queries == ("start",) and second.conditions["start"] == \
        load_agent(folder / "agent.apl").rules[0].plan.children[1].conditions["start"]
    read = read_event_lines((folder / "events.jsonl").read_text())
    trace = run_agent(agent, read.events, load_actions(str(GOLDEN / "actions.py")))
    assert trace_lines(trace) == (folder / "trace.jsonl").read_text()
