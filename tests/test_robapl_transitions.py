"""RobAPL transitions, one golden case each (tests/golden_robapl/<case>/: agent.apl,
events.jsonl, the expected trace.jsonl; `pytest --update-golden` rewrites the traces, review the
diff). Every transition of the executor's table (`TRANSITIONS`, the table of docs/robapl.md) is
made by at least one case."""
import json
from pathlib import Path

import pytest

from golden_cases import check_expected
from retalisc.robapl.executor import TRANSITIONS
from retalisc.robapl.iec import SteppedIEC
from retalisc.robapl.patterns import agent_iec, condition_rules
from retalisc.robapl.runner import load_actions, read_event_lines, run_agent, trace_lines
from retalisc.robapl.syntax import load_agent, parse_agent
from retalisc.robapl.terms import Atom, Compound

GOLDEN = Path(__file__).resolve().parent / "golden_robapl"
CASES = sorted(p for p in GOLDEN.iterdir() if (p / "agent.apl").exists())


def run_case(folder: Path):
    read = read_event_lines((folder / "events.jsonl").read_text(), str(folder / "events.jsonl"))
    assert not read.bad
    agent = load_agent(folder / "agent.apl")
    program = folder / "iec.rtl"
    # an IEC in step (its own program, the ELE rules of the pattern conditions): its derived events join the event base
    iec = agent_iec(agent, program.read_text() if program.exists() else None, str(program))
    try:
        return run_agent(agent, read.events, load_actions(str(GOLDEN / "actions.py")), iec=iec)
    finally:
        if iec is not None:
            assert iec.problems == []
            iec.close()


@pytest.mark.parametrize("folder", CASES, ids=lambda p: p.name)
def test_golden_trace(folder, update_golden):
    check_expected(folder / "trace.jsonl", trace_lines(run_case(folder)), update_golden)


def test_every_transition_has_a_golden_case():
    made = set()
    for folder in CASES:
        for line in (folder / "trace.jsonl").read_text().splitlines():
            record = json.loads(line)
            if "to" in record and record["why"] != "reset":
                made.add((record["from"], record["to"], record["why"]))
    assert made <= set(TRANSITIONS), f"transitions outside the table: {made - set(TRANSITIONS)}"
    assert set(TRANSITIONS) <= made, f"transitions no golden case makes: {set(TRANSITIONS) - made}"


def test_a_condition_that_is_a_complex_event_of_the_iec():
    trace = run_case(GOLDEN / "iec_condition")
    assert [r["event"] for r in trace if "event" in r] == ["at_door(alice)", "bell", "visitor(alice)"]
    assert [(r["t"], r["action"]) for r in trace if "action" in r] == [(4.0, "act(alice)")]
    alone = read_event_lines('{"t": 4, "event": "bell"}')
    trace = run_agent(load_agent(GOLDEN / "iec_condition" / "agent.apl"), alone.events,
                      load_actions(str(GOLDEN / "actions.py")))
    assert not [r for r in trace if "action" in r]      # no visitor derived: the greeting never starts


def _records(trace, node):
    return [(r["from"], r["to"], r.get("outcome")) for r in trace if r.get("node") == node and "to" in r]


def test_preemption_runs_wind_down_bottom_up_before_the_root_ends():
    trace = run_case(GOLDEN / "preempt")
    order = [r["node"] for r in trace if "to" in r and r["to"] == "finished"]
    assert order.index("low#1/inner/inner_down") < order.index("low#1/inner") < \
        order.index("low#1/outer_down") < order.index("low#1")
    assert ("failing", "finished", "preempted") in _records(trace, "low#1")
    assert ("failing", "finished", "parent_preempted") in _records(trace, "low#1/inner")
    started = [r["node"] for r in trace if r.get("to") == "executing"]
    assert started.index("high#1") > started.index("low#1/outer_down/note")


def test_pause_keeps_finished_children_and_reruns_the_interrupted_one():
    trace = run_case(GOLDEN / "pause_resume")
    actions = [r["action"] for r in trace if "action" in r]
    assert actions == ["act(one)", "long(two,5)", "act(brake)", "act(warm)", "long(two,5)"]
    assert ("executing", "failing", "parent_failure") in _records(trace, "plan#1/two")


def test_synchronous_micro_step_sees_one_snapshot():
    trace = run_case(GOLDEN / "repeat")
    ran = [r["belief_update"] for r in trace if "belief_update" in r]
    assert ran == ["plan#1/loop/r2", "plan#1/loop/r3"]


def test_the_stepped_iec_sees_node_status_and_the_events_actions_emit():
    # the IEC derives started(N) from node_status(N, executing) and heard(X) from an event the
    # agent's own action emitted: both reach the agent as events of later macro steps
    iec = SteppedIEC.from_source("started(N) <- node_status(N, executing).\n"
                                 "heard(X) <- echo(X).\n", "stepped.rtl")
    agent = parse_agent(
        "rules {\n  go <- true | list p {\n    external say: shout(hi)\n  }\n}\n")
    actions = load_actions(None)

    def shout(word, context):
        context.emit(Compound("echo", (Atom(word),)))
        return "done"

    actions.register("shout", shout)
    try:
        trace = run_agent(agent, [(1.0, Atom("go"))], actions, iec=iec)
    finally:
        problems = iec.problems
        iec.close()
    assert problems == []
    events = [r["event"] for r in trace if "event" in r]
    assert events[0] == "go"
    assert "started(p#1)" in events and "started(p#1/say)" in events and "echo(hi)" in events
    assert events.index("echo(hi)") < events.index("heard(hi)")
    assert all(r["t"] == 1.0 for r in trace)


def test_a_pattern_condition_is_an_ele_rule_of_the_iec_giving_the_hand_written_trace():
    # the ELE road: the pattern condition compiled to a rule of the IEC gives the trace of the
    # same rule written by hand in iec.rtl with an event(...) condition
    agent = load_agent(GOLDEN / "pattern_condition" / "agent.apl")
    assert [r.splitlines()[1] for r in condition_rules(agent)] == ["visitor(P) <- (at_door(P) seq bell).10."]
    assert trace_lines(run_case(GOLDEN / "pattern_condition")) == trace_lines(run_case(GOLDEN / "iec_condition"))
    alone = read_event_lines('{"t": 4, "event": "bell"}')
    iec = agent_iec(agent)
    try:
        trace = run_agent(agent, alone.events, load_actions(str(GOLDEN / "actions.py")), iec=iec)
    finally:
        iec.close()
    assert not [r for r in trace if "action" in r]      # no visitor derived: the greeting never starts
