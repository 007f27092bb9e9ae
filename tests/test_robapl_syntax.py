"""RobAPL agent files: the parse, the located errors (`file:line:col: message`, exit 2) and
`retalisc robapl check|run`."""
import json

import pytest
from click.testing import CliRunner

from retalisc.cli import main
from retalisc.frontend.errors import RetalisError
from retalisc.robapl.runner import read_event_lines
from retalisc.robapl.syntax import parse_agent
from retalisc.robapl.terms import Atom, Compound

AGENT = """agent demo.
beliefs { likes(mori, tea). known(F) :- friend(F). friend(alice). }
goals { tidy(room). }
resources { hands: 1. }
rules {
  tidy(R) <- likes(mori, tea) | list clean [priority: 3; resources: <hands, using, 1>] {
    external wipe: wipe(R) [end: done; result: X]
    belief_update note [start: finished(wipe); post: clean(R)]
    on_preempt stop { external put: put_down(cloth) }
  }
}
"""


def test_agent_parts():
    agent = parse_agent(AGENT, "demo.apl")
    assert agent.name == "demo"
    assert agent.pool == {"hands": 1}
    assert agent.goals == [Compound("tidy", (Atom("room"),))]
    assert len(agent.beliefs) == 3
    plan = agent.rules[0].plan
    assert (plan.kind, plan.name, plan.priority) == ("list", "clean", 3)
    assert [c.kind for c in plan.children] == ["external", "belief_update", "on_preempt"]
    assert plan.children[0].result == "X"
    assert str(plan.resources[0]) == "<hands, using, 1>"


@pytest.mark.parametrize("text, where, message", [
    ("rules { go <- true | external x: act }", "1:22", "root of a plan is a list node"),
    ("rules { go <- true | list p { external x } }", "1:31", "needs a term"),
    ("rules { go <- true | list p { goal_update g: want(x) } }", "1:31", "adopt(Goal) or drop(Goal)"),
    ("rules { go <- true | list p { belief_update b } }", "1:31", "needs a post condition"),
    ("rules { go <- true | list p [resources: <arm, using, 1>] { } }", "1:41", "not in the resources section"),
    ("resources { arm: 1. }\nrules { go <- true | list p [resources: <arm, using, 2>] { } }", "2:41", "the pool has 1"),
    ("rules { go <- true | list p { external a: act external a: act } }", "1:47", "two children of p"),
    ("rules { go <- true | list p [start: a; start: b] { } }", "1:40", "given twice"),
    ("rules { go <- true | list p [when: a] { } }", "1:30", "unexpected"),
    ("beliefs { likes(mori }", "1:22", "unexpected"),
])
def test_located_errors(text, where, message):
    with pytest.raises(RetalisError) as error:
        parse_agent(text, "bad.apl")
    rendered = error.value.render(text)
    assert rendered.startswith(f"bad.apl:{where}:"), rendered
    assert message in rendered


def test_check_command(tmp_path):
    good = tmp_path / "good.apl"
    good.write_text(AGENT)
    result = CliRunner().invoke(main, ["robapl", "check", str(good)])
    assert result.exit_code == 0, result.output
    assert "agent demo: 3 beliefs, 1 goals, 1 resources, 1 rules, 5 plan nodes" in result.output
    bad = tmp_path / "bad.apl"
    bad.write_text("rules {\n  go <- true | list p { external x }\n}\n")
    for command in (["robapl", "check"], ["check"]):      # `retalisc check` knows agent files too
        result = CliRunner().invoke(main, command + [str(bad)])
        assert result.exit_code == 2
        assert f"{bad}:2:25: error: external node x needs a term" in result.output
    assert CliRunner().invoke(main, ["check", str(good)]).exit_code == 0


def test_bad_event_lines_are_reported_counted_and_skipped():
    text = "\n".join([
        '{"t": 0, "event": "go"}',
        'not json',
        '{"t": "soon", "event": "go"}',
        '{"t": 1, "event": "go(X)"}',
        '{"t": 2, "event": "f(a,"}',
        '{"t": 3, "event": "heard(mori, \\"OK\\")"}',
    ])
    read = read_event_lines(text, "e.jsonl")
    assert [t for t, _ in read.events] == [0.0, 3.0]
    assert read.events[1][1] == Compound("heard", (Atom("mori"), "OK"))
    assert [line.split(":")[1] for line in read.bad] == ["2", "3", "4", "5"]


def test_run_command_writes_the_trace(tmp_path):
    agent = tmp_path / "a.apl"
    agent.write_text("rules { go <- true | list p { belief_update b [post: done_it] } }")
    events = tmp_path / "e.jsonl"
    events.write_text('{"t": 0, "event": "go"}\nbroken\n')
    out = tmp_path / "t.jsonl"
    result = CliRunner().invoke(main, ["robapl", "run", str(agent), "--events", str(events), "--trace-out", str(out)])
    assert result.exit_code == 0, result.output
    assert "1 bad event lines skipped" in result.output
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert records[-1]["to"] == "deactivating" and records[-1]["outcome"] == "success"


def test_a_pattern_condition_is_checked_as_an_ele_rule_at_its_place(tmp_path):
    text = "rules {\n  bell <- true | list greet {\n    external hello: act(P) [start: visitor(P) <- {%s}]\n  }\n}\n"
    good = tmp_path / "good.apl"
    good.write_text(text % "(at_door(P) seq bell).10")
    spec = parse_agent(good.read_text(), str(good)).rules[0].plan.children[0]
    assert spec.conditions["start"] == (parse_agent("rules { e <- true | list p [end: event(visitor(P))] }")
                                        .rules[0].plan.conditions["end"])
    assert spec.patterns["start"][1] == "(at_door(P) seq bell).10"
    result = CliRunner().invoke(main, ["robapl", "check", str(good)])
    assert result.exit_code == 0 and "1 pattern conditions" in result.output, result.output
    bad = tmp_path / "bad.apl"
    bad.write_text(text % "(at_door(P) seq ).10")
    result = CliRunner().invoke(main, ["robapl", "check", str(bad)])
    assert result.exit_code == 2
    assert f"{bad}:3:29: error: node hello: the start pattern is not an ELE rule body" in result.output, result.output
