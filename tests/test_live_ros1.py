"""End to end: `retalisc ros` as a ROS 1 node on a real ROS master (Debian's rosmaster on
127.0.0.1 and a free port), a client (tests/ros1_client.py) publishing tf and marker
messages and calling the services of thesis A.1. ROS 1 runs under the Python of .venv-ros,
which `bash setup.sh` makes (docs/ros.md); every process is stopped by its pid at the end."""
from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from live_support import LIVE, ROOT, Processes, free_port, retalisc_argv, retalisc_env, wait_port


def _ros_python() -> str:
    python = os.environ.get("RETALISC_ROS_PYTHON") or str(ROOT / ".venv-ros" / "bin" / "python")
    if not Path(python).exists():
        pytest.skip(f"ROS 1 is not set up ({python} is missing): `bash setup.sh` installs Debian's "
                    f"python3-rospy and makes .venv-ros")
    check = subprocess.run([python, "-c", "import rospy, genpy, rosbags"], capture_output=True, text=True,
                           env=retalisc_env())
    if check.returncode != 0:
        pytest.skip(f"ROS 1 is not importable with {python}: {check.stderr.strip().splitlines()[-1:]}")
    if shutil.which("rosmaster") is None:
        pytest.skip("rosmaster is not installed (Debian: python3-rosmaster; `bash setup.sh`)")
    return python


@pytest.fixture(scope="module")
def ros(tmp_path_factory):
    """A ROS master of this module's own, and the environment that points at it."""
    python = _ros_python()
    directory = tmp_path_factory.mktemp("ros1")
    processes = Processes(directory)
    port = free_port()
    env = retalisc_env({"ROS_MASTER_URI": f"http://127.0.0.1:{port}", "ROS_IP": "127.0.0.1",
                        "ROS_HOSTNAME": "127.0.0.1", "ROS_HOME": str(directory / "home"),
                        "ROS_LOG_DIR": str(directory / "log")})
    try:
        processes.start("rosmaster", [shutil.which("rosmaster"), "--core", "-p", str(port)], env)
        assert wait_port(port), "rosmaster did not start:\n" + processes.err("rosmaster")
        yield python, env, processes
    finally:
        processes.stop_all()


def _client(python, env, *args, timeout=120) -> dict:
    run = subprocess.run([python, str(ROOT / "tests" / "ros1_client.py"), *args], env=env, capture_output=True,
                         text=True, timeout=timeout)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


def test_ros1_node_topics_services_and_load(ros, tmp_path):
    python, env, processes = ros
    out = tmp_path / "out.jsonl"
    node = processes.start("node", retalisc_argv(python, "ros", str(LIVE / "tf_services.rtl"), "--config",
                                                 str(LIVE / "pub_sub.xml"), "--name", "iec1", "--out",
                                                 str(out)), env)
    try:
        processes.wait_for_line(node, "ros: node /iec1")
        forbidden = tmp_path / "must_not_exist"
        r = _client(python, env, "services", "iec1", str(forbidden))
        assert node.poll() is None, processes.err("node")     # still alive after the refusals
    finally:
        status = processes.stop(node)
    err = processes.err("node")
    # the output subscription: V of each tf from odom, published as geometry_msgs/Vector3
    assert r["subscribe"][:2] == [True, ""] and r["subscribe"][2]
    assert r["bad_subscribe"][0] is False and "unsafe" in r["bad_subscribe"][1]
    assert r["delivered"][:5] == [0.0, 1.0, 2.0, 3.0, 4.0]
    # queries: all answers, one answer at a time, none; refusals are error replies
    ok, answers = r["query_all"]
    assert ok and [a["V"] for a in answers] == [f"geometry_msgs__0__Vector3({i}.0,0.0,0.0)" for i in range(5)]
    assert answers[0]["P"] == "odom" and answers[0]["C"] == "base"        # plain strings (docs/robot_io.md)
    assert r["query_one"][:2] == [True, True] and r["query_one"][2]["T"] == "100"
    assert r["query_none"] == [True, False]
    assert r["unsafe"][0] is False and r["unsafe"][1].startswith("unsafe:") and "shell/1" in r["unsafe"][1]
    assert r["unsafe_one"][0] is False and "unsafe" in r["unsafe_one"][1]
    assert not forbidden.exists()
    assert r["syntax"][0] is False and r["syntax"][1].startswith("syntax:")
    # memories: created, bounded to 2 records, refused when unsafe or not a creation, deleted
    assert r["add_memory"] == [True, ""]
    assert r["add_memory_unsafe"][0] is False and "unsafe" in r["add_memory_unsafe"][1]
    assert r["add_memory_not_create"][0] is False
    assert r["last2"] == [6.0, 7.0]
    assert r["delete_memory"] == [True, ""] and r["delete_memory_bad"][0] is False
    assert r["after_delete_memory"] == 0
    # unsubscribed: no delivery after; input subscriptions deleted and added
    assert r["unsubscribe"] == [True, ""]
    assert r["delivered_after_unsubscribe"] == [float(i) for i in range(8)]
    assert r["delete_input"] == [True, ""] and r["delete_input_again"][0] is False
    assert r["count_after_delete_input"] == 10
    assert r["add_input"] == [True, ""] and r["add_input_bad_type"][0] is False
    assert r["count_after_add_input"] == 11
    # 10x the thesis's load: every transform in, every delivery out, in arrival order
    assert r["load_subscribe"] == [True, ""]
    assert r["load_received"] == 3800, err
    assert r["load_in_order"]
    assert r["load_memorized"] == 100
    # the node's own account, and its output file
    assert status == 0, err
    assert "rejected" in err and ", 0 errors;" in err
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert sum(1 for line in lines if line.get("consumer") == "robot_pos") == 8
    assert sum(1 for line in lines if line.get("consumer") == "all_tf") == 3800
    assert "/tf_other 3,801" in err and "/tf 10" in err   # the summary: every message counted


def test_ros1_nao_markers_live_as_replayed(ros, tmp_path):
    """The NAO application live: tf and ar_pose markers (a type the node learns from the
    publisher's connection header) in, the world pose of each marker out on /marker1 and
    /marker2; the same deliveries as feeding the same messages to the program directly.

    The client stamps the recording with the wall clock (a TFMessage, which has no header,
    is stamped with its arrival): the two topics come on two connections, and under load
    their relative order differs from the recorded one, which by arrival-order independence
    changes nothing as long as no event is later than the delay bound; the node's summary
    says so (no `late`). With the sample's old stamps every event was years late, the
    synchronized rule ran at once, and a detection that overtook its next transform got
    another pose (tests/test_nao_markers_order.py)."""
    python, env, processes = ros
    program = ROOT / "examples" / "nao_markers" / "nao_markers.rtl"
    count = len(_nao_markers_replayed(program, None))
    assert count >= 5
    out = tmp_path / "out.jsonl"
    node = processes.start("nao", retalisc_argv(python, "ros", str(program), "--config",
                                                str(program.parent / "pub_sub.xml"), "--out", str(out)), env)
    try:
        processes.wait_for_line(node, "ros: node /retalis")
        r = _client(python, env, "nao", "2.0", str(count))
    finally:
        status = processes.stop(node)
    err = processes.err("nao")
    assert status == 0, err
    summary = [line for line in err.splitlines() if line.startswith("retalis: ")]
    assert summary and " late" not in summary[-1] and "warning: " not in err and ", 0 errors;" in err, err
    expected = _nao_markers_replayed(program, r["start_s"])
    assert len(expected) == count
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert sorted((line["consumer"], line["event"]) for line in lines if "consumer" in line) == sorted(expected)
    # the messages, their header.seq aside, are the deliveries; header.seq is the output's line
    from retalisc.robot_io.messages import MessageConverter
    from retalisc.robot_io.samples import sample_store

    converter = MessageConverter(sample_store(1))
    published = sorted([topic, _without_seq(term)] for topic, term in r["received"])
    want = []
    for consumer, event in expected:
        name, message = converter.message(event)
        want.append(["/" + consumer, _without_seq(converter.term(message, name))])
    assert published == sorted(want)
    for topic, term in r["received"]:
        line = lines[_seq(term) - 1]
        name, message = converter.message(line["event"])
        assert line["consumer"] == topic[1:] and _without_seq(converter.term(message, name)) == _without_seq(term)


def _nao_markers_replayed(program: Path, start_s) -> list:
    """(consumer, event) of the deliveries of feeding 2 s of the sample NAO recording (tf and
    markers, first stamp at `start_s`, None: the sample's own) to the program in record order,
    a message without a header stamped with its record time (as the node stamps it with its
    arrival)."""
    from retalisc.driver.engine import Engine
    from retalisc.robot_io.messages import MessageConverter
    from retalisc.robot_io.samples import nao_records, sample_store

    store = sample_store(1)
    converter = MessageConverter(store)
    engine = Engine.load(program)
    when = {} if start_s is None else {"start_s": start_s}
    delivered = []
    for topic, msgtype, record_ns, msg in nao_records(store, seconds=2.0, **when):
        if topic in ("/tf", "/ar_pose_marker"):
            text, seconds = converter.event(msg, msgtype, topic, record_ns)
            delivered += [(e.consumer, e.event) for e in engine.feed(text, seconds) if e.consumer]
    return delivered


_HEADER_SEQ = re.compile(r"^(\w+\(std_msgs__0__Header\()(\d+),")


def _seq(term: str) -> int:
    """header.seq of a message written as a term."""
    return int(_HEADER_SEQ.match(term).group(2))


def _without_seq(term: str) -> str:
    return _HEADER_SEQ.sub(r"\g<1>0,", term)


def test_ros1_nao_application_live_against_the_ground_truth(ros, tmp_path):
    """The reference application (examples/nao/nao.rtl) as a live ROS 1 node: a 4-second
    recording of examples/nao/make_bag.py played into the master in real time (tf and the
    ar_pose markers, stamped as a robot would stamp them now, each message of the type definition
    the bag holds); the world
    pose of every detection comes on /markerK exactly once, within 1 mm and 0.1 degree of the
    ground truth, as `retalisc run --bag` gives it (tests/test_nao_application.py)."""
    import importlib.util
    import math

    spec = importlib.util.spec_from_file_location("nao_make_bag", ROOT / "examples" / "nao" / "make_bag.py")
    make_bag = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_bag)
    python, env, processes = ros
    bag, truth_path = make_bag.write(tmp_path / "nao.bag", seconds=4.0, seed=7)
    truth = [json.loads(line) for line in truth_path.read_text().splitlines()]
    assert len(truth) >= 20
    example = ROOT / "examples" / "nao"
    out = tmp_path / "out.jsonl"
    node = processes.start("nao_live", retalisc_argv(python, "ros", str(example / "nao.rtl"), "--config",
                                                     str(example / "pub_sub.xml"), "--out", str(out)), env)
    try:
        processes.wait_for_line(node, "ros: node /retalis")
        r = _client(python, env, "bag", str(bag), "1.0", "/tf,/ar_pose_marker", str(len(truth)),
                    ",".join(f"/marker{k}" for k in range(1, 9)))
    finally:
        status = processes.stop(node)
    err = processes.err("nao_live")
    assert status == 0, err
    assert "ros: node /retalis" in err and " 0 rejected, 0 errors;" in err, err
    # A.6: marker 4x4_K on /markerK, its pose in odom, the frame it is expressed in
    assert all(frame == "odom" for *_, frame, _, _ in r["received"]), r["received"][:2]
    keys = [("4x4_" + topic[len("/marker"):], sec, nsec) for topic, _, sec, nsec, _, _, _ in r["received"]]
    assert len(keys) == len(set(keys)), "a detection was published twice"
    want = {(row["marker"], row["stamp"][0], row["stamp"][1]): row for row in truth}
    assert len(want) == len(truth)
    assert set(keys) == set(want), (sorted(set(want) - set(keys)), sorted(set(keys) - set(want)))
    worst_position = worst_angle = 0.0
    for (topic, seq, sec, nsec, frame, position, orientation), key in zip(r["received"], keys):
        row = want[key]
        worst_position = max(worst_position, math.dist(position, row["position"]))
        dot = abs(sum(a * b for a, b in zip(orientation, row["orientation"])))
        worst_angle = max(worst_angle, 2 * math.acos(min(1.0, dot / math.sqrt(sum(a * a for a in orientation)))))
    print(f"live: {len(keys)} detections, max position error {worst_position * 1000:.4f} mm, "
          f"max angle error {math.degrees(worst_angle):.5f} deg")
    assert worst_position < 0.001 and worst_angle < math.radians(0.1)
    # the node's own output file holds the same poses, each once
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    derived = [line for line in lines if "consumer" not in line and line["event"].startswith("marker_pose(")]
    assert len(derived) == len(truth)
    # header.seq of each published pose is the line of its delivery in the output file
    assert all(lines[seq - 1].get("consumer") == topic[1:] for topic, seq, *_ in r["received"])
    assert len({seq for _, seq, *_ in r["received"]}) == len(r["received"])


def test_ros1_two_iecs_from_one_launch_file(ros, tmp_path):
    """ros/retalis/launch/two_iecs.launch: roslaunch starts two components; the second
    consumes what the first derives. roslaunch is stopped by its pid (SIGINT, as on a
    terminal), which stops the nodes it started."""
    python, env, processes = ros
    if shutil.which("roslaunch") is None:
        pytest.skip("roslaunch is not installed (Debian: python3-roslaunch; `bash setup.sh`)")
    env = dict(env, ROS_PACKAGE_PATH=str(ROOT / "ros"), RETALISC_ROS_PYTHON=python)
    launch = processes.start("roslaunch", [shutil.which("roslaunch"), "retalis", "two_iecs.launch"], env)
    try:
        r = _client(python, env, "chain", "iec1", "iec2")
    finally:
        launch.send_signal(signal.SIGINT)
        try:
            launch.wait(20)
        except subprocess.TimeoutExpired:
            processes.stop(launch)
    out = processes.out("roslaunch")
    pids = [int(pid) for pid in re.findall(r"process\[iec\d-\d\]: started with pid \[(\d+)\]", out)]
    alive = [pid for pid in pids if _alive(pid)]
    for pid in alive:                       # (only if roslaunch left them: fail, but clean up)
        os.kill(pid, signal.SIGKILL)
    assert r["positions"] == [1.0, 2.0, 3.0, 4.0, 5.0], out
    assert len(pids) == 2 and not alive, out
    assert "ros: node /iec1" in processes.err("roslaunch") and "ros: node /iec2" in processes.err("roslaunch")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


NUMBERED_XS = [1.0, 5.0, 2.0, 7.0, 3.0, 0.5, 9.0, 4.0, 6.0, 8.0, 2.5, 10.0, 1.5, 11.0]   # as ros1_client.py


def _numbered_reference():
    """(output file, [[topic, number, x, y]] of the published messages) of numbered.rtl over
    the events of ros1_client.py's `numbered` scenario, without a middleware and without a
    stop: the same LiveNode code over an in-process transport."""
    import io

    from retalisc.driver.engine import Engine
    from retalisc.live.config import load_config
    from retalisc.live.node import LiveNode, Reply, Transport
    from retalisc.robot_io.bags import typestore

    store = typestore("ros1_noetic")
    types = store.types

    class Recorder(Transport):
        wire, name = "ros1", "recorder"

        def __init__(self):
            self.published = []

        def start(self, node):
            pass

        def subscribe(self, topic, msgtype):
            pass

        def publish(self, topic, msgtype, data):
            self.published.append((topic, data))

    out, transport = io.StringIO(), Recorder()
    node = LiveNode(Engine.load(LIVE / "numbered.rtl"), transport, load_config(LIVE / "numbered.xml"), out=out,
                    log=lambda text: None)
    node.start()
    for i, x in enumerate(NUMBERED_XS):
        header = types["std_msgs/msg/Header"](seq=i + 1, stamp=types["builtin_interfaces/msg/Time"](sec=100 + i, nanosec=0),
                                              frame_id="f")
        msg = types["geometry_msgs/msg/PointStamped"](header=header, point=types["geometry_msgs/msg/Point"](x=x, y=0.0, z=0.0))
        node.arrived("/p", bytes(store.serialize_ros1(msg, "geometry_msgs/msg/PointStamped")))
    node.call(lambda: Reply(True))
    node.close()
    messages, number = [], None
    for topic, data in transport.published:
        if topic == "/vec/seq":
            number = store.deserialize_ros1(data, "std_msgs/msg/UInt64").data
        elif topic == "/vec":
            point = store.deserialize_ros1(data, "geometry_msgs/msg/Point")
            messages.append(["/vec", number, point.x, point.y])
        else:
            stamped = store.deserialize_ros1(data, "geometry_msgs/msg/PointStamped")
            messages.append(["/stamped", stamped.header.seq, stamped.point.x, stamped.point.y])
    return out.getvalue(), messages


def test_ros1_node_killed_and_restarted_subscriber_drops_repeats_by_number(ros, tmp_path):
    """`retalisc ros --state DIR` killed with SIGKILL after 9 of 14 events and started again
    with the same DIR, while a subscriber stays up: dropping the messages whose output number
    (header.seq of /stamped; the number on /vec/seq of /vec) it has already seen, the
    subscriber gets exactly the messages of a node that never stopped, and some were repeats;
    the --out file is that of an uninterrupted node."""
    python, env, processes = ros
    expected_out, expected = _numbered_reference()
    ends = [json.loads(line)["end"] for line in expected_out.splitlines()]
    assert {m[0] for m in expected} == {"/stamped", "/vec"} and len(expected) >= 10
    out, state = tmp_path / "out.jsonl", tmp_path / "state"
    argv = retalisc_argv(python, "ros", str(LIVE / "numbered.rtl"), "--config", str(LIVE / "numbered.xml"), "--name",
                         "numbered", "--out", str(out), "--state", str(state), "--snapshot-every", "4",
                         "--snapshot-seconds", "inf")
    first = processes.start("numbered_first", argv, env)
    client = subprocess.Popen([python, str(ROOT / "tests" / "ros1_client.py"), "numbered"], env=env,
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                              start_new_session=True)

    def ask(command: str) -> dict:
        client.stdin.write(command + "\n")
        client.stdin.flush()
        reply = client.stdout.readline()
        assert reply, f"the client stopped at {command!r}"
        return json.loads(reply)

    second = None
    try:
        processes.wait_for_line(first, "ros: node /numbered")
        assert ask("wait")["ready"]
        ask("send 0 9")
        # the messages of the first 9 events (stamped 100 to 108): their numbers are their lines
        of_nine = [m for m in expected if ends[m[1] - 1] < 109]
        assert 0 < len(of_nine) < len(expected)
        assert ask(f"expect {len(of_nine)}")["came"], processes.err("numbered_first")
        os.kill(first.pid, signal.SIGKILL)
        first.wait()
        second = processes.start("numbered_second", argv, env)
        processes.wait_for_line(second, "ros: node /numbered")
        assert ask("wait")["ready"]
        ask("send 9 14")
        assert ask(f"expect {len(expected)}")["came"], processes.err("numbered_second")
        time.sleep(0.3)                   # a late repeat would show now
        report = ask("report")
    finally:
        if client.poll() is None:
            os.kill(client.pid, signal.SIGTERM)
            client.wait(10)
        status = processes.stop(second) if second is not None else None
    err = processes.err("numbered_second")
    assert status == 0, err
    assert "restored snapshot" in err and "produced (and published) again" in err, err
    for topic in ("/stamped", "/vec"):        # each topic in order (the two come on two connections)
        assert [m for m in report["kept"] if m[0] == topic] == [m for m in expected if m[0] == topic], report
    print(f"{len(report['arrived'])} messages came, {report['repeats']} of them repeats")
    assert report["repeats"] > 0 and report["unpaired"] == [0, 0], report
    # the repeats are outputs the restart says it produced again (those after the snapshot)
    low, high = map(int, re.search(r"outputs (\d+) to (\d+) of the run were produced", err).groups())
    seen = set()
    for topic, number, _, _ in report["arrived"]:
        assert (topic, number) not in seen or low <= number <= high, (topic, number, low, high)
        seen.add((topic, number))
    assert out.read_text() == expected_out
