"""The thesis's use case (7.1.1, 7.1.3) end to end: examples/robapl_nao run by `retalisc robapl
run` with its simulated environment, its golden trace (expected_trace.jsonl; `pytest
--update-golden` rewrites it) and its picture."""
import json
from pathlib import Path

from click.testing import CliRunner

from golden_cases import check_expected
from retalisc.cli import main

NAO = Path(__file__).resolve().parent.parent / "examples" / "robapl_nao"


def run_example(tmp_path, events="events.jsonl"):
    trace_file, picture = tmp_path / "trace.jsonl", tmp_path / "run.png"
    result = CliRunner().invoke(main, ["robapl", "run", str(NAO / "nao.apl"), "--events", str(NAO / events),
                                       "--actions", str(NAO / "environment.py"), "--trace-out", str(trace_file),
                                       "--plot", str(picture)])
    assert result.exit_code == 0, result.output
    return trace_file.read_text(), picture


def test_golden_trace_and_picture(tmp_path, update_golden):
    text, picture = run_example(tmp_path)
    check_expected(NAO / "expected_trace.jsonl", text, update_golden)
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_what_nao_does(tmp_path):
    trace = [json.loads(line) for line in run_example(tmp_path)[0].splitlines()]
    actions = [(r["t"], r["action"]) for r in trace if "action" in r]

    def when(node, to, outcome=None):
        return next(r["t"] for r in trace if r.get("node") == node and r.get("to") == to
                    and (outcome is None or r.get("outcome") == outcome))

    # T1: the reminder at 10 am, finished when the spoken answer is heard
    assert (36000.0, 'say(mori,"Take drug A Mori")') in actions
    assert when("remind#1", "finished", "success") == 36004.0
    # T3 waits for the trash to be dropped (a lower priority): Waiting-Resource until then
    assert when("door#1", "waiting_resource") == 3.0
    assert when("trash#1/carry/drop", "finished", "success") == 12.0 == when("door#1", "executing")
    assert (17.0, "press(open_door_button)") in actions          # alice is a friend: the door opens
    # T7 pre-empts the trash plan: the trash is left on the floor, then NAO walks to the red button
    assert when("trash#2", "failing", "preempted") == 48.0
    assert (48.0, "put_down(trash,floor)") in actions
    assert when("trash#2", "finished", "preempted") == 49.0 == when("help#1", "executing")
    assert (54.0, "press(red_button)") in actions
    assert any(r.get("belief_update") == "help#1/called" and r["post"] == "emergency_called(araz)" for r in trace)


def test_no_answer_three_calls_then_emergency(tmp_path, update_golden):
    """T1 without an answer: three calls 10 s apart (a timeout(10) end condition and a repeat
    counted by iteration/2), then the emergency call of T7 through an abstract node."""
    text, _ = run_example(tmp_path, "events_no_answer.jsonl")
    check_expected(NAO / "expected_no_answer_trace.jsonl", text, update_golden)
    trace = [json.loads(line) for line in text.splitlines()]
    actions = [(r["t"], r["action"]) for r in trace if "action" in r]
    say = 'say(mori,"Take drug A Mori")'
    assert actions == [(36000.0, say), (36010.0, say), (36020.0, say), (36030.0, "move_to(red_button)"),
                       (36035.0, "press(red_button)")]
    assert any(r.get("belief_update") == "remind#1/emergency/help/called" and r["post"] == "emergency_called(mori)"
               for r in trace)


def test_the_stepped_iec_sees_every_node_status_change_of_the_run(tmp_path):
    # an IEC in step derives started(N) from each node_status(N, executing): one for each
    # Executing transition of the trace, at its time, and the agent does what it does without it
    program = tmp_path / "iec.rtl"
    program.write_text("started(N) <- node_status(N, executing).\n")
    trace_file = tmp_path / "trace.jsonl"
    result = CliRunner().invoke(main, ["robapl", "run", str(NAO / "nao.apl"), "--events", str(NAO / "events.jsonl"),
                                       "--actions", str(NAO / "environment.py"), "--iec", str(program),
                                       "--trace-out", str(trace_file)])
    assert result.exit_code == 0, result.output
    trace = [json.loads(line) for line in trace_file.read_text().splitlines()]
    executing = [(r["t"], r["node"]) for r in trace if r.get("to") == "executing"]
    started = [(r["t"], r["event"][len("started("):-1]) for r in trace if r.get("event", "").startswith("started(")]
    assert started == executing and started

    def behaviour(records):
        return [{k: v for k, v in r.items() if k not in ("macro", "micro")} for r in records
                if not r.get("event", "").startswith("started(")]

    golden = [json.loads(line) for line in (NAO / "expected_trace.jsonl").read_text().splitlines()]
    assert behaviour(trace) == behaviour(golden)
