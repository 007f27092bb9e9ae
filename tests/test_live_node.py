"""LiveNode without a middleware (a transport in memory): the pub_sub.xml of Listing 2.2,
feeding from many threads in arrival order, deliveries published as messages, the services
of thesis A.1 with their refusals, and bytes that are not a message."""
from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest

pytest.importorskip("rosbags", reason="the live tests need rosbags")

from hypothesis import given, settings, strategies as st  # noqa: E402

from live_support import retalisc_env  # noqa: E402
from retalisc.driver.engine import Engine  # noqa: E402
from retalisc.live.config import ConfigError, parse_config, ros1_type  # noqa: E402
from retalisc.live.node import LiveNode, Transport  # noqa: E402
from retalisc.robot_io.bags import typestore  # noqa: E402

LISTING_2_2 = """<?XML version="1.0"?>
  <publish_subscribe>
     <subscribe_to       name="/ar_pose_marker"
                         msg_type=" ar_pose / ARMarkers"
     >
     </subscribe_to>
     <publish_to         name="robot_marker_pos"
                          msg_type="geometry_msgs/Transform"
     />
     <publish_to         name="gazeControl"
                         msg_type="headTurn/GazeControl"
     />
  </publish_subscribe>
"""

PROGRAM = """
pos(X) <- geometry_msgs__0__Vector3(X, _, _).
memorize(geometry_msgs__0__Vector3(X, Y, Z), [], p(X, Y, Z), points, 1000).
"""


class MemoryTransport(Transport):
    wire = "cdr"
    name = "memory"

    def __init__(self):
        self.subscribed, self.published, self.advertised = {}, [], []

    def start(self, node):
        self.node = node

    def subscribe(self, topic, msgtype):
        self.subscribed[topic] = msgtype

    def unsubscribe(self, topic):
        return self.subscribed.pop(topic, None) is not None

    def advertise(self, topic, msgtype):
        self.advertised.append((topic, msgtype))

    def publish(self, topic, msgtype, data):
        self.published.append((topic, msgtype, data))


STORE = typestore("ros2_humble")


def vector(x: float) -> bytes:
    msg = STORE.types["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=0.0)
    return bytes(STORE.serialize_cdr(msg, "geometry_msgs/msg/Vector3"))


def make_node(program: str = PROGRAM, config: str = None):
    engine = Engine.from_source(program, "live.rtl")
    transport = MemoryTransport()
    node = LiveNode(engine, transport, parse_config(config) if config else None, log=lambda text: None)
    node.start()
    return node, transport


def test_listing_2_2_as_printed():
    config = parse_config(LISTING_2_2)
    assert [(s.name, s.msgtype) for s in config.subscribe] == [("/ar_pose_marker", "ar_pose/ARMarkers")]
    assert [(s.name, s.msgtype) for s in config.publish] == [("/robot_marker_pos", "geometry_msgs/Transform"),
                                                            ("/gazeControl", "headTurn/GazeControl")]
    assert ros1_type("tf2_msgs/msg/TFMessage") == "tf2_msgs/TFMessage"


@pytest.mark.parametrize("text, message", [
    ("<publish_subscribe><subscribe_to name='/a'/></publish_subscribe>", "needs the attributes"),
    ("<publish_subscribe><subscribe_to name='/a' msg_type='no type'/></publish_subscribe>", "not a message type"),
    ("<topics/>", "expected <publish_subscribe>"),
    ("<publish_subscribe><listen name='/a' msg_type='a/B'/></publish_subscribe>", "unknown element <listen>"),
    ("<publish_subscribe>\n<subscribe_to name='/a'", "pub_sub.xml:2:"),
    ('<!DOCTYPE x [<!ENTITY a "aaaa">]><publish_subscribe/>', "document type declaration"),
])
def test_bad_configurations(text, message):
    with pytest.raises(ConfigError, match=message.replace("(", r"\(")):
        parse_config(text)


def test_a_bad_configuration_is_a_usage_error(tmp_path):
    config = tmp_path / "bad.xml"
    config.write_text("<publish_subscribe><subscribe_to name='/a'/></publish_subscribe>")
    program = tmp_path / "p.rtl"
    program.write_text(PROGRAM)
    run = subprocess.run([sys.executable, "-m", "retalisc", "zenoh", str(program), "--config", str(config),
                          "--listen", "tcp/127.0.0.1:1"], capture_output=True, text=True, env=retalisc_env())
    assert run.returncode == 2 and "needs the attributes name and msg_type" in run.stderr
    assert "Traceback" not in run.stderr


@settings(max_examples=5, deadline=None)
@given(st.lists(st.lists(st.integers(-1000, 1000), min_size=1, max_size=30), min_size=2, max_size=4))
def test_arrival_order_from_many_threads(chunks):
    """Callbacks on several threads: the engine sees the messages in the order they arrived
    (the order of the `arrived` calls), nothing lost."""
    node, transport = make_node(config="<publish_subscribe><subscribe_to name='/v' "
                                       "msg_type='geometry_msgs/Vector3'/></publish_subscribe>")
    order, lock = [], threading.Lock()
    seen = []
    node._deliveries.append(lambda event: seen.append(event.event))

    def produce(values):
        for value in values:
            with lock:                     # the arrival order is the order of these calls
                order.append(value)
                node.arrived("/v", vector(float(value)))

    threads = [threading.Thread(target=produce, args=(chunk,)) for chunk in chunks]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    node.close()
    assert [e for e in seen if e.startswith("pos(")] == [f"pos({float(v)!r})" for v in order]


def test_services_and_refusals():
    node, transport = make_node(config="<publish_subscribe><subscribe_to name='/v' msg_type='geometry_msgs/Vector3'/>"
                                       "<publish_to name='out' msg_type='geometry_msgs/Point'/></publish_subscribe>")
    assert transport.subscribed == {"/v": "geometry_msgs/Vector3"}
    assert ("/out", "geometry_msgs/Point") in transport.advertised
    assert ("/out/seq", "std_msgs/UInt64") in transport.advertised       # the output numbers' topic
    outputs = []
    node._deliveries.append(outputs.append)
    reply = node.add_output_subscription("out", "", "pos(X)", "[X > 1]", "geometry_msgs__0__Point(X, 0.0, 0.0)")
    assert reply.ok and reply.value
    for x in (0.5, 2.0, 3.0):
        node.arrived("/v", vector(x))
    everything = node.query("mem(points, p(X, _, _))", "", all_answers=True)
    assert [a["X"] for a in everything.value] == ["0.5", "2.0", "3.0"]
    one = node.query("mem(points, p(X, _, _)^T)", "", all_answers=False)
    assert one.ok and one.value["X"] == "0.5"
    unsafe = node.query("shell(ls)", "")
    assert not unsafe.ok and unsafe.error.startswith("unsafe:")
    assert not node.query("p(", "").ok
    assert not node.add_output_subscription("out", "", "pos(X)", "[shell(ls)]").ok
    assert not node.add_output_subscription("", "", "pos(X)").ok
    assert not node.add_output_subscription("o2", "nope/Nothing", "pos(X)").ok
    assert not node.add_output_subscription("o2", "", "pos(X)", start="yesterday").ok
    assert not node.add_memory("d_mem(points)").ok
    assert not node.add_memory("c_mem(m, p(X)-[shell(ls)], 1, inf)").ok
    assert node.add_memory("c_mem(m2, geometry_msgs__0__Vector3(X, _, _)-[X > 2], 5, inf)").ok
    node.arrived("/v", vector(4.0))
    assert [a["X"] for a in node.query("mem(m2, geometry_msgs__0__Vector3(X, _, _))", "", True).value] == ["4.0"]
    assert node.delete_memory("m2").ok and not node.delete_memory("m2), halt, (x").ok
    gone = node.query("mem(m2, geometry_msgs__0__Vector3(X, _, _))", "", True)      # deleted: an error naming it
    assert not gone.ok and "no memory instance m2" in gone.error
    assert node.delete_output_subscription(reply.value).ok
    assert not node.add_input_subscription("/v", "geometry_msgs/Point").ok      # already, as another type
    assert node.delete_input_subscription("/v").ok and not node.delete_input_subscription("/v").ok
    assert node.add_input_subscription("w", "geometry_msgs/Vector3").ok and "/w" in transport.subscribed
    node.arrived("/w", b"\x00\x01\x00\x00garbage")       # not a Vector3: rejected, the node goes on
    node.arrived("/w", vector(5.0))
    node.close()
    published = [(topic, msgtype) for topic, msgtype, _ in transport.published]
    assert published == [("/out/seq", "std_msgs/UInt64"), ("/out", "geometry_msgs/Point")] * 3
    points = [STORE.deserialize_cdr(data, "geometry_msgs/msg/Point").x for _, _, data in transport.published[1::2]]
    assert points == [2.0, 3.0, 4.0]
    # each message comes right after its output number: its line in all the node's outputs
    numbers = [STORE.deserialize_cdr(data, "std_msgs/msg/UInt64").data for _, _, data in transport.published[::2]]
    assert numbers == [i + 1 for i, output in enumerate(outputs) if output.consumer == "out"] and len(outputs) > 3
    assert node.stats.rejected["/w"] == 1 and node.stats.received["/w"] == 2
    assert node.stats.errors == 0


def test_the_summary_counts_the_service_calls_clients_made():
    """The node's own set-up (subscribing to the configured topics, advertising the outputs)
    is not a service call; a transport without services (ROS 2 over DDS, Zenoh) shows none."""
    node, _ = make_node(config="<publish_subscribe><subscribe_to name='/v' msg_type='geometry_msgs/Vector3'/>"
                               "<publish_to name='out' msg_type='geometry_msgs/Point'/></publish_subscribe>")
    try:
        assert node.stats.calls == 0
        node.query("true", "")
        assert not node.delete_input_subscription("/nothing").ok          # a refused request is a call too
        assert node.stats.calls == 2
        assert node.stats.summary("ros").endswith("; 2 service calls")
        assert "service" not in node.stats.summary("ros2", services=False)
    finally:
        node.close()


def test_an_event_that_raises_does_not_stop_the_batch():
    program = "bad(X) <- geometry_msgs__0__Vector3(X, _, _) where X > 1, atom_length(f(X), _).\n" \
              "pos(X) <- geometry_msgs__0__Vector3(X, _, _).\n"
    node, _ = make_node(program, "<publish_subscribe><subscribe_to name='/v' msg_type='geometry_msgs/Vector3'/>"
                                 "</publish_subscribe>")
    seen = []
    node._deliveries.append(lambda event: seen.append(event.event))
    for x in (0.0, 2.0, 3.0):
        node.arrived("/v", vector(x))
    node.close()
    # pos(0.0) came out; each event that raised is reported and the ones after it are fed
    assert seen == ["pos(0.0)"] and node.stats.errors == 2 and node.fed == 3


def test_linger_feeds_what_arrives_meanwhile_in_one_call():
    engine = Engine.from_source(PROGRAM, "live.rtl")
    calls = []
    original = engine.feed_batch

    def counting(events):
        calls.append(len(events))
        return original(events)

    engine.feed_batch = counting
    node = LiveNode(engine, MemoryTransport(), parse_config(
        "<publish_subscribe><subscribe_to name='/v' msg_type='geometry_msgs/Vector3'/></publish_subscribe>"),
        log=lambda text: None, linger=0.5)
    node.start()
    for x in range(5):
        node.arrived("/v", vector(float(x)))
    node.close()
    assert calls == [5] and node.fed == 5


def point_stamped(stamp_ns: int) -> bytes:
    stamp = STORE.types["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    msg = STORE.types["geometry_msgs/msg/PointStamped"](header=STORE.types["std_msgs/msg/Header"](stamp=stamp, frame_id="f"),
                                                        point=STORE.types["geometry_msgs/msg/Point"](x=1.0, y=0.0, z=0.0))
    return bytes(STORE.serialize_cdr(msg, "geometry_msgs/msg/PointStamped"))


@pytest.mark.parametrize("old", [False, True])
def test_events_later_than_the_delay_bound_are_a_warning(old):
    """A message without a header is stamped with its arrival (the wall clock); one stamped
    long before it (a recording played with its old stamps) is late, and the node says so
    on its log, before its summary."""
    engine = Engine.from_source(PROGRAM, "live.rtl")
    logged = []
    node = LiveNode(engine, MemoryTransport(), parse_config(
        "<publish_subscribe><subscribe_to name='/v' msg_type='geometry_msgs/Vector3'/>"
        "<subscribe_to name='/p' msg_type='geometry_msgs/PointStamped'/></publish_subscribe>"), log=logged.append)
    node.start()
    node.arrived("/v", vector(1.0))
    for _ in range(2):
        node.arrived("/p", point_stamped(100 * 10**9 if old else time.time_ns()))
    node.close()
    warnings = [line for line in logged if line.startswith("warning: ")]
    assert node.late == engine.stats()["late"] == (2 if old else 0)
    if old:     # one warning per check that saw the count grow: here one or two
        assert 1 <= len(warnings) <= 2 and warnings[-1].endswith(
            "2 in all: their results may depend on the arrival order; are the stamps on the node's clock? "
            "(docs/ros.md)"), logged
        assert "more than the delay bound (max_delay) behind the clock (" in warnings[0]
    else:
        assert warnings == [], logged


def test_ros_without_rospy_says_how_to_set_it_up(tmp_path):
    if subprocess.run([sys.executable, "-c", "import rospy"], capture_output=True).returncode == 0:
        pytest.skip("rospy is importable here")
    program = tmp_path / "p.rtl"
    program.write_text(PROGRAM)
    run = subprocess.run([sys.executable, "-m", "retalisc", "ros", str(program)], capture_output=True, text=True,
                         env=retalisc_env())
    assert run.returncode == 2 and "python3-rospy" in run.stderr and ".venv-ros/bin/retalisc" in run.stderr
    assert "Traceback" not in run.stderr


HEARTBEAT_PROGRAM = """
alarm(silence(X), 0.3) <- geometry_msgs__0__Vector3(X, _, _).
"""


@pytest.mark.parametrize("heartbeat", [None, 0.05])
def test_heartbeat_moves_the_clock_while_nothing_arrives(heartbeat):
    """One message (stamped with its arrival: no header) arms a timer 0.3 s later; with a
    heartbeat the node's clock moves the program's on while nothing more arrives and the
    alarm fires, at the message's time + 0.3 s; without, the clock never gets there."""
    engine = Engine.from_source(HEARTBEAT_PROGRAM, "beat.rtl")
    seen = []
    node = LiveNode(engine, MemoryTransport(), parse_config(
        "<publish_subscribe><subscribe_to name='/v' msg_type='geometry_msgs/Vector3'/></publish_subscribe>"),
        log=lambda text: None, heartbeat=heartbeat)
    node._deliveries.append(seen.append)
    node.start()
    before = time.time()
    node.arrived("/v", vector(7.0))
    deadline = time.monotonic() + 3.0
    while not any(e.event == "silence(7.0)" for e in seen) and time.monotonic() < deadline:
        time.sleep(0.02)
    if heartbeat is None:
        time.sleep(0.5)
    node.close()
    alarms = [e for e in seen if e.event == "silence(7.0)"]
    if heartbeat is None:
        assert alarms == []
    else:
        assert len(alarms) == 1
        start = alarms[0].start if isinstance(alarms[0].start, float) else float(alarms[0].start)
        assert before - 0.1 < start < before + 0.5 and abs(float(alarms[0].end) - start - 0.3) < 1e-6


def test_heartbeat_does_not_go_with_a_state_directory(tmp_path):
    with pytest.raises(ValueError, match="heartbeat"):
        LiveNode(Engine.from_source(HEARTBEAT_PROGRAM, "beat.rtl"), MemoryTransport(), log=lambda text: None,
                 heartbeat=0.1, state=object())


def test_the_starting_thread_as_the_consumer():
    """`start(here=True)`: the thread that started the node feeds what arrives in `run` (as
    the `retalisc` program's main thread does, the Prolog thread itself): messages from other
    threads in their order, a service request from another thread answered between them,
    `stop` from any thread ending `run`, and `close` feeding what is still queued."""
    engine = Engine.from_source(PROGRAM, "live.rtl")
    transport = MemoryTransport()
    node = LiveNode(engine, transport, parse_config("<publish_subscribe><subscribe_to name='/v' "
                                                    "msg_type='geometry_msgs/Vector3'/></publish_subscribe>"),
                    log=lambda text: None)
    node.start(here=True)
    assert transport.subscribed == {"/v": "geometry_msgs/Vector3"}     # the set-up ran at once, here
    seen, replies = [], []
    node._deliveries.append(lambda event: seen.append((threading.current_thread(), event.event)))

    def client():
        for x in range(5):
            node.arrived("/v", vector(float(x)))
        replies.append(node.query("mem(points, p(X, _, _))", "", all_answers=True))
        node.arrived("/v", vector(5.0))
        node.stop()
        node.arrived("/v", vector(6.0))          # after the stop: fed by close

    thread = threading.Thread(target=client)
    thread.start()
    node.run(duration=30)
    thread.join()
    fed_in_run = [event for _, event in seen if event.startswith("pos(")]
    node.close()
    assert [a["X"] for a in replies[0].value] == ["0.0", "1.0", "2.0", "3.0", "4.0"]
    assert fed_in_run == [f"pos({float(x)!r})" for x in range(6)]
    assert [event for _, event in seen if event.startswith("pos(")] == [f"pos({float(x)!r})" for x in range(7)]
    assert {owner for owner, _ in seen} == {threading.current_thread()}
