"""RobAPL external actions as ROS 2 service calls and actions (retalisc/robapl/ros2_actions.py)
against an independent rclpy server process (tests/robapl_ros2_server.py, .venv-ros2's
Python): `retalisc robapl run` is started from this Python and hands over to .venv-ros2's; each
test has a ROS 2 domain of its own, discovery on the loopback, every process stopped by its pid.
The ResultInbox's clock and time-outs are tested without ROS 2."""
from __future__ import annotations

import json
import os
import subprocess
import threading
import time
from pathlib import Path

import pytest

from live_support import ROOT, Processes, RosDomain, retalisc_argv, retalisc_env, this_python
from retalisc.robapl.ros2_actions import ResultInbox
from retalisc.robapl.terms import Compound

ROS2_PYTHON = Path(os.environ.get("RETALISC_ROS2_PYTHON") or ROOT / ".venv-ros2" / "bin" / "python")
# the colcon install of ros/robapl_interfaces: setup.sh's, or another named by $ROBAPL_INTERFACES
INTERFACES = Path(os.environ.get("ROBAPL_INTERFACES") or ROOT / ".ros2-build" / "install" / "robapl_interfaces")
needs_ros2 = pytest.mark.skipif(not ROS2_PYTHON.exists(), reason="no .venv-ros2 (bash setup.sh makes it)")

ACTIONS = """
from retalisc.robapl.ros2_actions import Ros2Actions

def register(actions):
    ros2 = Ros2Actions(actions, node_name="robapl_test_agent")
    ros2.service("close_gripper", "/gripper", "std_srvs/srv/SetBool")
    ros2.service("press_button", "/press", "std_srvs/srv/Trigger")
    ros2.service("ring", "/no_such_service", "std_srvs/srv/Trigger", wait=0.5)
    if WITH_ACTION:
        ros2.action("carry", "/perform", "robapl_interfaces/action/Perform")
    else:
        actions.register("carry", lambda thing, to, context: "carried here")   # a Python callable beside them
"""

AGENT = """
agent arm.
resources { hands: 1. }
rules {
  grasp(O) <- true | list grasp [priority: 1; resources: <hands, blocking, 1>] {
    external close: close_gripper(true) [result: Said]
    external press: press_button [start: finished(close); pre: succeeded(close), Said = closed]
    external carry: carry(O, table) [start: finished(press); pre: succeeded(press); result: R]
    belief_update held [start: finished(carry); pre: succeeded(carry); post: carried(O, R)]
  }
  refuse <- true | list refuse {
    external open: close_gripper(false)
  }
  bell <- true | list bell {
    external ring: ring
  }
  help <- true | list help [priority: 5; resources: <hands, blocking, 1>] {
    external call: press_button
  }
}
"""


def _env(domain: int) -> dict:
    env = retalisc_env({"ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                        "RETALISC_ROS2_PYTHON": str(ROS2_PYTHON)})
    for key in ("ROS_STATIC_PEERS", "ROS_LOCALHOST_ONLY", "RMW_IMPLEMENTATION", "FASTRTPS_DEFAULT_PROFILES_FILE"):
        env.pop(key, None)
    site = INTERFACES / "lib" / "python3.11" / "site-packages"
    if INTERFACES.exists():
        sites = sorted((INTERFACES / "lib").glob("python3*/site-packages"))
        site = sites[0] if sites else site
        env["PYTHONPATH"] += os.pathsep + str(site)
        env["LD_LIBRARY_PATH"] = os.pathsep.join(p for p in (str(INTERFACES / "lib"), env.get("LD_LIBRARY_PATH")) if p)
    return env


def _has_action_type(env: dict) -> bool:
    found = subprocess.run([str(ROS2_PYTHON), "-c", "import robapl_interfaces.action"], env=env,
                           capture_output=True, timeout=60)
    return found.returncode == 0


def run_agent(tmp_path, events, with_action):
    """Runs AGENT on `events` against the server: (the trace, what the server saw)."""
    domain = RosDomain()
    env = _env(domain.id)
    if with_action and not _has_action_type(env):
        domain.release()
        pytest.skip("robapl_interfaces (ros/robapl_interfaces) is not built: bash setup.sh builds it")
    (tmp_path / "arm.apl").write_text(AGENT)
    (tmp_path / "actions.py").write_text(f"WITH_ACTION = {with_action}\n" + ACTIONS)
    (tmp_path / "events.jsonl").write_text("".join(json.dumps({"t": t, "event": e}) + "\n" for t, e in events))
    processes = Processes(tmp_path)
    try:
        server = processes.start("server", [str(ROS2_PYTHON), str(ROOT / "tests" / "robapl_ros2_server.py")], env)
        processes.wait_for_line(server, "ready", 60)
        agent = processes.start("agent", retalisc_argv(this_python, "robapl", "run", str(tmp_path / "arm.apl"),
                                                       "--events", str(tmp_path / "events.jsonl"), "--actions",
                                                       str(tmp_path / "actions.py"), "--trace-out",
                                                       str(tmp_path / "trace.jsonl")), env)
        agent.wait(120)
        assert agent.returncode == 0, processes.err("agent")
        time.sleep(0.3)            # the server's last lines (a cancel's result) are written
    finally:
        processes.stop_all()
        domain.release()
    trace = [json.loads(line) for line in (tmp_path / "trace.jsonl").read_text().splitlines()]
    seen = [json.loads(line) for line in processes.out("server").splitlines() if line.startswith("{")]
    return trace, seen


def _transition(trace, node, to):
    return next((r for r in trace if r.get("node") == node and r.get("to") == to), None)


@needs_ros2
def test_services_results_and_failures_come_back_as_events(tmp_path):
    """SetBool and Trigger calls: the response's message is the result (bound by `result:` and
    tested by the next node's pre condition); a false `success` is an action_failed event."""
    trace, seen = run_agent(tmp_path, [(0, "grasp(cup)"), (5, "refuse"), (6, "bell")], with_action=False)
    events = [r["event"] for r in trace if "event" in r]
    assert any(e.startswith('action_result("grasp#1/close@') and e.endswith(",closed)") for e in events)
    assert any(e.startswith('action_result("grasp#1/press@') and e.endswith(",pressed)") for e in events)
    assert _transition(trace, "grasp#1/press", "iteration_ended")["outcome"] == "success"
    assert [r["post"] for r in trace if r.get("belief_update") == "grasp#1/held"] == ['carried(cup,"carried here")']
    assert any(e.startswith('action_failed("refuse#1/open@') and e.endswith(',"refused")') for e in events)
    failed = _transition(trace, "refuse#1/open", "iteration_ended")
    assert failed["outcome"] == "failure" and failed["why"] == "action failed"
    # a service no server offers: the action fails at once (after `wait`), the run goes on
    assert _transition(trace, "bell#1/ring", "iteration_ended")["why"] == "action failed"
    assert _transition(trace, "bell#1", "finished")["outcome"] == "success"
    assert seen[:2] == [{"service": "gripper", "data": True}, {"service": "press"}]
    assert {"service": "gripper", "data": False} in seen
    # the Trigger answers after 0.3 s: the node waited for its result event, on the agent's clock
    press = _transition(trace, "grasp#1/press", "executing")["t"]
    assert _transition(trace, "grasp#1/press", "iteration_ended")["t"] - press >= 0.3


@needs_ros2
def test_a_ros2_action_runs_to_its_result(tmp_path):
    trace, seen = run_agent(tmp_path, [(0, "grasp(cup)")], with_action=True)
    assert {"goal": "carry", "arguments": ["cup", "table"]} in seen
    assert {"result": "carry", "status": "succeeded"} in seen
    carry = _transition(trace, "grasp#1/carry", "executing")["t"]
    assert _transition(trace, "grasp#1/carry", "iteration_ended")["t"] - carry >= 4.0
    assert [r["post"] for r in trace if r.get("belief_update") == "grasp#1/held"] == ['carried(cup,"carry done")']
    assert _transition(trace, "grasp#1", "finished")["outcome"] == "success"


@needs_ros2
def test_a_preempted_plan_cancels_its_ros2_goal(tmp_path):
    """help (priority 5) needs the hands the grasp plan holds while its carry goal runs: the plan
    is pre-empted, the carry node aborted, its goal cancelled on the server; then help runs."""
    trace, seen = run_agent(tmp_path, [(0, "grasp(cup)"), (2.0, "help")], with_action=True)
    assert {"goal": "carry", "arguments": ["cup", "table"]} in seen
    assert {"cancel": "carry"} in seen
    assert any(s.get("result") == "carry" and s.get("status") == "canceled" for s in seen)
    assert any(r.get("abort") == "grasp#1/carry" for r in trace)
    assert _transition(trace, "grasp#1", "finished")["outcome"] == "preempted"
    assert not any(r.get("belief_update") == "grasp#1/held" for r in trace)
    assert _transition(trace, "help#1/call", "iteration_ended")["outcome"] == "success"
    assert _transition(trace, "help#1/call", "executing")["t"] >= 2.0


def test_ros2_actions_without_rclpy_are_a_clear_error(tmp_path):
    """No rclpy here and no ROS 2 Python to hand over to: exit status 1 and what to do."""
    pytest.importorskip("lark")
    try:
        import rclpy  # noqa: F401
        pytest.skip("this Python has rclpy")
    except ImportError:
        pass
    (tmp_path / "arm.apl").write_text(AGENT)
    (tmp_path / "actions.py").write_text("WITH_ACTION = False\n" + ACTIONS)
    (tmp_path / "events.jsonl").write_text('{"t": 0, "event": "refuse"}\n')
    done = subprocess.run(retalisc_argv(this_python, "robapl", "run", str(tmp_path / "arm.apl"), "--events",
                                        str(tmp_path / "events.jsonl"), "--actions", str(tmp_path / "actions.py")),
                          env=retalisc_env({"RETALISC_ROS2_PYTHON": str(tmp_path / "no-python")}),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 1 and "ROS 2 actions need rclpy" in done.stderr, done.stderr


# ----- the inbox, without ROS 2

def test_the_inbox_waits_for_a_result_until_the_next_event_is_due():
    inbox = ResultInbox(timeout=5.0)
    inbox.expect("a@1", 10.0)
    threading.Timer(0.2, inbox.answer, ("a@1", True, "done")).start()
    started = time.monotonic()
    (at, event), = inbox.collect(None)
    assert 0.15 <= time.monotonic() - started < 2.0
    assert event == Compound("action_result", ("a@1", "done")) and 10.15 <= at < 12.0
    # an event due before the answer is taken first: collect returns nothing once its time has come
    inbox.expect("b@2", at)
    assert inbox.collect(at + 0.1) == [] and inbox.outstanding() == 1
    assert inbox.forget("b@2") and inbox.collect(None) == []


def test_the_inbox_fails_an_unanswered_call_after_its_timeout_and_drops_late_answers():
    inbox = ResultInbox(timeout=0.2)
    inbox.expect("c@3", 1.0)
    (at, event), = inbox.collect(None)
    assert event == Compound("action_failed", ("c@3", "timeout")) and at == pytest.approx(1.2)
    inbox.answer("c@3", True, "late")
    assert inbox.collect(None) == [] and inbox.outstanding() == 0


class _Message:
    """A stand-in for a generated rclpy message class: its fields in declared order."""
    FIELDS: dict = {}

    def __init__(self, **values):
        for name in self.FIELDS:
            setattr(self, name, values.get(name))

    @classmethod
    def get_fields_and_field_types(cls):
        return dict(cls.FIELDS)


class SetBool_Request(_Message):
    FIELDS = {"data": "boolean"}


class AddTwoInts_Response(_Message):
    FIELDS = {"sum": "int64"}


class Pose_Response(_Message):
    FIELDS = {"success": "boolean", "x": "double", "frame": "string"}


def test_requests_are_filled_in_field_order_and_answers_read_by_the_defaults():
    from retalisc.robapl.executor import ActionFailed
    from retalisc.robapl.ros2_actions import fill_message, message_value
    from retalisc.robapl.terms import Atom

    assert fill_message(SetBool_Request, ("true",)).data is True
    assert fill_message(SetBool_Request, (False,)).data is False
    with pytest.raises(ActionFailed, match="boolean"):
        fill_message(SetBool_Request, ("maybe",))
    with pytest.raises(ActionFailed, match="1 fields"):
        fill_message(SetBool_Request, ("true", "true"))
    assert message_value(AddTwoInts_Response(sum=5)) == (True, 5)
    assert message_value(Pose_Response(success=True, x=1.5, frame="map")) == \
        (True, Compound("pose", (1.5, Atom("map"))))
    assert message_value(Pose_Response(success=False, x=0.0, frame="map")) == (False, "failed")


def test_every_call_is_answered_once_stamped_no_earlier_than_its_call():
    from hypothesis import given, settings, strategies as st

    @settings(max_examples=60, deadline=None)
    @given(st.lists(st.tuples(st.floats(0, 100), st.sampled_from(["answer", "forget", "late"])), max_size=8))
    def check(calls):
        inbox = ResultInbox(timeout=1000.0)
        at, times = 0.0, []
        for number, (step, fate) in enumerate(calls):
            at += step
            times.append(at)
            inbox.expect(f"h@{number}", at)
            if fate == "answer":
                inbox.answer(f"h@{number}", True, number)
            elif fate == "forget":
                assert inbox.forget(f"h@{number}")
        answered = [number for number, (_, fate) in enumerate(calls) if fate == "answer"]
        got = inbox.collect(inbox.now())         # the next event is due: no waiting for the late ones
        assert [event.args[1] for _, event in got] == answered
        assert all(stamp >= times[event.args[1]] for stamp, event in got)
        for number, (_, fate) in enumerate(calls):
            inbox.answer(f"h@{number}", True, number)           # a second answer is dropped
        late = [number for number, (_, fate) in enumerate(calls) if fate == "late"]
        assert [event.args[1] for _, event in inbox.collect(None)] == late and inbox.outstanding() == 0

    check()
