"""The other side of the ROS 2 end-to-end tests (tests/test_live_ros2.py): an independent rclpy
process (run with .venv-ros2's Python), which publishes /tf_static before the node starts,
then finds the node in the graph, reads its parameters, publishes reliable and best-effort
topics and /clock, calls every Retalis service and prints what it saw as one JSON object.

    python ros2_client.py NODE_NAME FILE_THAT_MUST_NOT_APPEAR
    python ros2_client.py --tf FIRST LAST     (publish tf x = FIRST..LAST-1 on /tf_burst reliably, then exit)
    python ros2_client.py --bag BAG RATE TOPICS EXPECTED OUT_TOPICS    (play a ROS 1 recording as ROS 2 messages)
    python ros2_client.py --sim     (sim time on /clock, /sensor in, /echo and /quiet out: --heartbeat, --linger)

It prints `static published` on standard error once /tf_static is out (the test then starts
the node: a late joiner of a transient-local topic).
"""
from __future__ import annotations

import json
import os
import sys
import threading
import time

import rclpy
from builtin_interfaces.msg import Time
from geometry_msgs.msg import TransformStamped, Vector3
from rcl_interfaces.msg import Parameter, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.duration import Duration
from rclpy.executors import MultiThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from std_msgs.msg import UInt64
from tf2_msgs.msg import TFMessage

import retalis_interfaces.srv as srv
from ar_pose.msg import ARMarker, ARMarkers
from service_calls import pair as _pair, queries_and_memories, wait_for


BURST = 5000


def tf_message(stamp: float, x: float, child: str = "base") -> TFMessage:
    t = TransformStamped()
    t.header.stamp = Time(sec=int(stamp), nanosec=int(round((stamp % 1) * 1e9)))
    t.header.frame_id = "odom"
    t.child_frame_id = child
    t.transform.translation.x = x
    t.transform.rotation.w = 1.0
    return TFMessage(transforms=[t])


def publish_tf(first: int, last: int) -> None:
    """Publish tf messages x = first..last-1 (stamps 1000 + x) on /tf_burst, reliably: each is
    kept until the node's reader acknowledged it."""
    rclpy.init()
    client = rclpy.create_node("retalis_test_tf")
    # /tf_burst: the node reads it reliably, so no message is lost while the node's reader
    # and this writer still discover each other (a best-effort reader drops what comes first)
    tf = client.create_publisher(TFMessage, "/tf_burst", QoSProfile(history=HistoryPolicy.KEEP_ALL,
                                                                    reliability=ReliabilityPolicy.RELIABLE))
    if not wait_for(lambda: tf.get_subscription_count() > 0, 30):
        sys.exit("no subscriber of /tf_burst")
    for x in range(first, last):
        tf.publish(tf_message(1000 + x, float(x)))
    tf.wait_for_all_acked(Duration(seconds=10))
    client.destroy_node()
    rclpy.try_shutdown()


def ros2_message(value, cls):
    """The rclpy message of class `cls` with the fields of `value`, a message read by rosbags
    (from a ROS 1 recording): field by field, nested messages and lists of messages too; a
    field ROS 2 does not have (std_msgs/Header's seq) is left out."""
    msg = cls()
    for name, kind in cls.get_fields_and_field_types().items():
        source = getattr(value, name)
        current = getattr(msg, name)
        if hasattr(type(current), "get_fields_and_field_types"):
            setattr(msg, name, ros2_message(source, type(current)))
        elif kind.startswith("sequence<") and "/" in kind:
            package, type_name = kind[len("sequence<"):].rstrip(">").split(",")[0].split("/")
            item = getattr(__import__(f"{package}.msg", fromlist=[type_name]), type_name)
            setattr(msg, name, [ros2_message(element, item) for element in source])
        else:
            setattr(msg, name, source)
    return msg


def play_bag(path: str, rate: float, topics: str, expected: int, out_topics: str) -> None:
    """Publish the messages of TOPICS (comma-separated) of a ROS 1 recording as ROS 2 messages
    (rclpy's generated classes: tf2_msgs/TFMessage, ar_pose/ARMarkers; a header without its
    seq), in record order, at RATE times its clock, as a robot would send them now: every header
    stamp moved by the same whole number of seconds (`shift`), so that the first message is
    stamped with the wall clock, as in tests/ros1_client.py `bag`. Publishers are reliable
    (as tf2's broadcaster). Collects the geometry_msgs/PoseStamped messages on OUT_TOPICS
    (and their output numbers on TOPIC/seq) until EXPECTED have come, then half a second more
    to see duplicates; prints {"received": [[topic, sec, nsec, frame_id, [x, y, z], [qx, qy, qz,
    qw]], ...], "numbers": {topic: [...]}, ...}, stamps moved back by `shift`."""
    from geometry_msgs.msg import PoseStamped
    from rosbags.highlevel import AnyReader
    from pathlib import Path

    rclpy.init()
    client = rclpy.create_node("retalis_test_player")
    executor = MultiThreadedExecutor(num_threads=2)
    executor.add_node(client)
    threading.Thread(target=executor.spin, daemon=True).start()
    received, numbers, lock = [], {}, threading.Lock()
    shift = 0

    def on_pose(msg, topic):
        p, q = msg.pose.position, msg.pose.orientation
        with lock:
            received.append([topic, msg.header.stamp.sec - shift, msg.header.stamp.nanosec, msg.header.frame_id,
                             [p.x, p.y, p.z], [q.x, q.y, q.z, q.w]])

    def on_number(msg, topic):
        with lock:
            numbers.setdefault(topic, []).append(msg.data)

    reliable = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    subscriptions = []
    for topic in out_topics.split(","):
        subscriptions.append(client.create_subscription(PoseStamped, topic, lambda m, t=topic: on_pose(m, t), reliable))
        subscriptions.append(client.create_subscription(UInt64, topic + "/seq", lambda m, t=topic: on_number(m, t),
                                                        reliable))
    classes = {"tf2_msgs/msg/TFMessage": TFMessage, "ar_pose/msg/ARMarkers": ARMarkers}
    wanted = topics.split(",")
    with AnyReader([Path(path)]) as reader:
        connections = [c for c in reader.connections if c.topic in wanted]
        records = [(c.topic, c.msgtype, time_ns, reader.deserialize(raw, c.msgtype))
                   for c, time_ns, raw in reader.messages(connections=connections)]
    publishers = {topic: client.create_publisher(classes[msgtype], topic, reliable) for topic, msgtype, _, _ in records}
    shift = int(time.time()) + 1 - records[0][2] // 1_000_000_000
    messages = []
    for topic, msgtype, time_ns, msg in records:
        out = ros2_message(msg, classes[msgtype])
        for stamped in (getattr(out, "transforms", None) or []) + (getattr(out, "markers", None) or []) + [out]:
            if hasattr(stamped, "header"):
                stamped.header.stamp.sec += shift
        messages.append((topic, time_ns, out))
    if not wait_for(lambda: all(p.get_subscription_count() > 0 for p in publishers.values())
                    and all(s.get_publisher_count() > 0 for s in subscriptions), 30):
        sys.exit("the node's readers and writers did not match within 30 s")
    time.sleep(0.5)
    began, first_ns = time.monotonic(), messages[0][1]
    for topic, time_ns, msg in messages:
        due = began + (time_ns - first_ns) / 1e9 / rate
        if due > time.monotonic():
            time.sleep(due - time.monotonic())
        publishers[topic].publish(msg)
    published = time.monotonic() - began
    wait_for(lambda: len(received) >= expected, 20)
    time.sleep(0.5)
    with lock:
        print(json.dumps({"received": received, "numbers": numbers, "published": len(messages),
                          "publish_seconds": published, "shift": shift}), flush=True)
    os._exit(0)


def sim_time() -> None:
    """The other side of the --heartbeat and --linger test (tests/live/ros2_heartbeat.rtl):
    /clock every 50 ms of wall time, sim time moving 0.05 s a tick towards a target; five
    /sensor values 20 ms apart at sim time 5000.0; then sim time held at 5001.0 for a second
    (the timers, due at 5002.0, must not fire), then on to 5004.0 (they must). Prints the
    wall times (since the first /sensor message) of the /echo deliveries and of the last
    /sensor message, the /quiet values during the hold and after it."""
    rclpy.init()
    client = rclpy.create_node("retalis_test_sim")
    executor = MultiThreadedExecutor(num_threads=2)
    executor.add_node(client)
    threading.Thread(target=executor.spin, daemon=True).start()
    sim, target = [5000.0], [5000.0]
    clock = client.create_publisher(Clock, "/clock", 10)

    def tick():
        sim[0] = min(target[0], sim[0] + 0.05)
        clock.publish(Clock(clock=Time(sec=int(sim[0]), nanosec=int(round((sim[0] % 1) * 1e9)))))

    client.create_timer(0.05, tick)
    keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    sensor = client.create_publisher(Vector3, "/sensor", keep_all)
    echo, quiet = [], []
    echo_sub = client.create_subscription(Vector3, "/echo", lambda m: echo.append((time.monotonic(), m.x)), keep_all)
    quiet_sub = client.create_subscription(Vector3, "/quiet", lambda m: quiet.append(m.x), keep_all)
    if not wait_for(lambda: sensor.get_subscription_count() > 0 and clock.get_subscription_count() > 0
                    and echo_sub.get_publisher_count() > 0 and quiet_sub.get_publisher_count() > 0, 30):
        sys.exit("the node did not match within 30 s")
    time.sleep(1.0)                   # the node's clock is at 5000.0
    first = time.monotonic()
    for x in range(1, 6):
        sensor.publish(Vector3(x=float(x)))
        last = time.monotonic()
        time.sleep(0.02)
    wait_for(lambda: len(echo) >= 5, 10)
    target[0] = 5001.0
    time.sleep(1.5)
    held = list(quiet)
    target[0] = 5004.0
    wait_for(lambda: len(quiet) >= 5, 15)
    print(json.dumps({"echo": [[at - first, x] for at, x in echo], "last_sent": last - first, "quiet_held": held,
                      "quiet": list(quiet)}), flush=True)
    os._exit(0)


def main() -> None:
    if sys.argv[1] == "--sim":
        return sim_time()
    if sys.argv[1] == "--tf":
        return publish_tf(int(sys.argv[2]), int(sys.argv[3]))
    if sys.argv[1] == "--bag":
        return play_bag(sys.argv[2], float(sys.argv[3]), sys.argv[4], int(sys.argv[5]), sys.argv[6])
    name, forbidden = sys.argv[1], sys.argv[2]
    rclpy.init()
    client = rclpy.create_node("retalis_test_client")
    executor = MultiThreadedExecutor(num_threads=2)
    executor.add_node(client)
    threading.Thread(target=executor.spin, daemon=True).start()
    result = {}

    static = client.create_publisher(TFMessage, "/tf_static", QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    static.publish(tf_message(50, -5.0, "camera"))
    print("static published", file=sys.stderr, flush=True)

    # the graph: the node, its services, its publishers and subscriptions
    found = wait_for(lambda: (name, "/") in client.get_node_names_and_namespaces(), 30)
    result["node_found"] = found
    def graph():     # what discovery has told us of the node so far
        return (sorted(client.get_service_names_and_types_by_node(name, "/")),
                sorted(topic for topic, _ in client.get_publisher_names_and_types_by_node(name, "/")),
                sorted(topic for topic, _ in client.get_subscriber_names_and_types_by_node(name, "/")))

    wait_for(lambda: len(graph()[0]) >= 15 and "/pos/seq" in graph()[1] and len(graph()[2]) >= 5, 10)
    result["services"], result["publishers"], result["subscriptions"] = graph()

    def proxy(service, cls):
        cli = client.create_client(cls, f"/{name}/{service}")
        cli.wait_for_service(timeout_sec=10)

        def call(**fields):
            future = cli.call_async(cls.Request(**fields))
            wait_for(future.done, 20)
            return future.result()

        return call

    # parameters, through the parameter services; read-only ones refuse a change
    get = proxy("get_parameters", GetParameters)
    keys = ["program", "config", "name", "max_delay", "state_dir", "use_sim_time"]
    values = get(names=keys).values
    result["parameters"] = {key: (value.bool_value if value.type == 1 else value.string_value)
                            for key, value in zip(keys, values)}
    refused = proxy("set_parameters", SetParameters)(parameters=[Parameter(
        name="program", value=ParameterValue(type=4, string_value="other.rtl"))])
    result["set_program"] = [refused.results[0].successful, refused.results[0].reason]

    add_out = proxy("add_output_subscription", srv.AddOutputSubscription)
    del_out = proxy("delete_output_subscription", srv.DeleteOutputSubscription)
    add_mem, del_mem = proxy("add_memory", srv.AddMemory), proxy("delete_memory", srv.DeleteMemory)
    add_in = proxy("add_input_subscription", srv.AddInputSubscription)
    del_in = proxy("delete_input_subscription", srv.DeleteInputSubscription)
    query_one, query_all = proxy("query_one", srv.QueryOne), proxy("query_all", srv.QueryAll)

    def count(memory="tfs"):
        return len(query_all(query=f"mem({memory}, _)", at="").answers)

    # topics both ways: /tf in (reliable, the default of create_publisher), /pos (the program's
    # subscription) and /robot_pos (added below) out, with the output numbers on /pos/seq
    pos, numbers, robot = [], [], []
    client.create_subscription(Vector3, "/pos", lambda m: pos.append(m.x), 100)
    client.create_subscription(UInt64, "/pos/seq", lambda m: numbers.append(m.data), 100)
    client.create_subscription(Vector3, "/robot_pos", lambda m: robot.append(m.x), 100)
    tf = client.create_publisher(TFMessage, "/tf", 100)
    wait_for(lambda: tf.get_subscription_count() > 0, 10)
    stamp = 60
    while 0.0 not in pos and stamp < 90:        # until both ways are matched
        tf.publish(tf_message(stamp, 0.0))
        stamp += 1
        time.sleep(0.2)
    reply = add_out(topic="robot_pos", msg_type="geometry_msgs/Vector3", event="tf(P, C, V)",
                    conditions="[P == odom]", event_template="V", start="", end="")
    result["subscribe"] = [reply.ok, reply.error, reply.id]
    result["bad_subscribe"] = _pair(add_out(topic="robot_pos", msg_type="", event="tf(P, C, V)",
                                            conditions="[shell(ls)]", event_template="", start="", end=""))
    result["bad_type"] = _pair(add_out(topic="robot_pos", msg_type="no_such_pkg/Thing", event="tf(P, C, V)",
                                       conditions="", event_template="", start="", end=""))
    wait_for(lambda: client.count_publishers("/robot_pos") > 0, 10)
    time.sleep(0.5)
    for i in range(1, 6):
        tf.publish(tf_message(100 + i, float(i)))
    wait_for(lambda: len(robot) >= 5 and len(pos) >= stamp - 60 + 5, 10)
    result["pos"], result["pos_seq"], result["robot_pos"] = list(pos), list(numbers), list(robot)

    def three_more():
        for i in range(6, 9):
            tf.publish(tf_message(100 + i, float(i)))
        wait_for(lambda: len(robot) >= 8, 10)

    queries_and_memories(result, query_one, query_all, add_mem, del_mem, forbidden, three_more)
    result["unsubscribe"] = _pair(del_out(id=reply.id, end="200"))
    tf.publish(tf_message(300, 99.0))           # after the subscription's end: not delivered
    wait_for(lambda: any(a.values[0].startswith("geometry_msgs__0__Vector3(99.0")
                         for a in query_all(query="mem(tfs, tf(_, _, V))", at="").answers), 10)
    time.sleep(0.3)
    result["robot_pos_after_unsubscribe"] = list(robot)
    before = count()
    result["delete_input"] = _pair(del_in(topic="/tf"))
    result["delete_input_again"] = _pair(del_in(topic="/tf"))
    tf.publish(tf_message(301, 98.0))
    time.sleep(0.5)
    result["count_after_delete_input"] = [before, count()]
    other = client.create_publisher(TFMessage, "/tf_other", 10)
    result["add_input"] = _pair(add_in(topic="tf_other", msg_type="tf2_msgs/TFMessage"))
    result["add_input_bad_type"] = _pair(add_in(topic="/x", msg_type="not a type"))
    result["add_input_missing_package"] = _pair(add_in(topic="/things", msg_type="no_such_pkg/Thing"))
    # ar_pose/ARMarkers: not in rosbags' types, built by the set-up; read with its .msg file
    result["add_input_ar_pose"] = _pair(add_in(topic="/ar_pose_marker", msg_type="ar_pose/ARMarkers"))
    markers = client.create_publisher(ARMarkers, "/ar_pose_marker", 10)
    wait_for(lambda: markers.get_subscription_count() > 0, 10)
    sample = ARMarkers(markers=[ARMarker(id=7, confidence=90)])
    sample.header.stamp = Time(sec=303)
    sample.markers[0].pose.pose.position.x = 0.25

    def marker_ids():
        return [dict(zip(a.variables, a.values)) for a in query_all(query="mem(markers, marker(Id, X))", at="").answers]

    for _ in range(25):       # published best effort: until one has come through
        markers.publish(sample)
        time.sleep(0.2)
        if marker_ids():
            break
    result["markers"] = marker_ids()
    wait_for(lambda: other.get_subscription_count() > 0, 10)
    other.publish(tf_message(302, 42.0))
    wait_for(lambda: count() > before, 10)
    result["count_after_add_input"] = count()

    # time: /clock drives the node's clock (use_sim_time), which stamps header-less messages;
    # the default input QoS takes best-effort (sensor data) and reliable publishers alike, a
    # reliable reader (pub_sub.xml reliability="reliable") refuses a best-effort publisher
    clock = client.create_publisher(Clock, "/clock", 10)
    wait_for(lambda: clock.get_subscription_count() > 0, 10)
    # as a simulator does, /clock every 50 ms (a sample sent before the node matched us is lost)
    client.create_timer(0.05, lambda: clock.publish(Clock(clock=Time(sec=5000, nanosec=0))))
    best_effort = client.create_publisher(Vector3, "/sensor", qos_profile_sensor_data)
    reliable = client.create_publisher(Vector3, "/sensor", 10)
    refused_pub = client.create_publisher(Vector3, "/sensor_reliable", qos_profile_sensor_data)
    wait_for(lambda: best_effort.get_subscription_count() > 0 and reliable.get_subscription_count() > 0, 10)
    time.sleep(0.5)
    best_effort.publish(Vector3(x=1.5))
    reliable.publish(Vector3(x=2.5))
    refused_pub.publish(Vector3(x=3.5))
    wait_for(lambda: count("xs") >= 2, 10)
    time.sleep(0.3)
    xs = query_all(query="mem(xs, x(X)^T)", at="").answers
    result["xs"] = sorted([dict(zip(a.variables, a.values)) for a in xs], key=lambda a: a["X"])
    result["refused_pub_matched"] = refused_pub.get_subscription_count()

    # a burst of 5,000 tf messages, as fast as we can publish, on an input that pub_sub.xml makes
    # reliable with a keep-all history: every delivery comes back, in order
    keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    burst = []
    client.create_subscription(Vector3, "/burst_out", lambda m: burst.append(m.x), keep_all)
    result["burst_subscribe"] = _pair(add_out(topic="burst_out", msg_type="", event="tf(P, C, V)",
                                              conditions="[C == burst]", event_template="V", start="",
                                              end=""))
    burst_pub = client.create_publisher(TFMessage, "/tf_burst", keep_all)
    wait_for(lambda: burst_pub.get_subscription_count() > 0 and client.count_publishers("/burst_out") > 0, 10)
    time.sleep(0.5)
    began = time.monotonic()
    for k in range(BURST):
        burst_pub.publish(tf_message(6000 + k / 1000, float(k), "burst"))
    wait_for(lambda: len(burst) >= BURST, 60)
    result["burst_seconds"] = time.monotonic() - began
    result["burst_received"] = len(burst)
    result["burst_in_order"] = burst == [float(k) for k in range(BURST)]
    result["static_pub_matched"] = static.get_subscription_count()
    print(json.dumps(result), flush=True)
    sys.stderr.flush()
    # Leave without tearing rclpy down: with the executor's thread still spinning, the teardown
    # at exit sometimes aborts in C++ ("terminate called without an active exception").
    os._exit(0)


if __name__ == "__main__":
    main()
