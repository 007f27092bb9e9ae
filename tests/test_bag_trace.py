"""`retalisc run --bag` with `--trace RULE` and `--late FILE`, and the detections per rule,
on a small recording written here (four PointStamped messages on /smoke and /heat)."""
from __future__ import annotations

import json

from click.testing import CliRunner

from robot_io_support import rosbags  # noqa: F401  (skips without the 'ros' extra)

from retalisc.cli import main  # noqa: E402
from retalisc.robot_io.bags import write_bag  # noqa: E402

# smoke and heat in the same room (the header's frame) within 5 s make a fire
PROGRAM = """\
fire(Room) <- (smoke(geometry_msgs__0__PointStamped(std_msgs__0__Header(_, Room), _))
               seq heat(geometry_msgs__0__PointStamped(std_msgs__0__Header(_, Room), _))).5.
"""


def small_bag(path):
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types

    def point(stamp: int, room: str):
        header = types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=stamp, nanosec=0),
                                              frame_id=room)
        return types["geometry_msgs/msg/PointStamped"](header=header,
                                                       point=types["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0))

    kind = "geometry_msgs/msg/PointStamped"
    # (topic, record time, header stamp, room): the last smoke was stamped 7 s before the
    # newest event, 5 s more than --max-delay 2: late
    messages = [("/smoke", 1, 1, "kitchen"), ("/heat", 2, 2, "kitchen"), ("/heat", 3, 10, "hall"),
                ("/smoke", 4, 3, "hall")]
    return write_bag(path, "mcap", store, [(topic, kind, record * 10**9, point(stamp, room))
                                           for topic, record, stamp, room in messages])


def test_trace_and_late_with_a_bag(tmp_path, capfd):
    program = tmp_path / "fire.rtl"
    program.write_text(PROGRAM)
    bag = small_bag(tmp_path / "house")
    late = tmp_path / "late.jsonl"
    result = CliRunner().invoke(main, ["run", str(program), "--bag", str(bag), "--wrap-topic", "--plain-strings",
                                       "--max-delay", "2", "--trace", "r1", "--late", str(late)])
    assert result.exit_code == 0, result.output
    assert [json.loads(line)["event"] for line in result.stdout.splitlines()] == ["fire(kitchen)"]
    # the runtime writes the trace lines to standard error itself (file descriptor 2)
    written = capfd.readouterr().err + result.stderr
    trace = [line for line in written.splitlines() if line.startswith("trace r1")]
    assert trace[0].startswith("trace r1 at 1.0: created step 1 left (smoke(")
    assert any(line.startswith("trace r1 at 10.0: expired step 1 right (heat(") for line in trace)
    assert trace[-1] == ("trace r1 (fire/1): 1 detections; partial matches: 4 created, 0 consumed, 2 expired, "
                         "0 dropped, 0 replaced, 0 retracted")
    *_, detections, summary = result.stderr.splitlines()
    assert detections == "retalis: detections per rule: r1 1"
    assert summary.startswith("retalis: 4 events in, 1 derived, 0 rejected, 1 late, ")
    [record] = [json.loads(line) for line in late.read_text().splitlines()]
    assert record["event"].startswith("smoke(geometry_msgs__0__PointStamped(std_msgs__0__Header([3,0],hall)")
    assert (record["start"], record["clock"], record["lateness"], record["max_delay"]) == (3.0, 10.0, 7.0, 2.0)
    assert record["rules"] == ["r1"]


def test_trace_of_an_unknown_rule_with_a_bag(tmp_path):
    program = tmp_path / "fire_unknown.rtl"
    program.write_text(PROGRAM)
    result = CliRunner().invoke(main, ["run", str(program), "--bag", str(small_bag(tmp_path / "house")),
                                       "--trace", "r7"])
    assert result.exit_code == 2 and "no rule 'r7' in the program (its rules: r1)" in result.stderr
