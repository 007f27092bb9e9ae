"""Two retalisc components talking ROS 2 over DDS (cyclonedds) on the loopback interface:
the first turns tf into deliveries on /pos, the second consumes them. The test publishes
/tf_static before the first component starts (transient-local: a late joiner gets it) and
/tf after. Processes are stopped by their pid at the end."""
from __future__ import annotations

import json
import random
import sys
import time

import pytest

pytest.importorskip("cyclonedds", reason="the DDS tests need the 'live' extra (cyclonedds)")
pytest.importorskip("rosbags", reason="the DDS tests need rosbags")

from live_support import LIVE, Processes, retalisc_argv, retalisc_env  # noqa: E402
from retalisc.live.dds import DdsTransport, IdlTypes, dds_topic, dds_type  # noqa: E402
from retalisc.robot_io.bags import typestore  # noqa: E402


class _Store:
    store = typestore("ros2_humble")


class _Collector:
    """The node side of a DdsTransport used to listen: what came, by topic, in order."""

    store = _Store.store

    def __init__(self):
        self.received = {}

    def arrived(self, topic, data, *rest):
        self.received.setdefault(topic, []).append(data)


def tf_message(store, stamp: int, x: float, child: str = "base"):
    T = store.types
    return T["tf2_msgs/msg/TFMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=stamp, nanosec=0),
                                        frame_id="odom"),
        child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=0.0),
            rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))])


def test_ros2_names_and_cdr():
    assert dds_topic("/tf") == "rt/tf" and dds_topic("/arm/pose") == "rt/arm/pose"
    assert dds_type("tf2_msgs/TFMessage") == "tf2_msgs::msg::dds_::TFMessage_"
    store = _Store.store
    types = IdlTypes(store)
    cls = types.idl_class("tf2_msgs/msg/TFMessage")
    assert cls.__idl_typename__ == "tf2_msgs::msg::dds_::TFMessage_"
    data = bytes(store.serialize_cdr(tf_message(store, 7, 1.5), "tf2_msgs/msg/TFMessage"))
    sample = cls.deserialize(data)
    assert sample.transforms[0].child_frame_id == "base" and sample.transforms[0].header.stamp.sec == 7
    assert sample.serialize() == data        # the same CDR bytes as rosbags (and ROS 2 bags)
    for msgtype in ("visualization_msgs/msg/MarkerArray", "sensor_msgs/msg/PointCloud2", "std_msgs/msg/Empty"):
        message = _default(store, msgtype)
        data = bytes(store.serialize_cdr(message, msgtype))
        assert types.idl_class(msgtype).deserialize(data).serialize() == data


def _default(store, msgtype):
    """A message of `msgtype` with every field at its zero value."""
    import numpy

    _, fields = store.fielddefs[msgtype]
    values = {}
    for name, (kind, detail) in fields:
        if kind == 1:
            values[name] = {"string": "", "bool": False}.get(detail[0], 0.0 if detail[0].startswith("float") else 0)
        elif kind == 2:
            values[name] = _default(store, detail)
        elif kind == 3:
            inner, size = detail
            values[name] = numpy.zeros(size, dtype=numpy.float64) if inner[0] == 1 else [
                _default(store, inner[1]) for _ in range(size)]
        else:
            values[name] = numpy.zeros(0, dtype=numpy.uint8) if detail[0][0] == 1 else []
    return store.types[msgtype](**values)


def test_two_components_over_dds(tmp_path):
    domain = random.randrange(100, 230)
    env = retalisc_env({"ROS_DOMAIN_ID": str(domain)})
    env.pop("CYCLONEDDS_URI", None)
    store = _Store.store
    publisher = DdsTransport(domain)
    collector = _Collector()
    publisher.start(collector)
    processes = Processes(tmp_path)
    try:
        publisher.subscribe("/pos", "geometry_msgs/Vector3")          # the first's output, and its numbers
        publisher.subscribe("/pos/seq", "std_msgs/UInt64")
        publisher.advertise("/tf_static", "tf2_msgs/TFMessage")
        publisher.publish("/tf_static", "tf2_msgs/TFMessage",
                          bytes(store.serialize_cdr(tf_message(store, 50, -5.0, "static"), "tf2_msgs/msg/TFMessage")))
        _, writer, _ = publisher.advertise("/tf", "tf2_msgs/TFMessage")
        second = processes.start("second", retalisc_argv(sys.executable, "ros2", str(LIVE / "dds_second.rtl"),
                                                         "--config", str(LIVE / "second.xml"), "--out", "-"), env)
        first = processes.start("first", retalisc_argv(sys.executable, "ros2", str(LIVE / "dds_first.rtl"),
                                                       "--config", str(LIVE / "first.xml"), "--out",
                                                       str(tmp_path / "first.jsonl"), "--state", str(tmp_path / "state"),
                                                       "--snapshot-every", "2"), env)     # snapshots wait for acks
        processes.wait_for_line(second, "ros2: DDS domain")
        processes.wait_for_line(first, "ros2: DDS domain")
        deadline = time.monotonic() + 20
        while not writer.get_matched_subscriptions() and time.monotonic() < deadline:
            time.sleep(0.05)

        def seen():
            return [json.loads(line)["event"] for line in processes.out("second").splitlines()]

        stamp = 100
        while not any(event == "seen(0.0)" for event in seen()) and time.monotonic() < deadline:
            publisher.publish("/tf", "tf2_msgs/TFMessage",       # until the chain is connected
                              bytes(store.serialize_cdr(tf_message(store, stamp, 0.0), "tf2_msgs/msg/TFMessage")))
            stamp += 1
            time.sleep(0.2)
        for i in range(1, 6):
            publisher.publish("/tf", "tf2_msgs/TFMessage",
                              bytes(store.serialize_cdr(tf_message(store, 200 + i, float(i)), "tf2_msgs/msg/TFMessage")))
            time.sleep(0.01)
        while len([e for e in seen() if e not in ("seen(0.0)", "seen(-5.0)")]) < 5 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert first.poll() is None and second.poll() is None
    finally:
        processes.stop_all()
        publisher.close()
    events = seen()
    assert [e for e in events if e not in ("seen(0.0)", "seen(-5.0)")] == [f"seen({i}.0)" for i in range(1, 6)]
    first_out = [json.loads(line) for line in (tmp_path / "first.jsonl").read_text().splitlines()]
    # the last snapshot counted the subscribers of the outputs (a restart waits for them)
    last = sorted((tmp_path / "state").glob("snapshot-*.json"))[-1]
    assert json.loads(last.read_text())["node"]["subscribers"] == {"/pos": 2, "/pos/seq": 1}
    # tf_static, published before the first component started, reached it (transient local)
    assert first_out[0]["event"] == "geometry_msgs__0__Vector3(-5.0,0.0,0.0)" and first_out[0]["start"] == 50
    assert [line["start"] for line in first_out][-5:] == [201, 202, 203, 204, 205]    # header stamps
    assert "ros2: " in processes.err("first") and "0 rejected, 0 errors" in processes.err("first")
    # each message on /pos came with its output number on /pos/seq: its output's line. The
    # first outputs (tf_static, the connection tries) may come while discovery has matched
    # only one of the two readers: the five tf sent once the chain was up are compared
    numbers = [store.deserialize_cdr(data, "std_msgs/msg/UInt64").data for data in collector.received["/pos/seq"]]
    xs = [store.deserialize_cdr(data, "geometry_msgs/msg/Vector3").x for data in collector.received["/pos"]]
    lines = [i + 1 for i, line in enumerate(first_out) if line.get("consumer") == "pos"]
    assert numbers == lines[len(lines) - len(numbers):] and xs[-5:] == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert [f"geometry_msgs__0__Vector3({x},0.0,0.0)" for x in xs[-5:]] == [first_out[n - 1]["event"] for n in numbers[-5:]]
