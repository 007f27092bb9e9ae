"""The driver of the live part of benchmarks/robot_io.py: publishes TFMessages of 3
transforms to a running component over ROS 1, ROS 2 (rclpy) or Zenoh, receives the component's
deliveries (one geometry_msgs/Vector3 per message, derived from its first transform, whose
x is the message's number) and prints one JSON object:

- `latency`: at RATE messages/s for SECONDS (the thesis's load: 633.3 messages of 3
  transforms = 1,900 transforms/s), the time from publishing a message to receiving its
  delivery, p50 and p99, and the component's CPU share (its process CPU time over the wall
  time of the phase, from /proc/PID/stat);
- `throughput`: COUNT messages published as fast as the driver can, the time until the last
  delivery, messages and transforms per second, and how many were lost.

    python live_driver.py ros1|ros2|zenoh NODE_PID RATE SECONDS COUNT [ENDPOINT]

ROS 1 needs the Python of .venv-ros, ROS 2 that of .venv-ros2; Zenoh runs with the project's.
"""
from __future__ import annotations

import json
import os
import struct
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from retalisc.robot_io.bags import typestore  # noqa: E402

FRAMES = [("odom", "base_link"), ("base_link", "torso"), ("torso", "Neck")]


def messages(store, count: int, ros1: bool):
    T = store.types
    out = []
    for k in range(count):
        sec, nsec = 1_700_000_000 + k // 1000, (k % 1000) * 1_000_000
        transforms = []
        for i, (parent, child) in enumerate(FRAMES):
            header = (T["std_msgs/msg/Header"](seq=k, stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
                                               frame_id=parent) if ros1 else
                      T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
                                               frame_id=parent))
            transforms.append(T["geometry_msgs/msg/TransformStamped"](
                header=header, child_frame_id=child,
                transform=T["geometry_msgs/msg/Transform"](
                    translation=T["geometry_msgs/msg/Vector3"](x=float(k) if i == 0 else 0.1 * i, y=0.0, z=0.5),
                    rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))))
        msg = T["tf2_msgs/msg/TFMessage"](transforms=transforms)
        data = store.serialize_ros1(msg, "tf2_msgs/msg/TFMessage") if ros1 else \
            store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage")
        out.append(bytes(data))
    return out


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Channel:
    """publish(bytes) to /tf; deliveries of /out go to on_x(x, receive_time)."""

    def __init__(self, kind: str, endpoint: str, on_x):
        self.kind = kind
        if kind == "ros1":
            import rospy

            from retalisc.live.ros1 import raw_message_class
            store = typestore("ros1_noetic")
            text, md5 = store.generate_msgdef("tf2_msgs/msg/TFMessage", ros_version=1)
            rospy.init_node("retalisc_bench_driver", anonymous=True, disable_signals=True)
            self.cls = raw_message_class("tf2_msgs/TFMessage", md5, text)
            self.pub = rospy.Publisher("/tf", self.cls, queue_size=None, tcp_nodelay=True)
            self.sub = rospy.Subscriber("/out", rospy.AnyMsg,
                                        lambda m: on_x(struct.unpack_from("<d", m._buff, 0)[0], time.perf_counter()),
                                        queue_size=None, tcp_nodelay=True)
            self.ready = lambda: self.pub.get_num_connections() > 0 and self.sub.get_num_connections() > 0
        elif kind == "ros2":          # rclpy (.venv-ros2): CDR bytes both ways
            import rclpy
            from geometry_msgs.msg import Vector3
            from tf2_msgs.msg import TFMessage

            rclpy.init()
            self.node = rclpy.create_node("retalisc_bench_driver")
            from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

            self.pub = self.node.create_publisher(TFMessage, "/tf", QoSProfile(
                history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE))
            self.sub = self.node.create_subscription(
                Vector3, "/out", lambda data: on_x(struct.unpack_from("<d", data, 4)[0], time.perf_counter()),
                QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE), raw=True)
            threading.Thread(target=rclpy.spin, args=(self.node,), daemon=True).start()
            self.ready = lambda: self.pub.get_subscription_count() > 0 and self.node.count_publishers("/out") > 0
        else:
            import zenoh

            from retalisc.live.zenoh_transport import peer_config
            self.session = zenoh.open(peer_config([], [endpoint]))
            self.pub = self.session.declare_publisher("tf", congestion_control=zenoh.CongestionControl.BLOCK)
            self.sub = self.session.declare_subscriber(
                "out", lambda s: on_x(struct.unpack_from("<d", s.payload.to_bytes(), 4)[0], time.perf_counter()))
            self.ready = lambda: True

    def publish(self, data: bytes) -> None:
        if self.kind == "ros1":
            message = self.cls()
            message._buff = data
            self.pub.publish(message)
        elif self.kind == "ros2":
            self.pub.publish(data)
        else:
            self.pub.put(data)


def main() -> None:
    kind, pid, rate, seconds, count = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), \
        int(sys.argv[5])
    endpoint = sys.argv[6] if len(sys.argv) > 6 else ""
    load_count = int(rate * seconds)
    warm = 2000
    data = messages(typestore("ros1_noetic" if kind == "ros1" else "ros2_humble"), warm + load_count + count,
                    kind == "ros1")
    received = {}
    lock = threading.Lock()
    arrived = threading.Condition(lock)

    def on_x(x, at):
        with arrived:
            received[int(x)] = at
            arrived.notify_all()

    channel = Channel(kind, endpoint, on_x)
    deadline = time.monotonic() + 30
    while not channel.ready() and time.monotonic() < deadline:
        time.sleep(0.05)
    # warm up until deliveries come back (the chain is connected)
    k = 0
    while not received and time.monotonic() < deadline:
        channel.publish(data[k])
        k += 1
        time.sleep(0.05)
    time.sleep(0.5)
    first = warm
    sent = {}
    cpu0, began = cpu_seconds(pid), time.perf_counter()
    for i in range(load_count):
        due = began + i / rate
        while True:
            now = time.perf_counter()
            if now >= due:
                break
            time.sleep(min(due - now, 0.0005))
        sent[first + i] = time.perf_counter()
        channel.publish(data[first + i])
    wall = time.perf_counter() - began
    cpu = cpu_seconds(pid) - cpu0
    wait_until = time.monotonic() + 10
    with arrived:
        while sum(1 for key in sent if key in received) < load_count and time.monotonic() < wait_until:
            arrived.wait(0.1)
    latencies = sorted(received[key] - sent[key] for key in sent if key in received)

    def quantile(q):
        return latencies[min(len(latencies) - 1, int(len(latencies) * q))] if latencies else None

    # the messages later than 20 ms: how many, and in how many stalls (runs of late messages
    # less than 50 ms apart by their sending time): a few long stalls or many short delays
    late = sorted(sent[key] for key in sent if key in received and received[key] - sent[key] > 0.020)
    stalls = sum(1 for i, at in enumerate(late) if i == 0 or at - late[i - 1] > 0.050)
    result = {"latency": {"messages": load_count, "received": len(latencies), "rate": rate, "seconds": wall,
                          "p50": quantile(0.5), "p90": quantile(0.9), "p99": quantile(0.99),
                          "max": latencies[-1] if latencies else None, "over_20ms": len(late), "stalls": stalls,
                          "cpu": cpu, "cpu_share": cpu / wall}}
    first = warm + load_count
    began = time.perf_counter()
    cpu0 = cpu_seconds(pid)
    for i in range(count):
        channel.publish(data[first + i])
    published = time.perf_counter() - began
    wait_until = time.monotonic() + 120
    with arrived:
        while first + count - 1 not in received and time.monotonic() < wait_until:
            arrived.wait(0.1)
        time.sleep(0.2)
        got = [received[first + i] for i in range(count) if first + i in received]
    elapsed = (max(got) - began) if got else float("nan")
    result["throughput"] = {"messages": count, "received": len(got), "lost": count - len(got),
                            "publish_seconds": published, "seconds": elapsed,
                            "messages_per_s": len(got) / elapsed if got else 0.0,
                            "transforms_per_s": 3 * len(got) / elapsed if got else 0.0,
                            "cpu": cpu_seconds(pid) - cpu0}
    print(json.dumps(result))
    sys.stdout.flush()
    os._exit(0)          # middleware threads need not be waited for


if __name__ == "__main__":
    main()
