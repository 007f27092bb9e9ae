"""Bag replay (`retalisc run PROGRAM --bag FILE`, retalisc/robot_io/replay.py): the
repository's own sample recording in the three formats, every shared sample bag, the ROS 1 /
ROS 2 pairs, the options, and the thesis's NAO program placing markers in the world."""
from __future__ import annotations

import json
import os
import math
import re
import subprocess
import sys

import pytest

from robot_io_support import ROOT, ROS1_ROS2_PAIRS, SHARED_NAMES, shared_bag, without_seq

from retalisc.driver.bridge import PrologError  # noqa: E402
from retalisc.driver.engine import Engine  # noqa: E402
from retalisc.robot_io.bags import Recording  # noqa: E402
from retalisc.robot_io.messages import Convention, MessageConverter  # noqa: E402
from retalisc.robot_io.replay import PACED_AHEAD, RATE_TICK, BagOptions, replay_bag  # noqa: E402
from retalisc.robot_io.samples import TF_CHAIN, nao_records, sample_store, write_nao_bag  # noqa: E402

NAO_PROGRAM = ROOT / "examples" / "nao_markers" / "nao_markers.rtl"
FORMATS = ["ros1", "ros2", "mcap"]


@pytest.fixture(scope="module")
def nao_bags(tmp_path_factory):
    """The sample recording (3 s, tf at 50 Hz) in each format."""
    folder = tmp_path_factory.mktemp("bags")
    return {fmt: write_nao_bag(folder / ("nao.bag" if fmt == "ros1" else f"nao_{fmt}"), fmt, seconds=3.0)
            for fmt in FORMATS}


def replay(engine_or_source, bag, tmp_path, echo=False, batch_size=64, **options):
    if isinstance(engine_or_source, Engine):
        engine = engine_or_source
    else:
        engine = Engine.from_source(engine_or_source, "replayed.rtl")
    engine.set_flag("echo_input", "true" if echo else "false")
    out = tmp_path / "out.jsonl"
    status = replay_bag(engine, str(bag), str(out), BagOptions(**options), batch_size=batch_size)
    return status, [json.loads(line) for line in out.read_text().splitlines()]


# ---- the thesis's application on the sample recording --------------------------------------

def _yaw(q):
    return 2 * math.atan2(q[2], q[3])


def _world_pose(records, stamp_ns, relative):
    """Oracle: the chain of the five transforms at `stamp_ns` (linear interpolation of the
    translations and yaws between the samples around it; every rotation of the sample
    recording is about z), applied to the marker's pose relative to the camera."""
    samples = [(ns, msg) for _, msgtype, ns, msg in records if msgtype == "tf2_msgs/msg/TFMessage"]
    x, y, z, yaw = 0.0, 0.0, 0.0, 0.0
    for link in range(len(TF_CHAIN)):
        around = []
        for _, msg in samples:
            tr = msg.transforms[link]
            ns = tr.header.stamp.sec * 1_000_000_000 + tr.header.stamp.nanosec
            around.append((ns, tr.transform))
        before = max((s for s in around if s[0] <= stamp_ns), key=lambda s: s[0])
        after = min((s for s in around if s[0] > stamp_ns), key=lambda s: s[0])
        f = (stamp_ns - before[0]) / (after[0] - before[0])
        t1, t2 = before[1], after[1]
        v = [a + f * (b - a) for a, b in zip((t1.translation.x, t1.translation.y, t1.translation.z),
                                              (t2.translation.x, t2.translation.y, t2.translation.z))]
        r = _yaw((t1.rotation.x, t1.rotation.y, t1.rotation.z, t1.rotation.w))
        r += f * (_yaw((t2.rotation.x, t2.rotation.y, t2.rotation.z, t2.rotation.w)) - r)
        x, y, z = x + math.cos(yaw) * v[0] - math.sin(yaw) * v[1], y + math.sin(yaw) * v[0] + math.cos(yaw) * v[1], z + v[2]
        yaw += r
    rx, ry, rz = relative
    return x + math.cos(yaw) * rx - math.sin(yaw) * ry, y + math.sin(yaw) * rx + math.cos(yaw) * ry, z + rz


def test_nao_markers_are_placed_in_the_world_the_same_from_every_format(nao_bags, tmp_path):
    outputs = {}
    for fmt in FORMATS:
        status, lines = replay(Engine.load(NAO_PROGRAM), nao_bags[fmt], tmp_path)
        assert status == 0
        outputs[fmt] = lines
    assert outputs["ros1"] == outputs["ros2"] == outputs["mcap"]
    store = sample_store(2)
    records = nao_records(store, seconds=3.0)
    detections = [m for _, msgtype, _, m in records if msgtype == "ar_pose/msg/ARMarkers"]
    derived = [line for line in outputs["ros2"] if line["event"].startswith("marker_pose(") and "consumer" not in line]
    delivered = [line for line in outputs["ros2"] if line["event"].startswith("geometry_msgs__0__PoseStamped(")
                 and "consumer" in line]
    poses = derived + delivered
    again = [line for line in outputs["ros2"] if line["event"].startswith("seen_again(")]
    assert again and all(0 < line["end"] - line["start"] <= 0.5 for line in again)
    assert len(outputs["ros2"]) == len(poses) + len(again)
    # marker_pose(Marker, PoseStamped) and its PoseStamped's delivery are two events, each one
    # line (a delivery repeating its derived event is printed once: feed.once_per_delivery)
    assert len(detections) == len(derived) == len(delivered) > 10
    converter = MessageConverter(store)
    by_stamp = {}
    for message in detections:
        marker = message.markers[0]
        stamp = marker.header.stamp.sec * 1_000_000_000 + marker.header.stamp.nanosec
        position = marker.pose.pose.position
        by_stamp[stamp] = (marker.header.frame_id, (position.x, position.y, position.z))
    by_delivery = {line["event"]: line["consumer"] for line in delivered}
    for line in derived:
        marker, text = re.fullmatch(r"marker_pose\('([^']+)',(.*)\)", line["event"]).groups()
        msgtype, pose = converter.message(text)
        assert msgtype == "geometry_msgs/msg/PoseStamped"
        stamp = pose.header.stamp.sec * 1_000_000_000 + pose.header.stamp.nanosec
        name, relative = by_stamp[stamp]
        # in odom, the frame the pose is expressed in; the marker beside it
        assert marker == name and pose.header.frame_id == "odom" and abs(line["start"] - stamp / 1e9) < 1e-6
        assert by_delivery[text] == "marker" + marker.split("_")[1]
        expected = _world_pose(records, stamp, relative)
        got = (pose.pose.position.x, pose.pose.position.y, pose.pose.position.z)
        assert all(abs(a - b) < 1e-4 for a, b in zip(got, expected)), (got, expected)


# ---- input events: record order, options ------------------------------------------------------

def test_echo_input_gives_every_message_in_record_order(nao_bags, tmp_path):
    status, lines = replay("", nao_bags["mcap"], tmp_path, echo=True)
    assert status == 0
    with Recording(nao_bags["mcap"]) as bag:
        converter = MessageConverter(bag.typestore)
        expected = [converter.event(r.msg, r.msgtype, r.topic, r.time_ns) for r in bag.records()]
    assert [(line["event"], line["start"]) for line in lines] == expected
    markers = [line["start"] for line in lines if line["event"].startswith("ar_pose__0__ARMarkers")]
    assert markers != sorted(markers) or len(markers) < 2  # late detections stay late
    tf = [line["start"] for line in lines if line["event"].startswith("tf2_msgs")]
    assert len(tf) == 150 and lines[0]["start"] <= tf[0]


def test_topics_start_and_duration_select_by_record_time(nao_bags, tmp_path):
    status, lines = replay("", nao_bags["ros1"], tmp_path, echo=True, topics=["/tf", "/robot_pose"],
                           start=1.0, duration=0.5)
    assert status == 0
    records = nao_records(sample_store(1), seconds=3.0)
    first = records[0][2]
    chosen = [r for r in records if r[0] in ("/tf", "/robot_pose")
              and first + 1_000_000_000 <= r[2] < first + 1_500_000_000]
    assert len(lines) == len(chosen) == 25 + 5


def test_wrap_topic_plain_strings_and_record_stamps(nao_bags, tmp_path):
    status, lines = replay("", nao_bags["ros2"], tmp_path, echo=True, topics=["/robot_pose"], duration=0.15,
                           convention=Convention(plain_strings=True, wrap_topic=True), stamp="record")
    assert status == 0 and len(lines) == 2
    assert lines[0]["event"] == ("robot_pose(geometry_msgs__0__PoseStamped(std_msgs__0__Header([1413748205,0],'/odom'),"
                                 "geometry_msgs__0__Pose(geometry_msgs__0__Point(0.0,0.0,0.0),"
                                 "geometry_msgs__0__Quaternion(0.0,0.0,0.0,1.0))))")
    assert lines[0]["start"] == 1413748205.002          # recorded 2 ms after its stamp


class VirtualClock:
    """A replay clock that only moves when the replay sleeps."""

    def __init__(self):
        self.time, self.sleeps = 100.0, []

    def now(self):
        return self.time

    def sleep(self, seconds):
        self.sleeps.append(seconds)
        self.time += seconds


def test_rate_paces_the_replay_by_the_recording_clock(nao_bags, capsys):
    engine = Engine.from_source("", "rate.rtl")
    engine.set_flag("echo_input", "false")
    clock = VirtualClock()
    status = replay_bag(engine, str(nao_bags["ros2"]), None, BagOptions(topics=["/tf"], rate=4.0, duration=1.0),
                        progress=True, clock=clock)
    assert status == 0
    summary = capsys.readouterr().err
    assert f"replaying {nao_bags['ros2']}" in summary           # the progress bar's label
    # 1 s of recording at 4x takes 0.25 s, fed in slices as the messages fall due
    assert 0.24 <= sum(clock.sleeps) <= 0.25 + RATE_TICK, clock.sleeps
    assert len(clock.sleeps) >= 10
    assert all(s >= RATE_TICK for s in clock.sleeps)


def test_each_message_is_fed_within_a_tick_of_its_due_time_with_the_fewest_wake_ups(nao_bags):
    """--tick is a latency budget: each message is fed no earlier than it falls due and at
    most a tick later; the replay sleeps until the first message not fed is a tick late and
    feeds every message due by then in one call. A longer tick gives fewer, larger calls and
    the same output."""
    runs = {}
    for tick in (RATE_TICK, 0.05):
        engine = Engine.from_source("", f"tick{int(tick * 1000)}.rtl")
        engine.set_flag("echo_input", "true")
        clock, lines, fed = VirtualClock(), [], []
        engine.on_output(lambda event: lines.append(event.line))
        feed_batch = engine.feed_batch
        engine.feed_batch = lambda items: fed.extend((clock.time, item[1]) for item in items) or feed_batch(items)
        assert replay_bag(engine, str(nao_bags["ros2"]), None,
                          BagOptions(topics=["/tf"], rate=4.0, duration=1.0, tick=tick, stamp="record"),
                          progress=False, clock=clock) == 0
        first = fed[0][1]
        lateness = [at - (100.0 + (seconds - first) / 4.0) for at, seconds in fed]
        assert all(-1e-6 <= late <= tick + 1e-6 for late in lateness), lateness
        # the fewest wake-ups within the budget: one per run of messages within a tick of the first
        dues = [(seconds - first) / 4.0 for _, seconds in fed]
        greedy, deadline = 0, None
        for due in dues:
            if deadline is None or due > deadline + 1e-6:
                greedy, deadline = greedy + 1, due + tick
        assert len(clock.sleeps) == greedy, (clock.sleeps, greedy)
        runs[tick] = (clock.sleeps, lines)
    assert len(runs[0.05][0]) <= 6 < len(runs[RATE_TICK][0])
    assert runs[0.05][1] == runs[RATE_TICK][1] and runs[RATE_TICK][1]


def test_on_the_wall_clock_the_runtime_paces_the_messages_and_the_output_is_the_same(nao_bags, tmp_path):
    """With a rate and the wall clock, the messages go to the runtime a quarter of a second
    ahead and it feeds each when it falls due (Engine.feed_paced): the replay takes the
    recording's time over the rate, hands each message over once in a few calls, and gives
    the output of the replay as fast as possible, line for line."""
    import time as clock

    program = NAO_PROGRAM.read_text(encoding="utf-8")
    _, fast = replay(program, nao_bags["ros1"], tmp_path, echo=True, topics=None)
    engine = Engine.from_source(program, "paced.rtl")
    calls = []
    paced = engine.feed_paced
    engine.feed_paced = lambda *args: calls.append((len(args[0]), max(args[1]) - clock.time())) or paced(*args)
    began = clock.perf_counter()
    status, lines = replay(engine, nao_bags["ros1"], tmp_path, echo=True, rate=6.0)
    took = clock.perf_counter() - began
    assert status == 0 and lines == fast and len(fast) > 150
    assert 0.45 <= took <= 2.0, took                          # 3 s of recording at 6x
    with Recording(nao_bags["ros1"]) as bag:
        assert sum(n for n, _ in calls) == bag.message_count      # each message handed over once
    assert 2 <= len(calls) <= 10, calls                         # about one call per quarter second
    assert all(ahead <= PACED_AHEAD for _, ahead in calls), calls  # never more than that ahead of the clock


def test_feed_paced_feeds_each_item_when_it_is_due_and_delivers_the_output_at_once():
    import time as clock

    engine = Engine.from_source("b(X) <- a(X).\n", "paced_unit.rtl")
    engine.set_flag("echo_input", "false")
    now = clock.time()
    items = [("z(1)", 1.0), ("z(2)", 2.0), ("a(3)", 3.0), ("z(4)", 4.0), ("a(5)", 5.0)]
    dues = [now + 0.02, now + 0.04, now + 0.06, now + 0.08, now + 0.1]
    delivered = []
    last = engine.feed_paced(items, dues, 0.005, lambda out: delivered.append((clock.time(), out)))
    assert clock.time() >= dues[4] and [event.text for event in last] == ["b(5)"]
    assert len(delivered) == 1                                  # b(3), as soon as a(3) was fed
    at, out = delivered[0]
    assert dues[2] <= at < dues[4] and [event.text for event in out] == ["b(3)"]
    # without `deliver`, everything comes back at the end; items already due go in one batch
    assert [e.text for e in engine.feed_paced(items[2:], [0.0, 0.0, now + 0.12], 0.5)] == ["b(3)", "b(5)"]
    with pytest.raises(ValueError, match="due times"):
        engine.feed_paced(items, dues[:2])


def test_feed_paced_wakes_when_the_first_item_left_is_a_tick_late():
    """The runtime's pacing: one wake-up serves every item due within `tick` of the first
    one left, so the three items due within 20 ms go in one group (one delivery), fed no
    earlier than the first is a tick late; the last item waits for its own deadline."""
    import time as clock

    engine = Engine.from_source("b(X) <- a(X).\n", "paced_deadline.rtl")
    engine.set_flag("echo_input", "false")
    now = clock.time()
    items = [("a(1)", 1.0), ("a(2)", 2.0), ("a(3)", 3.0), ("a(4)", 4.0)]
    dues = [now + 0.05, now + 0.06, now + 0.07, now + 0.25]
    tick = 0.03
    delivered = []
    last = engine.feed_paced(items, dues, tick, lambda out: delivered.append((clock.time(), [e.text for e in out])))
    end = clock.time()
    assert [texts for _, texts in delivered] == [["b(1)", "b(2)", "b(3)"]]
    assert dues[0] + tick <= delivered[0][0] < dues[3]
    assert [e.text for e in last] == ["b(4)"] and end >= dues[3] + tick


def test_feed_paced_stops_at_an_item_that_fails():
    engine = Engine.from_source("b(X) <- a(X) where X > 0.\n", "paced_fail.rtl")
    engine.set_flag("echo_input", "false")
    delivered = []
    with pytest.raises(PrologError) as caught:
        engine.feed_paced([("a(1)", 1.0), ("a(2)", 2.0), ("a(x)", 3.0), ("a(4)", 4.0)], [0.0] * 4, 0.01,
                          delivered.append)
    assert caught.value.batch_index == 2
    assert [e.text for batch in delivered for e in batch] + [e.text for e in caught.value.delivered] == ["b(1)", "b(2)"]
    assert [e.text for e in engine.feed_paced([("a(5)", 5.0)], [0.0])] == ["b(5)"]


@pytest.mark.parametrize("rate", [None, 20.0])
def test_a_message_whose_processing_fails_is_reported_and_the_replay_goes_on(nao_bags, tmp_path, capsys, rate):
    # the condition raises (foo is no number) for every tf message; the poses still go through
    program = ("tf_seen <- tf2_msgs__0__TFMessage(_) where _ is foo + 1.\n"
               "pose_seen <- geometry_msgs__0__PoseStamped(_, _).\n")
    status, out = replay(program, nao_bags["ros1"], tmp_path, topics=["/tf", "/robot_pose"], batch_size=7,
                         rate=rate)
    err = capsys.readouterr().err
    failures = [line for line in err.splitlines() if ": error: " in line]
    assert status == 0, err
    assert len(failures) == 3 * 50                          # every tf message (3 s at 50 Hz), once
    assert all(f"{nao_bags['ros1']}:/tf#" in line for line in failures), err
    assert "150 failed" in err
    assert [event["event"] for event in out].count("pose_seen") == 3 * 10, out[:5]
    assert "tf_seen" not in [event["event"] for event in out]


@pytest.mark.parametrize("rate", [None, 20.0])
def test_messages_that_cannot_be_decoded_are_rejected_and_the_replay_goes_on(tmp_path, capsys, rate):
    from rosbags.rosbag1 import Writer
    store = sample_store(1)
    records = nao_records(store, seconds=0.2, tf_rate=20)
    path = tmp_path / "broken.bag"
    with Writer(path) as writer:
        connections = {}
        for number, (topic, msgtype, ns, msg) in enumerate(records):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            data = store.serialize_ros1(msg, msgtype)
            writer.write(connections[topic], ns, data[:7] if number == 1 else data)
    status, lines = replay("", path, tmp_path, echo=True, rate=rate)
    err = capsys.readouterr().err
    assert status == 0 and len(lines) == len(records) - 1
    assert f"{path}:{records[1][0]}#2: rejected: cannot decode" in err
    assert "1 rejected" in err


# ---- the shared sample bags -----------------------------------------------------------------

@pytest.mark.parametrize("name", SHARED_NAMES)
def test_every_shared_bag_replays_every_message(name, tmp_path, capsys):
    path = shared_bag(name)
    with Recording(path) as bag:
        count = bag.message_count
    status, lines = replay("", path, tmp_path, echo=count < 600, batch_size=2000)
    err = capsys.readouterr().err
    assert status == 0 and len(lines) == (count if count < 600 else 0)
    assert "rejected" not in err.split("retalis:")[0]
    assert f"{count:,} messages" in err and f"{count:,} events" in err


@pytest.mark.parametrize("ros1, ros2", ROS1_ROS2_PAIRS)
def test_ros1_and_ros2_forms_of_a_recording_give_the_same_events(ros1, ros2, tmp_path):
    topics = ["/tf", "/tf_static"]
    _, one = replay("", shared_bag(ros1), tmp_path, echo=True, topics=topics)
    _, two = replay("", shared_bag(ros2), tmp_path, echo=True, topics=topics)
    assert len(one) == len(two) > 100
    assert "std_msgs__0__Header(0,[" in one[0]["event"] and "std_msgs__0__Header([" in two[0]["event"]
    assert [(without_seq(x["event"]), x["start"]) for x in one] == [(without_seq(x["event"]), x["start"]) for x in two]


# ---- the command line -------------------------------------------------------------------------

def _cli(*args):
    return subprocess.run([sys.executable, "-m", "retalisc", *map(str, args)], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)


def test_cli_replays_a_bag_and_reports_bad_input(nao_bags, tmp_path):
    from click.testing import CliRunner

    from retalisc.commands.compile import run_command

    consumers = tmp_path / "consumers"
    run = _cli("run", NAO_PROGRAM, "--bag", nao_bags["ros1"], "--consumer-dir", consumers, "--topics",
               "/tf,/ar_pose_marker", "--out-bag", tmp_path / "out.mcap")
    assert run.returncode == 0, run.stderr
    assert f"out-bag: {tmp_path / 'out.mcap'}: " in run.stderr and (tmp_path / "out.mcap").stat().st_size > 1000
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert lines and all(line["event"].startswith(("marker_pose(", "geometry_msgs__0__PoseStamped(", "seen_again("))
                         for line in lines)
    assert {p.name for p in consumers.iterdir()} == {"marker1.jsonl", "marker2.jsonl"}
    assert "messages in" in run.stderr and "/ar_pose_marker" in run.stderr and "/robot_pose" not in run.stderr
    program = tmp_path / "cli_bad_bag.rtl"            # in this process: a module name of its own
    program.write_text("alarm <- smoke.\n")
    bad = CliRunner().invoke(run_command, [str(program), "--bag", str(program)])
    assert bad.exit_code == 2 and "not a recording" in bad.output and bad.exception is None or \
        isinstance(bad.exception, SystemExit)
    usage = CliRunner().invoke(run_command, [str(program), "--events", "-", "--rate", "2"])
    assert usage.exit_code == 2 and "go with --bag" in usage.output


def test_a_reader_of_the_bag_run_that_goes_away_ends_it_quietly(nao_bags, tmp_path):
    """`retalisc run P --bag B | head -1`: status 1 and nothing on standard error, as for an
    events file."""
    program = tmp_path / "echo.rtl"
    program.write_text("null <- zzz.\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RETALISC_CACHE_DIR": str(tmp_path / "cache")}
    process = subprocess.Popen([sys.executable, "-m", "retalisc", "run", str(program), "--bag", str(nao_bags["ros1"]),
                                "--echo-input"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert process.stdout.readline().startswith(b'{"event": ')
    process.stdout.close()
    stderr = process.stderr.read()
    assert process.wait(timeout=120) == 1
    assert stderr == b""


# ---- a recording as the input of `retalisc query` and `retalisc explain` --------------------

def _last_tf_stamp(path, frame: str) -> float:
    """The header stamp of the last /tf transform of `frame`, read from the recording."""
    stamps = []
    with Recording(str(path)) as bag:
        for record in bag.records(["/tf"]):
            for transform in record.msg.transforms:
                if transform.child_frame_id == frame:
                    stamp = transform.header.stamp
                    stamps.append(stamp.sec + stamp.nanosec / 1e9 if hasattr(stamp, "sec") else stamp.to_sec())
    return max(stamps)


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_query_reads_a_recording(nao_bags, fmt, tmp_path):
    from click.testing import CliRunner

    from retalisc.commands.query import query_command

    program = tmp_path / f"nao_query_{fmt}.rtl"          # in this process: a module name of its own
    program.write_text(NAO_PROGRAM.read_text())
    result = CliRunner().invoke(query_command, [str(program), "--bag", str(nao_bags[fmt]), "--topics", "/tf",
                                                "--first", "prev(head_cam, tf(V, Q)^T, 1e12)"])
    assert result.exit_code == 0, result.output
    answer = json.loads(result.stdout)
    assert float(answer["T"]) == pytest.approx(_last_tf_stamp(nao_bags[fmt], "CameraTop_frame"), abs=1e-6)
    assert "bag: " in result.stderr and "/tf 150" in result.stderr
    usage = CliRunner().invoke(query_command, [str(program), "--topics", "/tf", "true"])
    assert usage.exit_code == 2 and "go with --bag" in usage.output


def test_explain_reads_a_recording_and_names_each_message(nao_bags):
    from click.testing import CliRunner

    from retalisc.commands.explain import explain_command

    bag = nao_bags["ros1"]
    result = CliRunner().invoke(explain_command, [str(NAO_PROGRAM), "--bag", str(bag), "--stamp", "header",
                                                  "--limit", "1", "seen_again(M)"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert "derived by rule r4" in lines[0], result.stdout
    with Recording(str(bag)) as recording:
        topics = [record.topic for record in recording.records()]
    numbers = [int(line.rsplit("#", 1)[1]) for line in lines[1:3]]
    assert all("input message /ar_pose_marker#" in line for line in lines[1:3])
    assert all(topics[n - 1] == "/ar_pose_marker" for n in numbers) and numbers[0] < numbers[1]
    both = CliRunner().invoke(explain_command, [str(NAO_PROGRAM), "--bag", str(bag), "--events", str(NAO_PROGRAM),
                                                "x"])
    assert both.exit_code == 2 and "one of them" in both.output
