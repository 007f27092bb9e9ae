"""`--state DIR` for the live nodes (docs/recovery.md): a node that crashes (its consumer
thread stops, no last snapshot, the files as the operating system has them) and is started
again with the same DIR ends with the output file, the memory and the published messages of
a node that never stopped: a subscriber that drops the messages whose output number it has
seen gets exactly the uninterrupted node's messages. No middleware: an in-process transport."""
from __future__ import annotations

import io
import random
import subprocess
import sys
import time

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
          "<publish_to name='out' msg_type='geometry_msgs/Point'/>"
          "<publish_to name='stamped' msg_type='geometry_msgs/PointStamped'/></publish_subscribe>")
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


class Crash(BaseException):
    """The process dies inside a batch, after the batch was journaled."""


def feed(node, indices, wire, crash_in_feed=None):
    """Feed XS[i] for i in `indices`; with `crash_in_feed`, the consumer dies when it feeds
    that event (journaled, not processed) and nothing after it is sent."""
    for i in indices:
        if i == CALL_AT:
            assert node.add_output_subscription("out", "", "pos(X)", "[X > 4]",
                                                "geometry_msgs__0__Point(X, 0.0, 0.0)").ok
            assert node.add_output_subscription("stamped", "", "geometry_msgs__0__PointStamped(H, P)", "[]",
                                                "geometry_msgs__0__PointStamped(H, P)").ok
        if i == crash_in_feed:
            def die(batch):
                raise SystemExit()      # the thread ends silently, as the process would
            node.engine.feed_batch = die
            node.arrived("/p", message(wire, XS[i], 10 + i))
            node._thread.join(10)
            assert not node._thread.is_alive()
            return
        node.arrived("/p", message(wire, XS[i], 10 + i))
        node.call(lambda: Reply(True))     # each event fed alone: the snapshots come every 3 events


def numbered(published, wire):
    """(output number, topic, bytes) of each published message: the number is the message's
    header.seq (ROS 1, a type with a header) or the std_msgs/UInt64 on `<topic>/seq` that
    comes right before the message."""
    result, numbers = [], {}
    for topic, data in published:
        if topic.endswith("/seq"):
            assert topic[:-4] not in numbers
            numbers[topic[:-4]] = int.from_bytes(data[-8:], "little")     # after CDR's 4-byte header
        elif topic in numbers:
            result.append((numbers.pop(topic), topic, data))
        else:
            assert wire == "ros1" and topic == "/stamped"
            result.append((int.from_bytes(data[:4], "little"), topic, data))
    assert not numbers
    return result


def subscriber(published, wire):
    """What a subscriber keeps that drops each message whose number is not above the highest
    it has seen on that topic."""
    highest, kept = {}, []
    for number, topic, data in numbered(published, wire):
        if number > highest.get(topic, 0):
            highest[topic] = number
            kept.append((number, topic, data))
    return kept


def memory(node):
    return [answer["X"] for answer in node.query("mem(points, p(X))", "", all_answers=True).value]


def crash(node):
    """The process dies: the consumer stops after what it took, no last snapshot is written,
    nothing is closed (the journal and output were flushed to the operating system)."""
    node._queue.put(_STOP)
    node._thread.join(10)


_REFERENCES = {}


def reference_run(wire):
    """(output file, memory, published) of a node that never stopped."""
    if wire not in _REFERENCES:
        out = io.StringIO()
        node, transport = node_for(wire, out=out)
        feed(node, range(len(XS)), wire)
        expected_memory = memory(node)
        node.close()
        _REFERENCES[wire] = out.getvalue(), expected_memory, transport.published
    return _REFERENCES[wire]


@pytest.mark.parametrize("wire", ["cdr", "ros1"])
def test_published_messages_carry_their_output_number(wire):
    expected, _, published = reference_run(wire)
    lines = expected.splitlines()
    messages = numbered(published, wire)
    assert {topic for _, topic, _ in messages} == {"/out", "/stamped"}
    for number, topic, _ in messages:        # the number is the output's line in the output file
        assert f'"consumer":"{topic[1:]}"' in lines[number - 1].replace(" ", "")
    assert len(messages) == sum(1 for line in lines if '"consumer"' in line)
    assert [n for n, _, _ in messages] == sorted(n for n, _, _ in messages)
    if wire == "ros1":    # a type with a std_msgs/Header: header.seq, no companion topic
        assert not any(topic == "/stamped/seq" for topic, _ in published)


@pytest.mark.parametrize("wire, crash_after", [("cdr", 2), ("cdr", 5), ("ros1", 5), ("ros1", 11)])
def test_a_crashed_node_restarted_gives_the_uninterrupted_output(tmp_path, wire, crash_after):
    expected, expected_memory, reference_published = reference_run(wire)
    assert "up(" in expected and len(reference_published) >= 4

    out = tmp_path / "out.jsonl"
    def state():
        return LiveState(tmp_path / "state", str(out), snapshot_events=3, snapshot_seconds=float("inf"),
                         log=lambda text: None)
    first, first_transport = node_for(wire, state=state())
    feed(first, range(crash_after), wire)
    crash(first)
    assert out.read_text() != expected

    restored = state()
    second, second_transport = node_for(wire, state=restored)
    assert restored.restored is not None
    # replayed: the events after the snapshot and the config subscription (before the first) or the requests
    assert restored.replayed == (crash_after % 3, {2: 1, 5: 2, 11: 0}[crash_after])
    assert second_transport.subscribed == {"/p": "geometry_msgs/PointStamped"}
    feed(second, range(crash_after, len(XS)), wire)
    assert memory(second) == expected_memory
    second.close()
    assert out.read_text() == expected
    # the topic is at-least-once: the restart publishes again what came after the snapshot,
    # each message with the number (and bytes) it had; dropping repeats gives the reference
    before, after = first_transport.published, second_transport.published
    assert any(before[:j] + after == reference_published for j in range(len(before) + 1))
    repeated = set(numbered(before, wire)) & set(numbered(after, wire))
    assert repeated or crash_after % 3 == 0 or crash_after < CALL_AT
    assert subscriber(before + after, wire) == numbered(reference_published, wire)


@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")   # the consumer's death
@pytest.mark.parametrize("wire", ["cdr", "ros1"])
def test_seeded_random_crashes(tmp_path, wire):
    """Crashes at seeded random points, between two events or inside a batch (journaled, not
    fed), several per run, with snapshots every 1 to 4 events: the output file ends as the
    uninterrupted node's, and a subscriber dropping repeated numbers gets its messages."""
    expected, expected_memory, reference_published = reference_run(wire)
    modes = set()
    for seed in range(3):
        rng = random.Random(seed)
        every = rng.randint(1, 4)
        cuts = sorted(rng.sample(range(1, len(XS)), rng.randint(1, 3)))
        directory = tmp_path / f"{seed}"
        out = directory / "out.jsonl"
        published, start = [], 0
        for cut in cuts + [len(XS)]:
            node, transport = node_for(wire, state=LiveState(directory / "state", str(out), snapshot_events=every,
                                                             snapshot_seconds=float("inf"), log=lambda text: None))
            if cut == len(XS):
                feed(node, range(start, cut), wire)
                assert memory(node) == expected_memory, seed
                node.close()
            elif rng.random() < 0.5:
                modes.add("in a batch")
                feed(node, range(start, cut + 1), wire, crash_in_feed=cut)
                cut += 1                  # journaled before it died: the restart feeds it
            else:
                modes.add("between events")
                feed(node, range(start, cut), wire)
                crash(node)
            published += transport.published
            start = cut
        assert out.read_text() == expected, (seed, every, cuts)
        assert subscriber(published, wire) == numbered(reference_published, wire), (seed, every, cuts)
    assert modes == {"in a batch", "between events"}


def test_an_idle_node_takes_its_time_based_snapshot(tmp_path):
    """Nothing arrives after two events: the snapshot comes S seconds after the last one
    anyway, and a restart replays nothing."""
    out = tmp_path / "out.jsonl"
    state = LiveState(tmp_path / "state", str(out), snapshot_events=1000, snapshot_seconds=1.0, log=lambda text: None)
    node, _ = node_for("cdr", state=state)
    feed(node, range(2), "cdr")
    def snapshots():
        return sorted((tmp_path / "state").glob("snapshot-*.json"))
    first = snapshots()
    deadline = time.monotonic() + 5
    # (the file is written before the consumer thread marks the journal as taken in)
    while (snapshots() == first or state.journaled) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert snapshots() != first and not state.journaled
    last = snapshots()[-1]
    time.sleep(1.2)                # idle with nothing journaled since: no snapshot is needed
    assert snapshots()[-1] == last
    crash(node)
    restored = LiveState(tmp_path / "state", str(out), snapshot_events=1000, snapshot_seconds=1.0,
                         log=lambda text: None)
    again, _ = node_for("cdr", state=restored)
    assert restored.replayed == (0, 0)
    feed(again, range(2, len(XS)), "cdr")
    again.close()
    assert out.read_text() == reference_run("cdr")[0]


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


class HoldingTransport(FakeTransport):
    """A middleware like Zenoh: the number goes with the message (its attachment), and the
    session holds the last HELD messages put, handing one over only when more come after it;
    a crash loses what it holds, and its `flush` cannot wait for it."""

    HELD = 3
    attaches_seq = True
    flush_delivers = False

    def __init__(self, wire="cdr"):
        super().__init__(wire)
        self.held = []

    def publish(self, topic, msgtype, data, seq=None):
        assert seq is not None
        self.held.append((seq, topic, bytes(data)))
        while len(self.held) > self.HELD:
            self.published.append(self.held.pop(0))

    def close(self):                   # a clean stop hands over what the session held
        self.published += self.held
        self.held = []


def holding_node(state=None, out=None):
    transport = HoldingTransport()
    node = LiveNode(Engine.from_source(PROGRAM, "live.rtl"), transport, parse_config(CONFIG), out=out,
                    log=lambda text: None, state=state)
    node.start()
    return node, transport


def drop_repeats(messages):
    highest, kept = {}, []
    for number, topic, data in messages:
        if number > highest.get(topic, 0):
            highest[topic] = number
            kept.append((number, topic, data))
    return kept


@pytest.mark.parametrize("crash_after", [6, 12])
def test_outputs_held_by_the_middleware_at_a_crash_are_published_again(tmp_path, crash_after):
    """The node crashes right after a snapshot while the middleware still holds its last
    messages (lost with the process): the restart publishes the tail the snapshot kept (the
    messages of the last second) again, so the subscriber gets every output at least once
    and, dropping repeated numbers, exactly those of a node that never stopped."""
    reference, reference_transport = holding_node()
    feed(reference, range(len(XS)), "cdr")
    reference.close()
    expected = reference_transport.published
    assert [n for n, _, _ in expected] == sorted(n for n, _, _ in expected) and len(expected) >= 8

    out = tmp_path / "out.jsonl"
    def state():
        return LiveState(tmp_path / "state", str(out), snapshot_events=3, snapshot_seconds=float("inf"),
                         log=lambda text: None)
    first, first_transport = holding_node(state=state())
    feed(first, range(crash_after), "cdr")
    crash(first)                             # what the session held is gone
    lost = first_transport.held
    assert lost and not set(lost) & set(first_transport.published)

    restored = state()
    second, second_transport = holding_node(state=restored)
    assert restored.replayed == (0, 0)       # right after a snapshot: nothing to replay
    assert restored.republished >= len(lost)
    feed(second, range(crash_after, len(XS)), "cdr")
    second.close()
    received = first_transport.published + second_transport.published
    assert set(received) == set(expected)                 # every output at least once
    # the repeats: the tail's messages the middleware had handed over, each with its number and bytes
    assert len(received) == len(expected) + restored.republished - len(lost)
    assert drop_repeats(received) == expected


def test_the_tail_keeps_only_the_last_seconds(tmp_path, monkeypatch):
    """A snapshot keeps the publications of the last TAIL_SECONDS only (and at most
    TAIL_MESSAGES); a transport whose flush delivers keeps none."""
    from retalisc.live import state as state_module

    live = LiveState(tmp_path / "state", None, log=lambda text: None)
    clock = [1000.0]
    monkeypatch.setattr(state_module.time, "time", lambda: clock[0])
    live.published(1, "/a", "std_msgs/UInt64", b"x", "attachment")
    clock[0] += state_module.TAIL_SECONDS / 2
    live.published(2, "/a", "std_msgs/UInt64", b"y", "attachment")
    clock[0] += state_module.TAIL_SECONDS * 0.75
    assert [record[0] for record in live._tail_records()] == [2]
    assert live.tail.maxlen == state_module.TAIL_MESSAGES
    monkeypatch.undo()

    node, transport = node_for("cdr", state=LiveState(tmp_path / "other", None, log=lambda text: None))
    feed(node, range(len(XS)), "cdr")
    assert transport.published and not node.state.tail
    node.close()


def test_a_state_directory_another_process_holds_is_refused(tmp_path):
    """A node takes the lock of its state directory (recovery.StateDir.lock) before it restores:
    while another process holds it the node does not start and the directory is unchanged; the
    lock of a process killed with SIGKILL is gone."""
    from retalisc.driver.recovery import RecoveryError

    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from retalisc.driver.recovery import StateDir; "
         "StateDir(sys.argv[1]).lock(); print('locked', flush=True); time.sleep(120)", str(tmp_path / "state")],
        env=retalisc_env(), stdout=subprocess.PIPE)
    try:
        assert holder.stdout.readline() == b"locked\n"
        with pytest.raises(RecoveryError, match=f"in use by another process \\(pid {holder.pid}\\)"):
            node_for("cdr", state=LiveState(tmp_path / "state", str(tmp_path / "out.jsonl"), log=lambda text: None))
        assert sorted(p.name for p in (tmp_path / "state").iterdir()) == ["lock"]
    finally:
        holder.kill()
        holder.wait(30)
    node, _ = node_for("cdr", state=LiveState(tmp_path / "state", str(tmp_path / "out.jsonl"), log=lambda text: None))
    feed(node, range(3), "cdr")
    node.close()
    assert (tmp_path / "state" / "snapshot-00000000.json").exists()


def test_a_crafted_snapshot_is_refused_by_a_live_node(tmp_path):
    """A live node restores through recovery.restore_newest: a snapshot made to run the shell,
    its checksum made again, stops the start (RecoveryError, `--state` exits with status 2),
    restores nothing and runs nothing."""
    import hashlib
    import json

    from retalisc.driver.recovery import RecoveryError
    from test_recovery_crafted import craft, crafted_terms

    out = tmp_path / "out.jsonl"
    node, _ = node_for("cdr", state=LiveState(tmp_path / "state", str(out), log=lambda text: None))
    feed(node, range(3), "cdr")
    node.close()
    manifest_path = sorted((tmp_path / "state").glob("snapshot-*.json"))[-1]
    manifest = json.loads(manifest_path.read_text())
    snapshot = manifest_path.with_suffix(".state")
    module = snapshot.read_text(encoding="utf-8").split("\n", 1)[0].rsplit(",", 1)[1].rstrip(").")
    canary = tmp_path / "canary"
    craft(snapshot, crafted_terms(module, canary)["ele_trigger_clause"])
    manifest.update(sha256=hashlib.sha256(snapshot.read_bytes()).hexdigest(), state_bytes=snapshot.stat().st_size)
    manifest_path.write_text(json.dumps(manifest))
    with pytest.raises(RecoveryError, match="refused: .*clause of .*ele_trigger/3 with a body"):
        node_for("cdr", state=LiveState(tmp_path / "state", str(out), log=lambda text: None))
    assert not canary.exists()
