"""ROS strings: plain atoms by default, the 2015 release's quoted atoms on request
(collect_settings `ros_strings`, docs/robot_io.md "Strings"), on the real bags of
../shared/data/bags (evo_tf_example: odom -> base_footprint on /tf, in ROS 1 and ROS 2)."""
from __future__ import annotations

import json

import pytest

from robot_io_support import shared_bag

pytest.importorskip("rosbags")

from retalisc.driver.engine import Engine  # noqa: E402
from retalisc.robot_io.bags import Recording  # noqa: E402
from retalisc.robot_io.messages import Convention, MessageConverter  # noqa: E402
from retalisc.robot_io.replay import replay_bag  # noqa: E402
from retalisc.robot_io.ros1_terms import Ros1Terms  # noqa: E402

# One link/2 event per transform, kept in memory `links` (a ROS 1 header has a seq first).
LINKS = """
null do split(Ts) <- tf2_msgs__0__TFMessage(Ts).
split([geometry_msgs__0__TransformStamped(H, C, _)|T]) :- frame(H, F), new_event(link(F, C)), split(T).
split([]).
frame(std_msgs__0__Header(_, _, F), F).
frame(std_msgs__0__Header(_, F), F).
memorize(link(F, C), [], link(F, C), links, 1000).
"""
BAGS = ["evo_tf_example.bag", "evo_tf_example_ros2"]


def replayed(program: str, name: str, tmp_path) -> Engine:
    """The whole bag replayed into the program; without options, strings are as it says."""
    engine = Engine.from_source(program, "strings.rtl")
    assert replay_bag(engine, str(shared_bag(name)), str(tmp_path / "out.jsonl"), progress=False) == 0
    return engine


@pytest.mark.parametrize("name", BAGS)
def test_a_query_with_odom_finds_the_transforms_of_the_bag(name, tmp_path):
    engine = replayed(LINKS, name, tmp_path)
    assert engine.ros_strings == "plain"
    answers = engine.query_all("mem(links, link(odom, C))")
    assert len(answers) == 517 and {a["C"] for a in answers} == {"base_footprint"}
    assert engine.query_all("mem(links, link('\"odom\"', C))") == []


@pytest.mark.parametrize("name", BAGS)
def test_the_quoted_mode_gives_the_release_atoms(name, tmp_path):
    engine = replayed(":- ros_strings(quoted).\n" + LINKS, name, tmp_path)
    assert engine.ros_strings == "quoted"
    answers = engine.query_all("mem(links, link('\"odom\"', C))")
    assert len(answers) == 517 and {a["C"] for a in answers} == {"'\"base_footprint\"'"}
    assert engine.query_all("mem(links, link(odom, C))") == []


@pytest.mark.parametrize("plain", [True, False])
def test_the_c_and_text_roads_agree_on_a_real_bag_in_both_modes(plain):
    """Every message of the ROS 1 bag: the term the runtime builds from the bytes in C is the
    term of the text road (read by the runtime), in both string modes."""
    engine = Engine.from_source("", "roads.rtl")
    if not engine.ros1_schema("m(std_msgs__0__Empty,[])"):
        pytest.skip("the runtime has no ROS 1 C helper")
    engine.set_flag("echo_input", "true")
    convention = Convention(plain_strings=plain)
    with Recording(shared_bag("evo_tf_example.bag")) as bag:
        terms = Ros1Terms(engine, bag.typestore, convention)
        converter = MessageConverter(bag.typestore, convention)
        roads, texts = [], []
        for record in bag.raw_records():
            road = terms.event(record.raw, record.msgtype, record.topic, record.time_ns)
            assert road is not None, record.msgtype
            roads.append(road)
            decoded = bag.decode(record)
            texts.append(converter.event(decoded.msg, record.msgtype, record.topic, record.time_ns))
    from_bytes = [(o.event, o.start) for o in engine.feed_batch(roads)]
    from_text = [(o.event, o.start) for o in engine.feed_batch(texts)]
    assert len(from_bytes) == len(texts) == 518
    assert from_bytes == from_text
    frame = "odom" if plain else "'\"odom\"'"
    assert sum(f",{frame})," in event for event, _ in from_text) == 517       # every /tf header


def test_a_program_in_the_two_file_form_is_quoted_unless_it_says_otherwise(tmp_path):
    from retalisc.compiler import compile_file

    (tmp_path / "rules.txt").write_text("b(X) <- a(X).\n")
    (tmp_path / "goals.txt").write_text("compile_event_file('rules.txt')\n")
    (tmp_path / "plain.txt").write_text(":- ros_strings(plain).\ncompile_event_file('rules.txt')\n")
    (tmp_path / "one.rtl").write_text("b(X) <- a(X).\n")
    modes = {name: compile_file(str(tmp_path / name)).unit.settings.ros_strings
             for name in ("goals.txt", "plain.txt", "one.rtl")}
    assert modes == {"goals.txt": "quoted", "plain.txt": "plain", "one.rtl": "plain"}


def test_the_cli_answers_a_query_with_odom_with_plain_atoms(tmp_path):
    from click.testing import CliRunner

    from retalisc.cli import main

    program = tmp_path / "links.rtl"
    program.write_text(LINKS)
    result = CliRunner().invoke(main, ["run", str(program), "--bag", str(shared_bag("evo_tf_example.bag")),
                                       "--query", "1715000000", "mem(links, link(odom, C))"])
    assert result.exit_code == 0, result.output
    (line,) = [json.loads(line) for line in result.stdout.splitlines() if line.startswith('{"query"')]
    assert line["status"] == "answered" and line["answers"]
    assert {answer["C"] for answer in line["answers"]} == {"base_footprint"}
