"""The other side of the ROS 1 end-to-end tests (tests/test_live_ros1.py): a ROS 1 client run
with the ROS Python (.venv-ros), which publishes messages, calls the node's services and
prints what it saw as one JSON object.

    python ros1_client.py services NODE_NAME FILE_THAT_MUST_NOT_APPEAR
    python ros1_client.py exploits NODE_NAME CANARY_FILE
    python ros1_client.py nao SECONDS
    python ros1_client.py bag BAG RATE TOPICS EXPECTED OUT_TOPICS
    python ros1_client.py numbered        (commands on standard input, one JSON reply a line)
"""
from __future__ import annotations

import json
import sys
import threading
import time

import rospy
from geometry_msgs.msg import TransformStamped, Vector3
from tf2_msgs.msg import TFMessage

from retalisc.live.ros1 import raw_message_class
from retalisc.live.ros1_services import service_class
from retalisc.robot_io.messages import MessageConverter
from service_calls import pair as _pair, queries_and_memories, wait_for


def tf_message(stamp: float, x: float, count: int = 1) -> TFMessage:
    transforms = []
    for i in range(count):
        t = TransformStamped()
        t.header.stamp = rospy.Time.from_sec(stamp)
        t.header.frame_id = "odom"
        t.child_frame_id = f"link{i}" if count > 1 else "base"
        t.transform.translation.x = x
        t.transform.rotation.w = 1.0
        transforms.append(t)
    return TFMessage(transforms)


def services(node: str, forbidden: str) -> dict:
    def proxy(name):
        rospy.wait_for_service(f"/{node}/{name}", timeout=10)
        return rospy.ServiceProxy(f"/{node}/{name}", service_class(name))

    add_out, del_out = proxy("add_output_subscription"), proxy("delete_output_subscription")
    add_mem, del_mem = proxy("add_memory"), proxy("delete_memory")
    add_in, del_in = proxy("add_input_subscription"), proxy("delete_input_subscription")
    query_one, query_all = proxy("query_one"), proxy("query_all")
    result = {}
    got, everything = [], []
    tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=None)
    tf2_pub = rospy.Publisher("/tf_other", TFMessage, queue_size=None)
    positions = rospy.Subscriber("/robot_pos", Vector3, lambda m: got.append(m.x))
    reply = add_out(topic="robot_pos", msg_type="", event="tf(P, C, V)", conditions="[P == odom]",
                    template="V", start="", end="")
    result["subscribe"] = [reply.ok, reply.error, reply.id]
    result["bad_subscribe"] = _pair(add_out(topic="robot_pos", msg_type="", event="tf(P, C, V)",
                                            conditions="[shell(ls)]", template="", start="", end=""))
    wait_for(lambda: positions.get_num_connections() > 0 and tf_pub.get_num_connections() > 0)
    time.sleep(0.5)     # the node adds our connection to its publisher after we count it (below)
    for i in range(5):
        tf_pub.publish(tf_message(100 + i, float(i)))
    wait_for(lambda: len(got) >= 5, 10)
    result["delivered"] = list(got)

    def three_more():
        for i in range(5, 8):
            tf_pub.publish(tf_message(100 + i, float(i)))
        wait_for(lambda: len(got) >= 8, 10)

    queries_and_memories(result, query_one, query_all, add_mem, del_mem, forbidden, three_more)
    result["unsubscribe"] = _pair(del_out(id=reply.id, end=""))
    for i in range(8, 10):        # stamped now: after the unsubscription (at the wall clock's now)
        tf_pub.publish(tf_message(time.time(), float(i)))
    wait_for(lambda: _count(query_all) >= 10, 10)
    time.sleep(0.3)
    result["delivered_after_unsubscribe"] = list(got)
    result["delete_input"] = _pair(del_in(topic="/tf"))
    result["delete_input_again"] = _pair(del_in(topic="/tf"))
    tf_pub.publish(tf_message(200, 99.0))
    time.sleep(0.3)
    result["count_after_delete_input"] = _count(query_all)
    result["add_input"] = _pair(add_in(topic="tf_other", msg_type="tf2_msgs/TFMessage"))
    result["add_input_bad_type"] = _pair(add_in(topic="/x", msg_type="not a type"))
    wait_for(lambda: tf2_pub.get_num_connections() > 0)
    tf2_pub.publish(tf_message(time.time(), 42.0))
    wait_for(lambda: _count(query_all) > 10, 10)
    result["count_after_add_input"] = _count(query_all)
    # 10x the thesis's load (1,900 transforms/s): 3,800 messages of 5 transforms in one second
    load = rospy.Subscriber("/all_tf", Vector3, lambda m: everything.append(m.x), queue_size=None)
    load_sub = add_out(topic="all_tf", msg_type="geometry_msgs/Vector3",
                       event="tf2_msgs__0__TFMessage([geometry_msgs__0__TransformStamped(_, _, "
                             "geometry_msgs__0__Transform(V, _))|_])", conditions="",
                       template="V", start="", end="")
    result["load_subscribe"] = _pair(load_sub)
    wait_for(lambda: load.get_num_connections() > 0)
    # rospy counts the connection on this side once the node's header has arrived, while the
    # node adds it to its publisher just after writing that header: a message published in
    # between is not sent to us (seen under load as 1-11 of the first messages missing).
    time.sleep(0.5)
    messages = 3800
    began = time.monotonic()
    for k in range(messages):
        due = began + k / messages
        while time.monotonic() < due:
            time.sleep(0.0005)
        tf2_pub.publish(tf_message(time.time(), float(k), count=5))
    result["load_publish_seconds"] = time.monotonic() - began
    wait_for(lambda: len(everything) >= messages, 60)
    result["load_received"] = len(everything)
    result["load_seconds"] = time.monotonic() - began
    result["load_in_order"] = everything == [float(k) for k in range(messages)]
    result["load_memorized"] = _count(query_all)
    return result


def exploits(node: str, canary: str) -> dict:
    """The goal exploits of issue 35 through each service that takes a goal, then a query
    that must still be answered; each reply as [ok, error] (tests/test_live_ros1_boundary.py)."""
    def proxy(name):
        rospy.wait_for_service(f"/{node}/{name}", timeout=10)
        return rospy.ServiceProxy(f"/{node}/{name}", service_class(name))

    add_out, add_mem = proxy("add_output_subscription"), proxy("add_memory")
    query_one, query_all = proxy("query_one"), proxy("query_all")
    shell = f'shell("touch {canary}")'
    goals = {"print_message": f'print_message(error, format("~@", [{shell}]))',
             "format_W": f'format(atom(_), "~W", ["touch {canary}", [portray_goal(shell)]])',
             "put_attr": f"put_attr(Y, freeze, {shell}), Y = 1",
             "thrown": f'throw(error(format("~@", [{shell}]), _))',
             "aborted": "throw('$aborted')"}
    result = {}
    for name, goal in goals.items():
        result[f"query_all_{name}"] = _pair(query_all(query=goal, at=""))
        result[f"query_one_{name}"] = _pair(query_one(query=goal, at=""))
        result[f"add_output_{name}"] = _pair(add_out(topic="robot_pos", msg_type="", event="tf(P, C, V)",
                                                     conditions=f"[{goal}]", template="V", start="", end=""))
        result[f"add_memory_{name}"] = _pair(add_mem(memory=f"c_mem(m_{name}, tf(P, C, V)-[{goal}], 2, inf)"))
    started = time.monotonic()
    result["caught_limit"] = _pair(query_all(query="catch((repeat, fail), _, true)", at=""))
    result["caught_limit_seconds"] = time.monotonic() - started
    result["after"] = _pair(query_all(query="X = 1", at=""))
    return result


def _count(query_all) -> int:
    return len(query_all(query="mem(tfs, _)", at="").answers)


def nao(seconds: float) -> dict:
    """Publish the sample NAO recording (tf and ar_pose markers) in record order and in real
    time, as the robot would send it now: the recording is made with its first stamp at the
    wall clock's now (`start_s`, reported), when the connections are up, so that the stamps
    are on the node's clock (a header-less TFMessage is stamped with its arrival; with the
    sample's own 2014 stamps the node's clock would be years ahead of every stamp, every
    event late and every synchronized rule released at once). Collect what comes on
    /marker1 and /marker2 as event terms."""
    from retalisc.robot_io.samples import nao_records, sample_store

    store = sample_store(1)
    converter = MessageConverter(store)
    publishers = {}
    received = []

    def on_marker(msg, topic):
        decoded = store.deserialize_ros1(msg._buff, "geometry_msgs/msg/PoseStamped")
        received.append([topic, converter.term(decoded, "geometry_msgs/msg/PoseStamped")])

    subscribers = [rospy.Subscriber(t, rospy.AnyMsg, on_marker, callback_args=t) for t in ("/marker1", "/marker2")]
    for topic, msgtype in (("/tf", "tf2_msgs/msg/TFMessage"), ("/ar_pose_marker", "ar_pose/msg/ARMarkers")):
        text, md5 = store.generate_msgdef(msgtype, ros_version=1)
        publishers[topic] = rospy.Publisher(topic, raw_message_class(msgtype.replace("/msg/", "/"), md5, text),
                                            queue_size=None)
    wait_for(lambda: all(p.get_num_connections() > 0 for p in publishers.values())
             and all(s.get_num_connections() > 0 for s in subscribers))
    time.sleep(0.5)     # as in services(): the node's publishers may not have added us yet
    start_s = time.time()
    records = [r for r in nao_records(store, seconds=seconds, start_s=start_s) if r[0] in publishers]
    messages = [(topic, record_ns, bytes(store.serialize_ros1(msg, msgtype))) for topic, msgtype, record_ns, msg in records]
    began, first_ns = time.monotonic(), int(start_s * 1_000_000_000)
    for topic, record_ns, raw in messages:       # in real time, as recorded
        message = publishers[topic].data_class()
        message._buff = raw
        due = began + (record_ns - first_ns) / 1e9
        if due > time.monotonic():
            time.sleep(due - time.monotonic())
        publishers[topic].publish(message)
    expected = int(sys.argv[3]) if len(sys.argv) > 3 else 0
    wait_for(lambda: len(received) >= expected, 15)
    time.sleep(0.5)
    return {"received": received, "published": len(records), "start_s": start_s}


def bag(path: str, rate: float, topics: str, expected: int, out_topics: str) -> dict:
    """Publish the messages of TOPICS (comma-separated) of a ROS 1 recording, in record order,
    at RATE times its clock, as a robot would send them now: every header stamp is moved by
    the same whole number of seconds (`shift`), so that the first message is stamped with
    the wall clock (a live component's clock; a header-less message, such as a TFMessage, is
    stamped with its arrival). Each goes out as the type (name, MD5 sum, full definition)
    the recording holds. Collects the geometry_msgs/PoseStamped messages that come on
    OUT_TOPICS until EXPECTED have come (then half a second more, to see duplicates), each
    as [topic, seq, sec, nsec, frame_id, [x, y, z], [qx, qy, qz, qw]] with its stamp moved
    back by `shift`."""
    from retalisc.robot_io.bags import Recording, typestore

    out_store = typestore("ros1_noetic")
    received = []

    def on_pose(msg, topic):
        pose = out_store.deserialize_ros1(msg._buff, "geometry_msgs/msg/PoseStamped")
        p, q = pose.pose.position, pose.pose.orientation
        received.append([topic, pose.header.seq, pose.header.stamp.sec - shift, pose.header.stamp.nanosec,
                         pose.header.frame_id, [p.x, p.y, p.z], [q.x, q.y, q.z, q.w]])

    subscribers = [rospy.Subscriber(t, rospy.AnyMsg, on_pose, callback_args=t, queue_size=None)
                   for t in out_topics.split(",")]
    wanted = topics.split(",")
    publishers = {}
    with Recording(path) as recording:
        store = recording.typestore
        for c in recording._reader.connections:
            if c.topic in wanted and c.topic not in publishers:
                publishers[c.topic] = rospy.Publisher(
                    c.topic, raw_message_class(c.msgtype.replace("/msg/", "/"), c.digest, c.msgdef.data),
                    queue_size=None)
        records = list(recording.records(wanted))
    shift = int(time.time()) + 1 - records[0].time_ns // 1_000_000_000
    messages = []
    for record in records:
        _move_stamps(record.msg, shift)
        messages.append((record.topic, record.time_ns, bytes(store.serialize_ros1(record.msg, record.msgtype))))
    wait_for(lambda: all(p.get_num_connections() > 0 for p in publishers.values())
             and all(s.get_num_connections() > 0 for s in subscribers))
    time.sleep(0.5)     # as in services(): the node's publishers may not have added us yet
    began, first_ns = time.monotonic(), messages[0][1]
    for topic, time_ns, raw in messages:
        due = began + (time_ns - first_ns) / 1e9 / rate
        if due > time.monotonic():
            time.sleep(due - time.monotonic())
        message = publishers[topic].data_class()
        message._buff = raw
        publishers[topic].publish(message)
    published = time.monotonic() - began
    wait_for(lambda: len(received) >= expected, 20)
    time.sleep(0.5)
    return {"received": received, "published": len(messages), "publish_seconds": published, "shift": shift}


def _move_stamps(msg, seconds: int) -> None:
    """Add `seconds` to every header stamp in a rosbags message (nested messages and lists)."""
    fields = getattr(msg, "__dataclass_fields__", None)
    if fields is None:
        return
    for name in fields:
        value = getattr(msg, name)
        if name == "stamp" and hasattr(value, "sec") and type(msg).__name__.endswith("Header"):
            value.sec += seconds
        elif isinstance(value, list):
            for item in value:
                _move_stamps(item, seconds)
        else:
            _move_stamps(value, seconds)


def chain(first: str, second: str) -> dict:
    """Two components from one launch file: tf into the first, positions out of the second."""
    rospy.wait_for_service(f"/{second}/query_all", timeout=30)
    rospy.wait_for_service(f"/{first}/query_all", timeout=30)
    query_all = rospy.ServiceProxy(f"/{second}/query_all", service_class("query_all"))
    tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=None)
    wait_for(lambda: tf_pub.get_num_connections() > 0)

    def positions():
        reply = query_all(query="mem(positions, pos(X, _, _))", at="")
        return [float(answer.values[0]) for answer in reply.answers]

    deadline = time.monotonic() + 20
    while not positions() and time.monotonic() < deadline:     # until the chain is connected
        tf_pub.publish(tf_message(time.time(), 0.0))
        time.sleep(0.2)
    for i in range(1, 6):
        tf_pub.publish(tf_message(time.time(), float(i)))
    wait_for(lambda: len([x for x in positions() if x > 0]) >= 5, 10)
    return {"positions": [x for x in positions() if x > 0]}


NUMBERED_XS = [1.0, 5.0, 2.0, 7.0, 3.0, 0.5, 9.0, 4.0, 6.0, 8.0, 2.5, 10.0, 1.5, 11.0]


def point_stamped(store, i: int) -> bytes:
    """Event i of the `numbered` scenario: a geometry_msgs/PointStamped, x = NUMBERED_XS[i],
    stamped 100 + i s, header.seq i + 1 (tests/test_live_ros1.py makes the same bytes)."""
    types = store.types
    header = types["std_msgs/msg/Header"](seq=i + 1, stamp=types["builtin_interfaces/msg/Time"](sec=100 + i, nanosec=0),
                                          frame_id="f")
    msg = types["geometry_msgs/msg/PointStamped"](header=header, point=types["geometry_msgs/msg/Point"](
        x=NUMBERED_XS[i], y=0.0, z=0.0))
    return bytes(store.serialize_ros1(msg, "geometry_msgs/msg/PointStamped"))


def _live_connections(publisher) -> int:
    """The subscribers of `publisher` whose connection is open: the connection of a killed
    node stays in rospy's list until a write to it fails, and a message written to it is lost."""
    import socket

    alive = 0
    for connection in list(publisher.impl.connections):
        sock = getattr(connection, "socket", None)
        if sock is None:
            continue
        try:
            closed = sock.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT) == b""
        except BlockingIOError:
            closed = False
        except OSError:
            closed = True
        alive += not closed
    return alive


def numbered() -> None:
    """A subscriber that outlives the node: publishes events on /p and takes /stamped
    (geometry_msgs/PointStamped: the output number is header.seq) and /vec (geometry_msgs/Point,
    its number the std_msgs/UInt64 that comes on /vec/seq right before it: the k-th number
    received is the k-th message's). Commands on standard input, a JSON reply each:
    `wait` (until /p and the three outputs are connected), `send I J` (events I to J-1),
    `expect N` (until N messages that are not repeats came), `report` (what came: every
    message in arrival order as [topic, number, x, y], the repeats dropped as a consumer
    drops them, the count of repeats)."""
    from retalisc.robot_io.bags import typestore

    store = typestore("ros1_noetic")
    publisher = rospy.Publisher("/p", raw_message_class("geometry_msgs/PointStamped", *reversed(
        store.generate_msgdef("geometry_msgs/msg/PointStamped", ros_version=1))), queue_size=None)
    lock = threading.Lock()
    arrived, kept, highest, numbers, pending = [], [], {}, [], []

    def keep(topic, number, point):
        arrived.append([topic, number, point.x, point.y])
        if number > highest.get(topic, 0):        # dropping repeats: a number not above the highest seen
            highest[topic] = number
            kept.append([topic, number, point.x, point.y])

    def on_stamped(msg):
        decoded = store.deserialize_ros1(msg._buff, "geometry_msgs/msg/PointStamped")
        with lock:
            keep("/stamped", decoded.header.seq, decoded.point)

    def pair():
        while numbers and pending:
            keep("/vec", numbers.pop(0), pending.pop(0))

    def on_vec(msg):
        with lock:
            pending.append(store.deserialize_ros1(msg._buff, "geometry_msgs/msg/Point"))
            pair()

    def on_vec_seq(msg):
        with lock:
            numbers.append(store.deserialize_ros1(msg._buff, "std_msgs/msg/UInt64").data)
            pair()

    subscribers = [rospy.Subscriber("/stamped", rospy.AnyMsg, on_stamped, queue_size=None),
                   rospy.Subscriber("/vec", rospy.AnyMsg, on_vec, queue_size=None),
                   rospy.Subscriber("/vec/seq", rospy.AnyMsg, on_vec_seq, queue_size=None)]
    for line in sys.stdin:
        command = line.split()
        if not command:
            continue
        if command[0] == "wait":
            reply = {"ready": wait_for(lambda: _live_connections(publisher) > 0
                                       and all(s.get_num_connections() > 0 for s in subscribers), 20)}
        elif command[0] == "send":
            first, last = int(command[1]), int(command[2])
            for i in range(first, last):
                message = publisher.data_class()
                message._buff = point_stamped(store, i)
                publisher.publish(message)
                time.sleep(0.02)
            reply = {"sent": last - first}
        elif command[0] == "expect":
            wanted = int(command[1])
            reply = {"came": wait_for(lambda: len(kept) >= wanted, 15), "kept": len(kept)}
        else:
            with lock:
                reply = {"arrived": arrived, "kept": kept, "repeats": len(arrived) - len(kept),
                         "unpaired": [len(numbers), len(pending)]}
        print(json.dumps(reply))
        sys.stdout.flush()


def main() -> None:
    rospy.init_node("retalisc_test_client", anonymous=True, disable_signals=True)
    scenario = sys.argv[1]
    if scenario == "services":
        result = services(sys.argv[2], sys.argv[3])
    elif scenario == "exploits":
        result = exploits(sys.argv[2], sys.argv[3])
    elif scenario == "chain":
        result = chain(sys.argv[2], sys.argv[3])
    elif scenario == "nao":
        result = nao(float(sys.argv[2]))
    elif scenario == "bag":
        result = bag(sys.argv[2], float(sys.argv[3]), sys.argv[4], int(sys.argv[5]), sys.argv[6])
    elif scenario == "numbered":
        numbered()
        rospy.signal_shutdown("done")
        return
    else:
        raise SystemExit(f"unknown scenario {scenario}")
    print(json.dumps(result))
    sys.stdout.flush()
    rospy.signal_shutdown("done")


if __name__ == "__main__":
    main()
