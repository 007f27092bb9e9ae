"""`--state DIR` for the live nodes (docs/recovery.md): a node that crashes (its consumer
thread stops, no last snapshot, the files as the operating system has them) and is started
again with the same DIR ends with the output file, the memory and the published messages of
a node that never stopped. No middleware: an in-process transport."""
from __future__ import annotations

import io
import subprocess
import sys

import pytest

pytest.importorskip("rosbags", reason="the live tests need rosbags")

from live_support import ROOT, retalisc_env  # noqa: E402
from retalisc.driver.engine import Engine  # noqa: E402
from retalisc.live.config import parse_config  # noqa: E402
from retalisc.live.node import _STOP, LiveNode, Reply, Transport  # noqa: E402
from retalisc.live.state import LiveState  # noqa: E402
from retalisc.robot_io.bags import typestore  # noqa: E402

PROGRAM = """
pos(X) <- geometry_msgs__0__PointStamped(_, geometry_msgs__0__Point(X, _, _)).
up(X, Y) <- pos(X) seq pos(Y) where Y > X + 2.
memorize(pos(X), [], p(X), points, 4).
"""
CONFIG = ("<publish_subscribe><subscribe_to name='/p' msg_type='geometry_msgs/PointStamped'/>"
          "<publish_to name='out' msg_type='geometry_msgs/Point'/></publish_subscribe>")
XS = [1.0, 5.0, 2.0, 7.0, 3.0, 0.5, 9.0, 4.0, 6.0, 8.0, 2.5, 10.0, 1.5, 11.0]
CALL_AT = 4          # the service request comes before this event


class FakeTransport(Transport):
    name = "fake"

    def __init__(self, wire):
        self.wire = wire
        self.subscribed, self.published = {}, []

    def start(self, node):
        self.node = node

    def subscribe(self, topic, msgtype):
        self.subscribed[topic] = msgtype

    def unsubscribe(self, topic):
        return self.subscribed.pop(topic, None) is not None

    def publish(self, topic, msgtype, data):
        self.published.append((topic, bytes(data)))


def message(wire: str, x: float, second: int) -> bytes:
    store = typestore("ros1_noetic" if wire == "ros1" else "ros2_humble")
    types = store.types
    stamp = types["builtin_interfaces/msg/Time"](sec=second, nanosec=0)
    header = (types["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="f") if wire == "ros1"
              else types["std_msgs/msg/Header"](stamp=stamp, frame_id="f"))
    msg = types["geometry_msgs/msg/PointStamped"](header=header, point=types["geometry_msgs/msg/Point"](x=x, y=0.0, z=0.0))
    name = "geometry_msgs/msg/PointStamped"
    return bytes(store.serialize_ros1(msg, name) if wire == "ros1" else store.serialize_cdr(msg, name))


def node_for(wire, state=None, out=None):
    transport = FakeTransport(wire)
    node = LiveNode(Engine.from_source(PROGRAM, "live.rtl"), transport, parse_config(CONFIG), out=out,
                    log=lambda text: None, state=state)
    node.start()
    return node, transport


def feed(node, indices, wire):
    for i in indices:
        if i == CALL_AT:
            assert node.add_output_subscription("out", "", "pos(X)", "[X > 4]",
                                                "geometry_msgs__0__Point(X, 0.0, 0.0)").ok
        node.arrived("/p", message(wire, XS[i], 10 + i))
        node.call(lambda: Reply(True))     # each event fed alone: the snapshots come every 3 events


def memory(node):
    return [answer["X"] for answer in node.query("mem(points, p(X))", "", all_answers=True).value]


def crash(node):
    """The process dies: the consumer stops after what it took, no last snapshot is written,
    nothing is closed (the journal and output were flushed to the operating system)."""
    node._queue.put(_STOP)
    node._thread.join(10)


@pytest.mark.parametrize("wire, crash_after", [("cdr", 2), ("cdr", 5), ("ros1", 5), ("ros1", 11)])
def test_a_crashed_node_restarted_gives_the_uninterrupted_output(tmp_path, wire, crash_after):
    reference_out = io.StringIO()
    reference, reference_transport = node_for(wire, out=reference_out)
    feed(reference, range(len(XS)), wire)
    expected_memory = memory(reference)
    reference.close()
    expected = reference_out.getvalue()
    assert "up(" in expected and len(reference_transport.published) >= 4

    out = tmp_path / "out.jsonl"
    state = lambda: LiveState(tmp_path / "state", str(out), snapshot_events=3, snapshot_seconds=float("inf"),
                              log=lambda text: None)
    first, first_transport = node_for(wire, state=state())
    feed(first, range(crash_after), wire)
    crash(first)
    assert out.read_text() != expected

    restored = state()
    second, second_transport = node_for(wire, state=restored)
    assert restored.restored is not None
    assert restored.replayed == (crash_after % 3, 1 if crash_after < 6 else 0)   # the config subscription, the request
    assert second_transport.subscribed == {"/p": "geometry_msgs/PointStamped"}
    feed(second, range(crash_after, len(XS)), wire)
    assert memory(second) == expected_memory
    second.close()
    assert out.read_text() == expected
    # the topic is at-least-once: the restart publishes again what came after the snapshot
    before, after = first_transport.published, second_transport.published
    assert any(before[:j] + after == reference_transport.published for j in range(len(before) + 1))


def test_a_clean_stop_and_two_restarts(tmp_path):
    reference_out = io.StringIO()
    reference, _ = node_for("cdr", out=reference_out)
    feed(reference, range(len(XS)), "cdr")
    reference.close()
    out = tmp_path / "out.jsonl"
    for part in (range(0, 4), range(4, 9), range(9, len(XS))):
        node, _ = node_for("cdr", state=LiveState(tmp_path / "state", str(out), log=lambda text: None))
        feed(node, part, "cdr")
        node.close()                       # the last snapshot: nothing to replay next time
    assert out.read_text() == reference_out.getvalue()


def test_state_refuses_standard_output(tmp_path):
    program = tmp_path / "p.rtl"
    program.write_text(PROGRAM)
    result = subprocess.run([sys.executable, "-m", "retalisc", "ros2", str(program), "--state", str(tmp_path / "s"),
                             "--out", "-", "--duration", "1"], capture_output=True, text=True, cwd=ROOT,
                            env=retalisc_env(), timeout=60)
    assert result.returncode == 2 and "--state" in result.stderr and "Traceback" not in result.stderr


def test_state_of_another_program_is_refused(tmp_path):
    out = tmp_path / "out.jsonl"
    node, _ = node_for("cdr", state=LiveState(tmp_path / "state", str(out), log=lambda text: None))
    feed(node, range(3), "cdr")
    node.close()
    before = sorted(path.name for path in (tmp_path / "state").iterdir())
    program = tmp_path / "other.rtl"
    program.write_text("q(X) <- geometry_msgs__0__PointStamped(X, _).\n")
    result = subprocess.run([sys.executable, "-m", "retalisc", "ros2", str(program), "--state", str(tmp_path / "state"),
                             "--out", str(out), "--duration", "1"], capture_output=True, text=True, cwd=ROOT,
                            env=retalisc_env(), timeout=60)
    assert result.returncode == 2, result.stderr
    assert "another program" in result.stderr and "Traceback" not in result.stderr
    assert sorted(path.name for path in (tmp_path / "state").iterdir()) == before
