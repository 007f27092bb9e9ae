"""Two retalisc components over Zenoh (peers, multicast scouting off, explicit loopback
endpoints): the first turns tf into deliveries on /pos, the second consumes them; the second
stops and starts again and is back without restarting the first. Processes are stopped by
their pid at the end."""
from __future__ import annotations

import json
import sys
import time

import pytest

zenoh = pytest.importorskip("zenoh", reason="the Zenoh tests need the 'live' extra (eclipse-zenoh)")
pytest.importorskip("rosbags", reason="the Zenoh tests need rosbags")

from live_support import LIVE, Processes, free_port, retalisc_argv, retalisc_env, tf_message  # noqa: E402
from retalisc.live.zenoh_transport import peer_config, zenoh_key  # noqa: E402
from retalisc.robot_io.bags import typestore  # noqa: E402


def test_zenoh_keys():
    assert zenoh_key("/tf") == "tf" and zenoh_key("/arm/pose") == "arm/pose"


def test_two_components_over_zenoh_and_a_restart(tmp_path):
    store = typestore("ros2_humble")
    first_port, second_port = free_port(), free_port()
    first_at, second_at = f"tcp/127.0.0.1:{first_port}", f"tcp/127.0.0.1:{second_port}"
    env = retalisc_env()
    processes = Processes(tmp_path)
    session = zenoh.open(peer_config([], [first_at]))
    publisher = session.declare_publisher("tf")
    numbered = []            # (the attachment: the output number, x) of what the first publishes on pos
    listener = session.declare_subscriber("pos", lambda sample: numbered.append((
        int.from_bytes(sample.attachment.to_bytes(), "little"),
        store.deserialize_cdr(sample.payload.to_bytes(), "geometry_msgs/msg/Vector3").x)))

    def second_component(name):
        return processes.start(name, retalisc_argv(sys.executable, "zenoh", str(LIVE / "dds_second.rtl"), "--config",
                                                   str(LIVE / "second.xml"), "--out", "-", "--listen", second_at,
                                                   "--connect", first_at), env)

    def seen(name):
        return [json.loads(line)["event"] for line in processes.out(name).splitlines()]

    def send_until(name, x, stamp, timeout=20.0):
        """Publish tf until `name` has seen x (the chain is connected), then 1..3 after it."""
        deadline = time.monotonic() + timeout
        while f"seen({x})" not in seen(name) and time.monotonic() < deadline:
            publisher.put(bytes(store.serialize_cdr(tf_message(store, stamp, x), "tf2_msgs/msg/TFMessage")))
            time.sleep(0.1)
        for i in range(1, 4):
            publisher.put(bytes(store.serialize_cdr(tf_message(store, stamp + i, x + i), "tf2_msgs/msg/TFMessage")))
        while len(seen(name)) < 1 or seen(name)[-1] != f"seen({x + 3})":
            if time.monotonic() > deadline:
                break
            time.sleep(0.05)

    try:
        first = processes.start("first", retalisc_argv(sys.executable, "zenoh", str(LIVE / "dds_first.rtl"),
                                                       "--config", str(LIVE / "first.xml"), "--out",
                                                       str(tmp_path / "first.jsonl"), "--state", str(tmp_path / "state"),
                                                       "--snapshot-every", "2",
                                                       "--listen", first_at, "--connect", second_at), env)
        second = second_component("second")
        processes.wait_for_line(first, "zenoh: peer")
        processes.wait_for_line(second, "zenoh: peer")
        send_until("second", 10.0, 100)
        assert processes.stop(second) == 0
        again = second_component("again")
        processes.wait_for_line(again, "zenoh: peer")
        send_until("again", 20.0, 200)
        assert first.poll() is None
    finally:
        processes.stop_all()
        listener.undeclare()
        publisher.undeclare()
        session.close()
    assert [e for e in seen("second") if e != "seen(10.0)"] == ["seen(11.0)", "seen(12.0)", "seen(13.0)"]
    assert [e for e in seen("again") if e != "seen(20.0)"] == ["seen(21.0)", "seen(22.0)", "seen(23.0)"]
    assert "zenoh: " in processes.err("first") and "0 rejected, 0 errors" in processes.err("first")
    # each sample's attachment is its output's line in the first component's output
    lines = [json.loads(line) for line in (tmp_path / "first.jsonl").read_text().splitlines()]
    last = sorted((tmp_path / "state").glob("snapshot-*.json"))[-1]     # some subscribers of /pos
    assert json.loads(last.read_text())["node"]["subscribers"] == {"/pos": 1}
    # a snapshot keeps the messages of the last second (published again on restart): each as published
    for manifest in sorted((tmp_path / "state").glob("snapshot-*.json")):
        for seq, topic, msgtype, data, how in json.loads(manifest.read_text())["node"]["tail"]:
            assert topic == "/pos" and how == "attachment" and lines[seq - 1]["consumer"] == "pos", manifest
    assert numbered and len(numbered) <= len(lines)
    for number, x in numbered:
        line = lines[number - 1]
        assert line["consumer"] == "pos" and line["event"] == f"geometry_msgs__0__Vector3({x},0.0,0.0)", line
    assert [number for number, _ in numbered] == sorted({number for number, _ in numbered})
