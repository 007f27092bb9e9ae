"""One clock per run (messages.EventClock, docs/robot_io.md "Time"): a message is at the time it
carries (its header, a TFMessage's first transform), else the latest /clock, else its arrival
on the run's clock; a jump of more than an hour warns once. Tested on the sim-time Nav2 MCAP of
../shared/data/bags (headers from 924 s, record times in 2026)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from robot_io_support import shared_bag

pytest.importorskip("rosbags")

from retalisc.driver.engine import Engine  # noqa: E402
from retalisc.robot_io.messages import EventClock  # noqa: E402
from retalisc.robot_io.replay import BagOptions, replay_bag  # noqa: E402

NAV2 = "evo_nav2_turtlebot.mcap"
PROGRAM = Path(__file__).resolve().parent.parent / "examples" / "nav2" / "moving_stopped.rtl"


def run(tmp_path, topics=None, echo=False, out_bag=None, flush_timers=True, name="out.jsonl"):
    engine = Engine.load(PROGRAM)
    engine.set_flag("echo_input", "true" if echo else "false")
    if flush_timers:
        engine.set_flag("flush_timers", "true")
    out = tmp_path / name
    assert replay_bag(engine, str(shared_bag(NAV2)), str(out), BagOptions(topics=topics), progress=False,
                      out_bag=out_bag) == 0
    return [json.loads(line) for line in out.read_text().splitlines()], engine.detections()


def test_the_whole_recording_gives_the_detections_of_odometry_and_amcl_alone(tmp_path, capsys):
    whole, whole_counts = run(tmp_path, name="whole.jsonl")
    two, two_counts = run(tmp_path, topics=["/odom", "/amcl_pose"], name="two.jsonl")
    assert whole == two
    assert [whole_counts[r] for r in ("r1", "r2", "r3", "r4")] == [two_counts[r] for r in ("r1", "r2", "r3", "r4")]
    assert whole_counts["r3"] > 1000 and whole_counts["r4"] > 10 and whole_counts["r5"] == 5422
    assert "jumps" not in capsys.readouterr().err


def test_every_input_is_on_the_simulation_clock(tmp_path):
    lines, _ = run(tmp_path, echo=True, flush_timers=False)
    inputs = [line for line in lines if line["event"].startswith(("tf2_msgs", "tf_static(", "nav_msgs", "geometry_msgs"))]
    assert len(inputs) == 8197
    assert all(900 < line["start"] < 1100 for line in inputs)      # not 1.78e9 (2026)
    static = [line for line in inputs if line["event"].startswith("tf_static(") and "[0,0]" in line["event"]]
    assert static and all(900 < line["start"] < 1100 for line in static)   # stamp 0: the arrival, moved


def test_the_out_bag_puts_inputs_and_derived_events_on_one_clock(tmp_path):
    mcap_reader = pytest.importorskip("mcap.reader")
    out_bag = tmp_path / "derived.mcap"
    run(tmp_path, out_bag=str(out_bag), flush_timers=False)
    times = {}
    with open(out_bag, "rb") as stream:
        for _, channel, message in mcap_reader.make_reader(stream).iter_messages():
            times.setdefault(channel.topic, []).append(message.log_time)
    inputs = [t for topic in ("/odom", "/amcl_pose", "/tf", "/tf_static") for t in times[topic]]
    derived = times["/retalis/events"]
    assert derived and min(inputs) <= min(derived) and max(derived) <= max(inputs)
    assert max(inputs) - min(inputs) < 200 * 10**9          # one clock: the recording's 97 s of sim time


# ---- the rule itself ------------------------------------------------------------------------


def clock(record=False):
    warnings = []
    return EventClock(warnings.append, record=record), warnings


def test_a_message_is_at_the_time_it_carries_else_at_its_arrival():
    c, warnings = clock()
    assert c.time(0.0, 5_000_000_000, "/a", "b:/a#1") == 5.0                 # nothing carried yet
    assert c.time(7.25, 6_000_000_000, "/b", "b:/b#2") == 7.25
    assert c.time(0.0, 8_000_000_000, "/a", "b:/a#3") == 8.0                 # same clock: the arrival
    assert warnings == []


def test_a_message_without_a_time_follows_the_sim_clock_of_the_others():
    c, warnings = clock()
    record = 1_778_234_353_000_000_000
    assert c.time(928.8, record, "/odom", "b:/odom#1") == 928.8
    assert c.time(0.0, record + 500_000_000, "/tf_static", "b:/tf_static#2") == pytest.approx(929.3)
    assert warnings == []


def test_clock_messages_give_the_time_of_the_messages_without_one():
    c, warnings = clock()
    c.clock(12.5)
    assert c.time(0.0, 1_778_234_353_000_000_000, "/scan_status", "b:/scan_status#1") == 12.5
    assert c.time(13.0, 1_778_234_354_000_000_000, "/odom", "b:/odom#2") == 13.0
    assert warnings == []


def test_a_jump_of_more_than_an_hour_warns_once_with_both_times_and_the_topic():
    c, warnings = clock()
    c.time(0.0, 1_778_234_353_000_000_000, "/status", "b:/status#1")        # record clock, 2026
    c.time(928.8, 1_778_234_353_100_000_000, "/odom", "b:/odom#2")          # sim clock
    c.time(0.0, 1_778_234_353_200_000_000, "/status", "b:/status#3")
    c.time(1778234354.0, 1_778_234_354_000_000_000, "/odom", "b:/odom#4")
    assert len(warnings) == 1
    assert "b:/odom#2" in warnings[0] and "1778234353.000000000 s" in warnings[0] and "928.800000000 s" in warnings[0]
    assert "on /odom" in warnings[0]


def test_stamp_record_puts_everything_on_the_record_clock():
    c, warnings = clock(record=True)
    assert c.time(928.8, 5_000_000_000, "/odom", "b:/odom#1") == 5.0
    c.clock(12.0)
    assert c.time(0.0, 6_000_000_000, "/a", "b:/a#2") == 6.0
    assert warnings == []


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_a_recording_with_a_clock_stamps_the_messages_without_a_time_by_it(tmp_path, fmt, capsys):
    """/clock (sim time, 100-102 s) recorded on the wall clock with std_msgs/String status
    messages: each status is at the latest /clock, on both roads (ROS 1 bytes, ROS 2 text),
    and also when --topics leaves /clock out; nothing warns."""
    from retalisc.robot_io.bags import typestore, write_bag

    store = typestore("ros1_noetic" if fmt == "ros1" else "ros2_humble")
    T = store.types
    wall = 1_778_234_353_000_000_000
    records = []
    for k in range(3):
        records.append(("/clock", "rosgraph_msgs/msg/Clock", wall + k * 10**9,
                        T["rosgraph_msgs/msg/Clock"](clock=T["builtin_interfaces/msg/Time"](sec=100 + k, nanosec=0))))
        records.append(("/status", "std_msgs/msg/String", wall + k * 10**9 + 500_000_000,
                        T["std_msgs/msg/String"](data=f"s{k}")))
    bag = write_bag(tmp_path / ("c.bag" if fmt == "ros1" else "c_mcap"), fmt, store, records)
    for topics in (None, ["/status"]):
        engine = Engine.from_source("", "clock.rtl")
        engine.set_flag("echo_input", "true")
        out = tmp_path / "out.jsonl"
        assert replay_bag(engine, str(bag), str(out), BagOptions(topics=topics), progress=False) == 0
        status = [json.loads(line) for line in out.read_text().splitlines() if "String" in line]
        assert [(line["event"], line["start"]) for line in status] == [
            ("std_msgs__0__String(s0)", 100.0), ("std_msgs__0__String(s1)", 101.0), ("std_msgs__0__String(s2)", 102.0)]
    assert "jumps" not in capsys.readouterr().err
