"""The live ROS 2 node (`retalisc ros2`, rclpy) against an independent rclpy process
(tests/ros2_client.py, run with .venv-ros2's Python): the node and its services in the graph
API, its parameters, topics both ways with their output numbers, a transient-local
/tf_static published before the node started, reliable and best-effort inputs, /clock under
use_sim_time, every Retalis service with its ok and error replies (an unsafe query
refused), and a burst of 5,000 messages on a reliable keep-all input; then a node killed and
restarted with --state. One node and one client serve the tests of the session fixture; stock
discovery settings, a domain of its own (RosDomain); each process stopped by its pid."""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

from live_support import LIVE, ROOT, Processes, RosDomain, retalisc_argv, retalisc_env, this_python
from retalisc.live.config import ConfigError, QosSpec, parse_config
from retalisc.live.ros1_services import MESSAGES, PACKAGE, SERVICES

ROS2_PYTHON = Path(os.environ.get("RETALISC_ROS2_PYTHON") or ROOT / ".venv-ros2" / "bin" / "python")
INTERFACES = ROOT / "ros" / "retalis_interfaces"
needs_ros2 = pytest.mark.skipif(not ROS2_PYTHON.exists(), reason="no .venv-ros2 (bash setup.sh makes it)")


def _definition(text: str) -> str:
    """A .srv/.msg text without comments and blank lines."""
    lines = [line.split("#")[0].strip() for line in text.splitlines()]
    return "\n".join(line for line in lines if line)


def test_interface_package_has_the_ros1_services():
    """ros/retalis_interfaces defines the services of the ROS 1 node, field for field (the one
    renamed field aside: `template` is a C++ keyword)."""
    for name, (type_name, text) in SERVICES.items():
        ros1 = text.replace(f"{PACKAGE}/", "").replace("string template\n", "string event_template\n")
        assert _definition((INTERFACES / "srv" / f"{type_name}.srv").read_text()) == _definition(ros1), name
    for name, text in MESSAGES.items():
        assert _definition((INTERFACES / "msg" / f"{name}.msg").read_text()) == _definition(text)
    cmake = (INTERFACES / "CMakeLists.txt").read_text()
    assert all(f'"srv/{type_name}.srv"' in cmake for type_name, _ in SERVICES.values())


def test_pub_sub_qos_attributes():
    config = parse_config('<publish_subscribe>'
                          '<subscribe_to name="/scan" msg_type="sensor_msgs/LaserScan" qos="sensor_data"/>'
                          '<subscribe_to name="/odom" msg_type="nav_msgs/Odometry" reliability="reliable" '
                          'durability="transient_local" depth="5"/>'
                          '<subscribe_to name="/tf" msg_type="tf2_msgs/TFMessage"/>'
                          '<publish_to name="out" msg_type="std_msgs/String" qos="default" depth="20"/>'
                          '</publish_subscribe>')
    assert config.qos("/scan", True) == QosSpec("sensor_data")
    assert config.qos("/odom", True) == QosSpec(None, "reliable", "transient_local", 5)
    assert config.qos("/tf", True) is None and config.qos("/out", True) is None
    assert config.qos("/out", False) == QosSpec("default", depth=20)
    keep_all = parse_config('<publish_subscribe><subscribe_to name="/a" msg_type="std_msgs/String" '
                            'reliability="reliable" history="keep_all"/></publish_subscribe>')
    assert keep_all.qos("/a", True) == QosSpec(None, "reliable", history="keep_all")
    for bad in ('qos="fast"', 'history="all"', 'history="keep_all" depth="3"', 'reliability="sometimes"',
                'durability="forever"', 'depth="0"', 'depth="-3"', 'depth="1e3"'):
        with pytest.raises(ConfigError, match="is not|not with"):
            parse_config(f'<publish_subscribe><subscribe_to name="/a" msg_type="std_msgs/String" {bad}/>'
                         f'</publish_subscribe>')


@needs_ros2
def test_qos_profiles():
    """The rclpy profiles of pub_sub.xml's QoS, and the defaults (run in .venv-ros2)."""
    script = """
import json
from retalisc.live.config import QosSpec
from retalisc.live.ros2 import qos_profile
def show(p): return [p.reliability.name, p.durability.name, p.history.name, p.depth]
print(json.dumps({
  "input": show(qos_profile(None, "/tf", True)), "output": show(qos_profile(None, "/pos", False)),
  "static_in": show(qos_profile(None, "/tf_static", True)), "static_out": show(qos_profile(None, "/tf_static", False)),
  "sensor": show(qos_profile(QosSpec("sensor_data"), "/scan", True)),
  "sensor_reliable": show(qos_profile(QosSpec("sensor_data", "reliable", depth=3), "/scan", True)),
  "parameters": show(qos_profile(QosSpec("parameters"), "/p", False)),
  "services": show(qos_profile(QosSpec("services_default"), "/p", False)),
  "durable": show(qos_profile(QosSpec(None, None, "transient_local"), "/map", False)),
  "keep_all": show(qos_profile(QosSpec(None, "reliable", history="keep_all"), "/tf", True))}))
"""
    shown = json.loads(subprocess.run([str(ROS2_PYTHON), "-c", script], env=retalisc_env(), capture_output=True,
                                      text=True, check=True, timeout=60).stdout)
    assert shown["input"] == ["BEST_EFFORT", "VOLATILE", "KEEP_LAST", 1000]
    assert shown["output"] == ["RELIABLE", "VOLATILE", "KEEP_LAST", 1000]
    assert shown["static_in"] == shown["static_out"] == ["RELIABLE", "TRANSIENT_LOCAL", "KEEP_LAST", 100]
    assert shown["sensor"] == ["BEST_EFFORT", "VOLATILE", "KEEP_LAST", 5]
    assert shown["sensor_reliable"] == ["RELIABLE", "VOLATILE", "KEEP_LAST", 3]
    assert shown["parameters"] == ["RELIABLE", "VOLATILE", "KEEP_LAST", 1000]
    assert shown["services"] == ["RELIABLE", "VOLATILE", "KEEP_LAST", 10]
    assert shown["durable"] == ["RELIABLE", "TRANSIENT_LOCAL", "KEEP_LAST", 1000]
    assert shown["keep_all"][:3] == ["RELIABLE", "VOLATILE", "KEEP_ALL"]


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """Run the client and the node once: (the client's JSON, the node's stderr, its output
    lines, its exit status, the file the unsafe queries tried to make)."""
    if not ROS2_PYTHON.exists():
        pytest.skip("no .venv-ros2 (bash setup.sh makes it)")
    folder = tmp_path_factory.mktemp("ros2")
    domain = RosDomain()
    env = retalisc_env({"ROS_DOMAIN_ID": str(domain.id)})
    for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "ROS_LOCALHOST_ONLY", "RMW_IMPLEMENTATION",
                "FASTRTPS_DEFAULT_PROFILES_FILE"):
        env.pop(key, None)         # stock discovery settings on both sides
    processes = Processes(folder)
    forbidden = folder / "must_not_exist"
    out = folder / "out.jsonl"
    parameters = folder / "params.yaml"      # as a launch file passes them (launch_ros writes such a file)
    parameters.write_text("/**:\n  ros__parameters:\n    use_sim_time: true\n")
    try:
        client = processes.start("client", [str(ROS2_PYTHON), str(ROOT / "tests" / "ros2_client.py"), "iec1",
                                            str(forbidden)], env)
        processes.wait_for_line(client, "static published", 30)
        # started from this Python (no rclpy): `retalisc ros2` hands over to .venv-ros2's
        node = processes.start("node", retalisc_argv(this_python, "ros2", str(LIVE / "ros2_node.rtl"), "--config",
                                                     str(LIVE / "ros2_node.xml"), "--out", str(out), "--ros-args", "-r",
                                                     "__node:=iec1", "--params-file", str(parameters)), env)
        try:
            client.wait(90)
        except subprocess.TimeoutExpired:
            pass
        alive = node.poll() is None
        status = processes.stop(node)
    finally:
        processes.stop_all()
        domain.release()
    err = processes.err("node")
    assert alive, err
    assert client.returncode == 0, processes.err("client") + err
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    return json.loads(processes.out("client")), err, lines, status, forbidden


def test_ros2_node_in_the_graph(session):
    r, err, _, status, _ = session
    assert r["node_found"] and "ros2: node /iec1 in domain" in err and status == 0
    services = dict((name, types[0]) for name, types in r["services"])
    for name, (type_name, _) in SERVICES.items():
        assert services[f"/iec1/{name}"] == f"retalis_interfaces/srv/{type_name}"
    assert services["/iec1/get_parameters"] == "rcl_interfaces/srv/GetParameters"
    assert {"/pos", "/pos/seq"} <= set(r["publishers"])
    assert {"/tf", "/tf_static", "/sensor", "/sensor_reliable", "/clock"} <= set(r["subscriptions"])


def test_ros2_parameters(session):
    r = session[0]
    assert r["parameters"] == {"program": str(LIVE / "ros2_node.rtl"), "config": str(LIVE / "ros2_node.xml"),
                               "name": "iec1", "max_delay": "", "state_dir": "", "use_sim_time": True}
    assert r["set_program"][0] is False and "read-only" in r["set_program"][1]


def test_ros2_topics_both_ways(session):
    r, err, lines, _, _ = session
    # /tf_static was published (transient local) before the node started: it came, stamp 50
    # (in any order with /tf's: the two readers are not ordered with each other)
    assert [line["start"] for line in lines if line["event"] == "geometry_msgs__0__Vector3(-5.0,0.0,0.0)"] == [50]
    assert r["static_pub_matched"] == 1
    # the program's subscription on /pos, each message with its output number on /pos/seq
    assert r["pos"][-5:] == [1.0, 2.0, 3.0, 4.0, 5.0]
    pos_lines = [i + 1 for i, line in enumerate(lines) if line.get("consumer") == "pos"]
    # (a contiguous run: the first may come before the client's /pos/seq reader matched the
    # node's writer, the client copied them while more came)
    first = pos_lines.index(r["pos_seq"][0])
    assert r["pos_seq"] == pos_lines[first:first + len(r["pos_seq"])] and len(r["pos_seq"]) >= 5
    assert [lines[n - 1]["event"] for n in r["pos_seq"][-5:]] == [
        f"geometry_msgs__0__Vector3({x}.0,0.0,0.0)" for x in range(1, 6)]
    assert [line["start"] for line in lines if line.get("consumer") == "robot_pos"] == list(range(101, 109))
    # /tf: the 9 messages after both ways matched, and those the client sent until then (1 or more)
    tf_in = re.search(r"/tf ([\d,]+)[;,]", err)
    assert "0 rejected, 0 errors" in err and tf_in and int(tf_in[1]) >= 10 and "/tf_other 1" in err, err


def test_ros2_services(session):
    r, _, _, _, forbidden = session
    assert r["subscribe"][:2] == [True, ""] and r["subscribe"][2]
    assert r["bad_subscribe"][0] is False and "unsafe" in r["bad_subscribe"][1]
    assert r["bad_type"] == [False, "unknown message type no_such_pkg/Thing"]
    assert r["robot_pos"] == [1.0, 2.0, 3.0, 4.0, 5.0]
    ok, answers = r["query_all"]
    assert ok and answers[0] == {"P": "odom", "C": "camera", "V": "geometry_msgs__0__Vector3(-5.0,0.0,0.0)"}
    assert [a["V"] for a in answers][-5:] == [f"geometry_msgs__0__Vector3({i}.0,0.0,0.0)" for i in range(1, 6)]
    assert r["query_one"][:2] == [True, True] and r["query_one"][2]["T"] == "50"
    assert r["query_none"] == [True, False]
    assert r["unsafe"][0] is False and r["unsafe"][1].startswith("unsafe:") and "shell/1" in r["unsafe"][1]
    assert r["unsafe_one"][0] is False and "open/3" in r["unsafe_one"][1]
    assert not forbidden.exists()
    assert r["syntax"][0] is False and r["syntax"][1].startswith("syntax:")
    assert r["add_memory"] == [True, ""] and r["last2"] == [7.0, 8.0]
    assert r["add_memory_unsafe"][0] is False and "unsafe" in r["add_memory_unsafe"][1]
    assert r["add_memory_not_create"][0] is False
    assert r["delete_memory"] == [True, ""] and r["delete_memory_bad"][0] is False and r["after_delete_memory"] == 0
    assert r["unsubscribe"] == [True, ""]
    assert r["robot_pos_after_unsubscribe"] == [float(i) for i in range(1, 9)]     # not the 99.0 at 300
    assert r["delete_input"] == [True, ""] and r["delete_input_again"] == [False, "not subscribed to /tf"]
    before, after = r["count_after_delete_input"]
    assert after == before and r["count_after_add_input"] == before + 1
    assert r["add_input"] == [True, ""] and r["add_input_bad_type"][0] is False
    # a type whose generated code is absent: an error naming the package, the node stays up
    assert r["add_input_missing_package"][0] is False and "no_such_pkg" in r["add_input_missing_package"][1]
    # a type rosbags does not ship, read with the definition of its installed .msg file
    assert r["add_input_ar_pose"] == [True, ""] and r["markers"]
    assert all(marker == {"Id": "7", "X": "0.25"} for marker in r["markers"])


def test_ros2_qos_and_clock(session):
    r, err = session[0], session[1]
    # best-effort (sensor data) and reliable publishers both reach the default (best-effort)
    # reader; header-less, they are stamped with /clock's time (use_sim_time)
    assert r["xs"] == [{"X": "1.5", "T": "5000.0"}, {"X": "2.5", "T": "5000.0"}]
    # a reliable reader (pub_sub.xml reliability="reliable") does not match a best-effort
    # publisher, and the node says so (its readers' QoS events are the executor's)
    assert r["refused_pub_matched"] == 0
    assert "/sensor_reliable', offering incompatible QoS" in err, err


def test_ros2_burst_of_5000_nothing_lost(session):
    """5,000 tf messages published at once on a reliable keep-all input come back, in order."""
    r, err = session[0], session[1]
    assert r["burst_subscribe"][0] is True
    assert r["burst_received"] == 5000, (r["burst_seconds"], err[-2000:])
    assert r["burst_in_order"]
    assert "/tf_burst 5,000" in err


def test_ros2_without_rclpy_is_a_clear_error(tmp_path):
    """Where neither this Python nor the hand-over Python has rclpy: one line, exit 2."""
    pytest.importorskip("rosbags")
    try:
        import rclpy  # noqa: F401
        pytest.skip("this Python has rclpy")
    except ImportError:
        pass
    done = subprocess.run(retalisc_argv(this_python, "ros2", str(LIVE / "ros2_node.rtl"), "--duration", "1"),
                          env=retalisc_env({"RETALISC_ROS2_PYTHON": str(tmp_path / "no-python")}),
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "needs ROS 2's rclpy" in done.stderr and "Traceback" not in done.stderr


@needs_ros2
def test_ros2_node_killed_and_restarted_with_state(tmp_path):
    """--state over ROS 2: a node killed (SIGKILL) after five messages and started again with
    the same state directory replays them from its journal and ends with the output file of a
    node that never stopped."""
    domain = RosDomain()
    env = retalisc_env({"ROS_DOMAIN_ID": str(domain.id)})
    processes = Processes(tmp_path)
    out, state = tmp_path / "out.jsonl", tmp_path / "state"
    argv = retalisc_argv(str(ROS2_PYTHON), "ros2", str(LIVE / "ros2_node.rtl"), "--config", str(LIVE / "ros2_node.xml"),
                         "--out", str(out), "--state", str(state), "--snapshot-every", "1000")

    def outputs():
        return [json.loads(line)["event"] for line in out.read_text().splitlines()] if out.exists() else []

    def start_and_publish(name, first, last):
        """Start a node, publish tf x = first..last-1 to it, wait for its outputs."""
        node = processes.start(name, argv, env)
        processes.wait_for_line(node, "ros2: node /retalis")
        done = subprocess.run([str(ROS2_PYTHON), str(ROOT / "tests" / "ros2_client.py"), "--tf", str(first), str(last)],
                              env=env, capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        deadline = time.monotonic() + 20
        while len(outputs()) < last and time.monotonic() < deadline:
            time.sleep(0.05)
        return node

    try:
        node = start_and_publish("first", 0, 5)
        os.kill(node.pid, signal.SIGKILL)
        node.wait(10)
        status = processes.stop(start_and_publish("again", 5, 10))
    finally:
        processes.stop_all()
        domain.release()
    assert status == 0, processes.err("again")
    assert outputs() == [f"geometry_msgs__0__Vector3({x}.0,0.0,0.0)" for x in range(10)], processes.err("again")
    # no snapshot since the start: the restart replayed the five messages from the journal
    assert "replayed 5 journaled events" in processes.err("again")


def test_nao_ros2_program_is_nao_rtl_with_ros2_headers(tmp_path):
    """examples/nao/nao_ros2.rtl over a ROS 1 recording: every output line of nao.rtl (poses,
    deliveries, the situations), the poses with ROS 2's header (no seq)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("nao_make_bag", ROOT / "examples" / "nao" / "make_bag.py")
    make_bag = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_bag)
    bag, _ = make_bag.write(tmp_path / "nao.bag", seconds=4.0, seed=5)

    def outputs(name):
        run = subprocess.run(retalisc_argv(this_python, "run", str(ROOT / "examples" / "nao" / name), "--bag", str(bag)),
                             env=retalisc_env(), capture_output=True, text=True, timeout=120)
        assert run.returncode == 0, run.stderr
        return [json.loads(line) for line in run.stdout.splitlines()]

    mine, original = outputs("nao_ros2.rtl"), outputs("nao.rtl")
    without_seq = re.compile(r"std_msgs__0__Header\(\d+,")
    for line in original:
        line["event"] = without_seq.sub("std_msgs__0__Header(", line["event"])
    assert sum(1 for line in mine if line.get("consumer", "").startswith("marker")) >= 15
    assert any(line["event"].startswith("person_moved_object(") for line in mine)
    assert mine == original


@needs_ros2
def test_ros2_nao_application_live_against_the_ground_truth(tmp_path):
    """The reference application as a live ROS 2 node: examples/nao/nao_ros2.rtl (nao.rtl in the
    form that reads ROS 2 headers, docs/ros.md) with examples/nao/pub_sub.xml, its QoS the
    defaults; a 4-second recording of examples/nao/make_bag.py played in real time by an
    independent rclpy process as ROS 2 messages (tf2_msgs/TFMessage, ar_pose/ARMarkers, stamps
    moved to now). The world pose of every detection comes on /markerK exactly once, within
    1 mm and 0.1 degree of the ground truth, each with its output number on /markerK/seq (the
    line of its delivery in the node's output file), as on ROS 1 (tests/test_live_ros1.py)."""
    import importlib.util
    import math

    spec = importlib.util.spec_from_file_location("nao_make_bag", ROOT / "examples" / "nao" / "make_bag.py")
    make_bag = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_bag)
    bag, truth_path = make_bag.write(tmp_path / "nao.bag", seconds=4.0, seed=7)
    truth = [json.loads(line) for line in truth_path.read_text().splitlines()]
    assert len(truth) >= 20
    example = ROOT / "examples" / "nao"
    domain = RosDomain()
    env = retalisc_env({"ROS_DOMAIN_ID": str(domain.id)})
    processes = Processes(tmp_path)
    out = tmp_path / "out.jsonl"
    try:
        node = processes.start("nao", retalisc_argv(str(ROS2_PYTHON), "ros2", str(example / "nao_ros2.rtl"), "--config",
                                                    str(example / "pub_sub.xml"), "--out", str(out)), env)
        processes.wait_for_line(node, "ros2: node /retalis")
        topics = ",".join(f"/marker{k}" for k in range(1, 9))
        played = subprocess.run([str(ROS2_PYTHON), str(ROOT / "tests" / "ros2_client.py"), "--bag", str(bag), "1.0",
                                 "/tf,/ar_pose_marker", str(len(truth)), topics], env=env, capture_output=True,
                                text=True, timeout=120)
        status = processes.stop(node)
    finally:
        processes.stop_all()
        domain.release()
    err = processes.err("nao")
    assert played.returncode == 0, played.stderr + err
    r = json.loads(played.stdout.strip().splitlines()[-1])
    assert status == 0, err
    assert " 0 rejected, 0 errors;" in err and "warning: " not in err, err
    summary = [line for line in err.splitlines() if line.startswith("retalis: ")]
    assert summary and " late" not in summary[-1], err
    assert all(frame == "odom" for _, _, _, frame, _, _ in r["received"])   # the frame the pose is in
    keys = [("4x4_" + topic[len("/marker"):], sec, nsec) for topic, sec, nsec, _, _, _ in r["received"]]
    assert len(keys) == len(set(keys)), "a detection was published twice"
    want = {(row["marker"], row["stamp"][0], row["stamp"][1]): row for row in truth}
    assert set(keys) == set(want), (sorted(set(want) - set(keys)), sorted(set(keys) - set(want)))
    worst_position = worst_angle = 0.0
    for topic, sec, nsec, _, position, orientation in r["received"]:
        row = want[("4x4_" + topic[len("/marker"):], sec, nsec)]      # A.6: marker 4x4_K on /markerK
        worst_position = max(worst_position, math.dist(position, row["position"]))
        dot = abs(sum(a * b for a, b in zip(orientation, row["orientation"])))
        worst_angle = max(worst_angle, 2 * math.acos(min(1.0, dot / math.sqrt(sum(a * a for a in orientation)))))
    print(f"live ROS 2: {len(keys)} detections, max position error {worst_position * 1000:.4f} mm, "
          f"max angle error {math.degrees(worst_angle):.5f} deg")
    assert worst_position < 0.001 and worst_angle < math.radians(0.1)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    derived = [line for line in lines if "consumer" not in line and line["event"].startswith("marker_pose(")]
    assert len(derived) == len(truth)
    # the output numbers on /markerK/seq: one per pose, each the line of a delivery to markerK
    for topic in {topic for topic, *_ in r["received"]}:
        numbers = r["numbers"].get(topic, [])
        assert len(numbers) == sum(1 for t, *_ in r["received"] if t == topic)
        assert all(lines[n - 1].get("consumer") == topic[1:] for n in numbers)


@needs_ros2
def test_ros2_heartbeat_on_sim_time_and_linger(tmp_path):
    """--heartbeat and --linger over rclpy, the node's clock /clock (use_sim_time): five
    messages 20 ms apart are fed in one batch half a second after the first (--linger 0.5: every
    delivery after the last message, none earlier than 0.4 s); each arms a timer 2 s of event
    time on, which fires through the heartbeat (an rclpy timer on the node's clock) while no
    message arrives, when /clock passes it, and not while /clock is held before it; the
    alarms at the messages' sim time + 2 s."""
    domain = RosDomain()
    env = retalisc_env({"ROS_DOMAIN_ID": str(domain.id)})
    processes = Processes(tmp_path)
    out = tmp_path / "out.jsonl"
    try:
        node = processes.start("beat", retalisc_argv(str(ROS2_PYTHON), "ros2", str(LIVE / "ros2_heartbeat.rtl"), "--config",
                                                     str(LIVE / "ros2_heartbeat.xml"), "--out", str(out), "--heartbeat",
                                                     "0.1", "--linger", "0.5", "--ros-args", "-p", "use_sim_time:=true"),
                               env)
        processes.wait_for_line(node, "ros2: node /retalis")
        done = subprocess.run([str(ROS2_PYTHON), str(ROOT / "tests" / "ros2_client.py"), "--sim"], env=env,
                              capture_output=True, text=True, timeout=90)
        status = processes.stop(node)
    finally:
        processes.stop_all()
        domain.release()
    err = processes.err("beat")
    assert done.returncode == 0, done.stderr + err
    r = json.loads(done.stdout.strip().splitlines()[-1])
    assert status == 0, err
    assert sorted(x for _, x in r["echo"]) == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert all(at > r["last_sent"] and at > 0.4 for at, _ in r["echo"]), r       # one batch, after the linger
    assert r["quiet_held"] == [], r
    assert sorted(r["quiet"]) == [1.0, 2.0, 3.0, 4.0, 5.0], r
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    alarms = [line for line in lines if line["event"].startswith("silence(") and "consumer" not in line]
    assert len(alarms) == 5 and all(line["start"] == 5000 and line["end"] == 5002 for line in alarms), alarms
