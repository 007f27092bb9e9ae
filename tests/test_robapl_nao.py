"""The thesis's use case (7.1.1, 7.1.3) end to end: examples/robapl_nao run by `retalisc robapl
run` with its simulated environment, its golden trace (expected_trace.jsonl; `pytest
--update-golden` rewrites it) and its picture."""
import importlib.util
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


def environment():
    """examples/robapl_nao/environment.py as a module."""
    spec = importlib.util.spec_from_file_location("robapl_nao_environment", NAO / "environment.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _trace(tmp_path):
    return [json.loads(line) for line in run_example(tmp_path)[0].splitlines()]


def _when(trace, node, to, outcome=None):
    return next(r["t"] for r in trace if r.get("node") == node and r.get("to") == to
                and (outcome is None or r.get("outcome") == outcome))


def _beliefs_added(trace, node):
    return [r["post"] for r in trace if r.get("belief_update") == node]


def test_t2_drug_box_check_every_afternoon(tmp_path):
    """T2 (and 7.1.2): at 3 pm NAO walks to the box and turns its head in parallel, takes the
    picture 2 s after both are done, counts the red pills; on day 0 one is left (nothing more),
    on day 1 none: NAO asks Mori, hears "No" and orders by e-mail, believing ordered(drug_a)."""
    trace = _trace(tmp_path)
    actions = [(r["t"], r["node"], r["action"]) for r in trace if "action" in r]
    day0 = [(t, a) for t, node, a in actions if node.startswith("drug_box#1/")]
    assert day0 == [(54000.0, "move_to(drug_shelf)"), (54000.0, "orient_head(down_left)"),
                    (54007.0, "take_picture(head_camera)"), (54007.0, "count_pills(picture_54007,red,white_box)")]
    assert _when(trace, "drug_box#1/walk", "executing") == _when(trace, "drug_box#1/orient", "executing")
    assert _when(trace, "drug_box#1/picture", "executing") == _when(trace, "drug_box#1/walk", "finished") + 2
    assert _when(trace, "drug_box#1/ask", "finished", "failure") == 54007.0       # pre N = 0 false: one pill left
    assert _beliefs_added(trace, "drug_box#1/ordered") == []
    day1 = [(t, a) for t, node, a in actions if node.startswith("drug_box#2/")]
    assert day1[-2:] == [(140407.0, 'say(mori,"Have you already ordered drug A?")'),
                         (140410.0, 'send_email(drugstore,"Please deliver drug A for Mori")')]
    assert _when(trace, "drug_box#2/ask", "finished", "success") == 140410.0        # the answer heard
    assert _beliefs_added(trace, "drug_box#2/ordered") == ["ordered(drug_a)"]
    assert _when(trace, "drug_box#2", "finished", "success") == 140410.0


def test_t5_where_is_my_key_per_person_and_while_walking(tmp_path):
    """T5: Mori, in front of the camera, says where his key is; Araz asking for his own key is
    not told Mori's; the next day Mori introduces himself and asks while NAO walks to the drug
    box (7.1.3: the plans share no resource), and NAO answers "On the desk" at once."""
    trace = _trace(tmp_path)
    said = [(r["t"], r["action"]) for r in trace if r.get("action", "").startswith("say(")]
    assert _beliefs_added(trace, "remember#1/store") == ["place(mori,key,desk)"]
    assert (54101.0, 'say(mori,"OK, I will remember")') in said
    assert (54201.0, 'say(araz,"I do not know")') in said
    assert (140402.0, "say(mori,on(desk))") in said
    assert _beliefs_added(trace, "introduce#1/who/attend/attend") == ["speaker(mori)"]
    # the answer comes while the walk to the drug box is executing
    assert _when(trace, "drug_box#2/walk", "executing") < 140402.0 < _when(trace, "drug_box#2/walk", "finished")
    assert environment().spoken({"on": ["desk"]}) == "On the desk"


def test_t6_drinks_from_the_kitchen_table(tmp_path):
    """T6: Araz (the last face seen) asks for water: NAO walks to the kitchen table, picks it up,
    walks to Araz's armchair and hands it over, holding hands and legs throughout."""
    trace = _trace(tmp_path)
    actions = [(r["t"], r["action"]) for r in trace if "action" in r and r["node"].startswith("drinks#1/")]
    assert actions == [(54300.0, "move_to(kitchen_table)"), (54305.0, "pick_up(water)"),
                       (54306.0, "move_to(armchair)"), (54311.0, "hand_over(water,araz)")]
    assert _beliefs_added(trace, "drinks#1/served") == ["served(araz,water)"]
    assert _when(trace, "drinks#1", "finished", "success") == 54312.0


def test_the_simulated_drug_box_empties_one_pill_a_day():
    assert [environment().pills_left(t) for t in (0, 36000, 54000, 122400, 140400, 300000)] == [2, 1, 1, 0, 0, 0]
