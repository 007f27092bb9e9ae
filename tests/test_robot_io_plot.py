"""`retalisc plot` (retalisc/robot_io/plot.py): rows per event type and consumer, bars for
intervals, from the output of a replay."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from retalisc.robot_io.plot import PlotError, _lanes, event_type, plot_timeline, read_rows, type_label

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("text, kind", [
    ("alarm", "alarm/0"),
    ("f(a, [1, 2, 3], g(x, y))", "f/3"),
    ("tf('\"/odom\"','\"a,b)\"',[0.0,1.0],[0,0,0,1])", "tf/4"),
    ('say("x, (y", z)', "say/2"),
    ("'hello world'(1)", "'hello world'/1"),
    ("geometry_msgs__0__PoseStamped(std_msgs__0__Header([1,2],'\"m\"'),p)", "geometry_msgs__0__PoseStamped/2"),
])
def test_event_types_are_read_from_the_text(text, kind):
    assert event_type(text) == kind


def test_labels_and_lanes():
    assert type_label("geometry_msgs__0__PoseStamped/2") == "geometry_msgs/PoseStamped"
    assert type_label("tf/4") == "tf/4"
    lanes = _lanes([(0, 2), (1, 3), (2, 4), (5, 6)])
    assert lanes == [[(0, 2), (2, 4), (5, 6)], [(1, 3)]]
    assert sum(len(lane) for lane in _lanes([(0, 10)] * 20)) == 20 and len(_lanes([(0, 10)] * 20)) == 8


def test_rows_from_output_and_event_files(tmp_path):
    output = tmp_path / "out.jsonl"
    output.write_text("\n".join(json.dumps(x) for x in [
        {"event": "a(1)", "start": 1.0, "end": 1.0},
        {"event": "b(x, y)", "start": 1.0, "end": 3.0},
        {"event": "b(x, z)", "start": 2.0, "end": 2.5, "consumer": "arm"},
        {"event": "a(1)", "start": 1.0, "end": 1.0, "op": "retract"},
        {"query": 1, "at": 2.0, "status": "answered", "answers": []},
    ]) + "\n\n")
    events = tmp_path / "in.jsonl"
    events.write_text('{"event": "c", "t": [0, 500000000]}\n{"op": "add_rule", "rule": "x <- y."}\n')
    rows = read_rows([str(output), str(events)])
    assert set(rows) == {"a/1", "b/2", "b/2 -> arm", "c/0"}
    assert rows["a/1"].ticks == [1.0] and rows["a/1"].retracted == [1.0]
    assert rows["b/2"].bars == [(1.0, 3.0)] and rows["c/0"].ticks == [0.5]
    image = tmp_path / "t.png"
    assert plot_timeline([str(output), str(events)], str(image)) == (4, 5)
    assert image.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(PlotError):
        plot_timeline([str(output)], str(tmp_path / "none.png"), types=["nothing"])


def test_cli_plot_of_a_replay(tmp_path):
    pytest.importorskip("rosbags", reason="writing the sample bag needs the 'ros' extra (rosbags)")
    from click.testing import CliRunner

    from retalisc.commands.plot import plot_command
    from retalisc.driver.engine import Engine
    from retalisc.robot_io.replay import replay_bag
    from retalisc.robot_io.samples import write_nao_bag

    bag = write_nao_bag(tmp_path / "nao.bag", "ros1", seconds=1.5)
    out = tmp_path / "out.jsonl"
    engine = Engine.load(ROOT / "examples" / "nao_markers" / "nao_markers.rtl")
    engine.set_flag("echo_input", "true")
    assert replay_bag(engine, str(bag), str(out)) == 0
    plot = CliRunner().invoke(plot_command, [str(out), "-o", str(tmp_path / "t.png"), "--types", "ar_,seen,->"])
    assert plot.exit_code == 0, plot.output
    assert "5 rows" in plot.output       # ar_pose/ARMarkers, ar_marker/3, seen_again/1, -> marker1, -> marker2
    assert (tmp_path / "t.png").stat().st_size > 10_000
    bad = CliRunner().invoke(plot_command, [str(bag), "-o", str(tmp_path / "b.png")])
    assert bad.exit_code == 2 and "not a UTF-8 text file" in bad.output
