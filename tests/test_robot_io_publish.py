"""Derived events back into the robot's tools (retalisc/robot_io/publish.py): `--out-bag`
MCAP files read back with `mcap` and `rosbags`, and the live Foxglove server received by a
WebSocket client on loopback."""
from __future__ import annotations

import base64
import json
import os
import socket
import struct
import threading
import time
from collections import Counter

import pytest

from robot_io_support import ROOT

from retalisc.driver.engine import Engine  # noqa: E402
from retalisc.robot_io.bags import typestore  # noqa: E402
from retalisc.robot_io.messages import MessageConverter  # noqa: E402
from retalisc.robot_io.replay import BagOptions, replay_bag  # noqa: E402
from retalisc.robot_io.samples import write_nao_bag  # noqa: E402

NAO = ROOT / "examples" / "nao_markers" / "nao_markers.rtl"


@pytest.fixture(scope="module")
def nao_ros2(tmp_path_factory):
    return write_nao_bag(tmp_path_factory.mktemp("bags") / "nao", "ros2", seconds=2.0)


def _nao_engine(echo: bool) -> Engine:
    engine = Engine.load(NAO)
    engine.set_flag("echo_input", "true" if echo else "false")
    return engine


@pytest.mark.parametrize("echo", [False, True])
def test_out_bag_holds_inputs_and_derived_events_and_reads_back(nao_ros2, tmp_path, echo):
    mcap_reader = pytest.importorskip("mcap.reader")
    from rosbags.highlevel import AnyReader

    out = tmp_path / "out.jsonl"
    mcap = tmp_path / "derived.mcap"
    assert replay_bag(_nao_engine(echo), str(nao_ros2), str(out), BagOptions(), out_bag=str(mcap)) == 0
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    poses = [x for x in lines if x["event"].startswith("marker_pose(") and "consumer" not in x]     # derived
    deliveries = Counter(x["consumer"] for x in lines if "consumer" in x)
    others = [x for x in lines if "consumer" not in x and not x["event"].startswith(("geometry_msgs__0__PoseStamped(",
                                                                                     "tf2_msgs", "ar_pose__0__",
                                                                                     "visualization_msgs"))]

    topics, by_topic = Counter(), {}
    with open(mcap, "rb") as stream:
        for schema, channel, message in mcap_reader.make_reader(stream).iter_messages():
            topics[channel.topic] += 1
            by_topic.setdefault(channel.topic, []).append((schema, channel, message))
    inputs = {"/tf": 100, "/robot_pose": 20, "/markers_viz": 4}
    for topic, count in inputs.items():
        assert topics[topic] == count                        # every input once, echoed or not
    assert topics["/ar_pose_marker"] > 5
    # marker_pose(Marker, PoseStamped) is not a message: on /retalis/events; its PoseStamped, in
    # odom, goes to the marker's consumer
    assert topics["/retalis/geometry_msgs/PoseStamped"] == 0
    assert topics["/marker1"] == deliveries["marker1"] and topics["/marker2"] == deliveries["marker2"]
    assert topics["/marker1"] + topics["/marker2"] == len(poses) > 5
    assert topics["/retalis/events"] == len(others) > 5     # seen_again/1 (and the raised tf/4, ar_marker/3 with echo)
    schema, channel, message = by_topic["/marker1"][0]
    assert (channel.message_encoding, schema.name, schema.encoding) == ("cdr", "geometry_msgs/msg/PoseStamped", "ros2msg")
    assert typestore("ros2_humble").deserialize_cdr(message.data, "geometry_msgs/msg/PoseStamped").header.frame_id == "odom"
    first = next(x for x in lines if x.get("consumer") == "marker1")
    assert message.log_time == round(first["end"] * 1e9)
    schema, channel, message = next(m for m in by_topic["/retalis/events"]
                                    if json.loads(m[2].data)["name"] == "seen_again")
    payload = json.loads(message.data)
    assert channel.message_encoding == "json" and "jsonschema" in channel.metadata
    assert payload["args"] in (["4x4_1"], ["4x4_2"]) and payload["end"] > payload["start"]

    with AnyReader([mcap]) as reader:
        connections = [c for c in reader.connections if c.msgtype != "__schemaless__"]
        counts = Counter()
        converter = MessageConverter(reader.typestore)
        for connection, time_ns, raw in reader.messages(connections=connections):
            msg = reader.deserialize(raw, connection.msgtype)
            counts[connection.topic] += 1
            if connection.topic == "/marker1" and counts["/marker1"] == 1:
                assert converter.term(msg, connection.msgtype) == first["event"]
    assert counts == Counter({t: n for t, n in topics.items() if t != "/retalis/events"})


class _WebSocket:
    """The smallest WebSocket client that speaks to a Foxglove server (RFC 6455 frames)."""

    def __init__(self, port: int, timeout: float = 10.0):
        deadline = time.monotonic() + timeout
        while True:
            try:
                self.sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                           f"Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n").encode())
        response = b""
        while b"\r\n\r\n" not in response:
            response += self.sock.recv(4096)
        head, _, self.buffer = response.partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 101"), head

    def _read(self, n: int) -> bytes:
        while len(self.buffer) < n:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("closed")
            self.buffer += chunk
        data, self.buffer = self.buffer[:n], self.buffer[n:]
        return data

    def receive(self):
        """(opcode, payload) of the next message."""
        first, second = self._read(2)
        opcode, length = first & 0x0F, second & 0x7F
        if length == 126:
            length = struct.unpack(">H", self._read(2))[0]
        elif length == 127:
            length = struct.unpack(">Q", self._read(8))[0]
        payload = self._read(length)
        if opcode == 9:
            self._send(0xA, payload)
            return self.receive()
        return opcode, payload

    def send_json(self, value) -> None:
        self._send(0x1, json.dumps(value).encode())

    def _send(self, opcode: int, payload: bytes) -> None:
        mask = os.urandom(4)
        header = bytes([0x80 | opcode])
        if len(payload) < 126:
            header += bytes([0x80 | len(payload)])
        else:
            header += bytes([0x80 | 126]) + struct.pack(">H", len(payload))
        self.sock.sendall(header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _collect(port: int, done: threading.Event, received: Counter, payloads: dict, errors: list) -> None:
    """A Foxglove client: subscribe to every channel advertised, collect the messages."""
    try:
        client = _WebSocket(port, timeout=20)
        client.sock.settimeout(0.5)
        channels, next_id = {}, 1
        while True:
            try:
                opcode, payload = client.receive()
            except (socket.timeout, ConnectionError):
                if done.is_set():
                    break
                continue
            if opcode == 1:
                message = json.loads(payload)
                if message.get("op") == "advertise":
                    subscriptions = []
                    for channel in message["channels"]:
                        channels[next_id] = channel
                        subscriptions.append({"id": next_id, "channelId": channel["id"]})
                        next_id += 1
                    client.send_json({"op": "subscribe", "subscriptions": subscriptions})
                elif message.get("op") == "status" and "Unknown channel ID" in message.get("message", ""):
                    # foxglove-sdk advertises a channel a moment before it accepts subscriptions
                    unknown = int(message["message"].rsplit(":", 1)[1])
                    time.sleep(0.02)
                    client.send_json({"op": "subscribe", "subscriptions": [
                        {"id": sid, "channelId": unknown} for sid, c in channels.items() if c["id"] == unknown]})
            elif opcode == 2 and payload[0] == 1:
                subscription, log_time = struct.unpack_from("<IQ", payload, 1)
                topic = channels[subscription]["topic"]
                received[topic] += 1
                payloads.setdefault(topic, []).append((log_time, payload[13:]))
        client.sock.close()
    except Exception as error:      # reported by the test
        errors.append(error)


def test_foxglove_server_sends_inputs_and_derived_events_to_a_loopback_client(nao_ros2, capfd):
    pytest.importorskip("foxglove", reason="--foxglove needs foxglove-sdk")
    port = _free_port()
    engine = _nao_engine(False)         # the engine stays in this thread; the client runs beside it
    done, received, payloads, errors = threading.Event(), Counter(), {}, []
    client = threading.Thread(target=_collect, args=(port, done, received, payloads, errors), daemon=True)
    client.start()
    try:
        status = replay_bag(engine, str(nao_ros2), None, BagOptions(rate=8.0), foxglove=port, foxglove_wait=20)
    finally:
        done.set()
        client.join(10)
    assert status == 0 and not errors
    assert received["/tf"] == 100 and received["/robot_pose"] == 20
    poses = [data for _, data in payloads["/retalis/events"] if json.loads(data)["name"] == "marker_pose"]
    assert received["/marker1"] + received["/marker2"] == len(poses) > 5
    assert received["/retalis/geometry_msgs/PoseStamped"] == 0
    assert received["/retalis/events"] > 5
    store = typestore("ros2_humble")
    _, data = payloads["/marker1"][0]
    pose = store.deserialize_cdr(data, "geometry_msgs/msg/PoseStamped")
    assert pose.header.frame_id == "odom"
    assert {json.loads(data)["name"] for _, data in payloads["/retalis/events"]} == {"seen_again", "marker_pose"}
    assert f"waiting for a client on ws://127.0.0.1:{port}" in capfd.readouterr().err
