"""The tf library (prolog_runtime/rtl_tf.pl, docs/tf.md): its plunit suite, and tf2's
BufferCore as the oracle on random scenarios (skipped without Debian's python3-tf2)."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from retalisc.compiler import compile_source
from tf_scenarios import differences, run_both, run_library, scenario, tf2_available

ROOT = Path(__file__).resolve().parent.parent
TF2 = tf2_available()
C_STORE = any((ROOT / "prolog_runtime" / "foreign").glob("rtl_tfstore.*"))


@pytest.mark.parametrize("road", ["c", "prolog"])
def test_plunit(swipl, tmp_path, road):
    if road == "c" and not C_STORE:
        pytest.skip("the C store is not built (prolog_runtime/c/build.sh)")
    program = tmp_path / "tf_host.pl"
    program.write_text(compile_source("host_rule(X) <- host_event(X).\n", "tf_host.rtl",
                                      module="tf_host").prolog)
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_tf.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120,
                          env={**os.environ, "TF_TEST_PROGRAM": str(program), "TF_TEST_ROAD": road})
    assert proc.returncode == 0, proc.stdout


@pytest.mark.skipif(not TF2, reason="tf2's Python binding is not installed (apt-get install python3-tf2)")
@settings(max_examples=6, deadline=None, phases=[Phase.explicit, Phase.reuse, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.integers(0, 2**32 - 1))
def test_same_answers_as_tf2(swipl, seed):
    ops = scenario(seed)
    ours, theirs = run_both(ops, swipl)
    assert differences(ours, theirs, ops) == []


@pytest.mark.skipif(not C_STORE, reason="the C store is not built (prolog_runtime/c/build.sh)")
@settings(max_examples=8, deadline=None, phases=[Phase.explicit, Phase.reuse, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.integers(0, 2**32 - 1))
def test_the_c_store_answers_as_the_prolog_road_and_tf2(swipl, seed):
    """The same transforms in, the same answers, failures and reasons out: the C store and the
    Prolog road (the reference) give identical lines (the same arithmetic, operation for
    operation), and both agree with tf2's BufferCore when it is installed."""
    ops = scenario(seed)
    c, prolog = run_library(ops, swipl, "c"), run_library(ops, swipl, "prolog")
    assert len(c) == len([op for op in ops if op[0] in ("lookup", "can")])
    assert c == prolog
    if TF2:
        _, theirs = run_both(ops, swipl)
        assert differences(c, theirs, ops) == []


BAGS = Path("/work/shared/data/bags")


@pytest.mark.skipif(not (BAGS / "evo_tf_example.bag").exists(), reason="the shared test bags are not here")
@pytest.mark.parametrize("name", ["evo_tf_example.bag", "evo_tf_example_ros2"])
def test_a_recording_teaches_the_tree_static_links_from_tf_static(name):
    """/tf_static's message comes in as tf_static(Msg) (ROS 1 bytes road and ROS 2 text road):
    its link answers at any time; /tf's links only within their data."""
    from retalisc.driver.engine import Engine
    from retalisc.robot_io.replay import replay_bag

    engine = Engine.from_source("x(A) <- y(A).\n")
    replay_bag(engine, str(BAGS / name), out=None)
    assert engine.query("tf_links(L), tf_records(R)") == {"L": "2", "R": "102"}
    static = engine.query("""tf_lookup(base_footprint, base_link, 1.0, _, S, R)""")
    assert static["R"] == "ok" and static["S"] == "[1,0]"
    dynamic = engine.query("""tf_lookup(odom, base_link, 1.0, _, _, R)""")
    assert dynamic["R"].startswith("extrapolation(past,1000000000,")
    latest = engine.query("""tf_lookup(odom, '/base_link', latest, P, S, R)""")
    assert latest["R"] == "ok"
    engine.close()


def test_the_tree_is_kept_in_a_snapshot(tmp_path):
    """The tf store is state (prolog_runtime/rtl_state.pl declares it): a snapshot restored into
    a new load answers every lookup as the engine that wrote it."""
    from retalisc.driver.engine import Engine

    program = "x(A) <- y(A).\n"
    first = Engine.from_source(program, "tf_state.rtl")
    for goal in ("tf_add(map, odom, 1.0, [0, 0, 0], [0, 0, 0, 1], static)",
                 "tf_add(odom, base, 1.0, [1, 0, 0], [0, 0, 0, 1], dynamic)",
                 "tf_add(odom, base, 2.0, [3, 0, 0], [0, 0, 0.7071067811865476, 0.7071067811865476], dynamic)"):
        first.bridge.call_text(f"rtl_tf:{goal}, R = \"\"", "R")
    first.feed_batch([("y(1)", 2.0)])
    lookups = ["tf_lookup(map, base, 1.5, P, _, R)", "tf_lookup(map, base, latest, P, _, R)",
               "tf_lookup(map, base, 0.5, _, _, R)", "tf_records(R), tf_links(P)"]
    expected = [first.query(q) for q in lookups]
    assert expected[0]["R"] == "ok" and expected[2]["R"].startswith("extrapolation(past")
    path = tmp_path / "tf.state"
    first.save_state(path)
    second = Engine.from_source(program, "tf_state.rtl")
    second.restore_state(path)
    assert [second.query(q) for q in lookups] == expected


@pytest.mark.skipif(not C_STORE, reason="the C store is not built (prolog_runtime/c/build.sh)")
@pytest.mark.parametrize("saved_on, restored_on", [("c", "prolog"), ("prolog", "c")])
def test_a_snapshot_of_one_road_restores_into_the_other(tmp_path, saved_on, restored_on):
    """The tree is written as data (rtl_state:state_data/4), the same on both roads."""
    from retalisc.driver.engine import Engine

    program = "x(A) <- y(A).\n"
    first = Engine.from_source(program, "tf_roads.rtl")
    first.bridge.call_text(f"rtl_tf:tf_set_road({saved_on}), R = \"\"", "R")
    for goal in ("tf_set_buffer(3)",
                 "tf_add('/map', odom, 1.0, [0, 0, 0.5], [0, 0, 0, 1], static)",
                 "tf_add(odom, base, 1.0, [1, 0, 0], [0, 0, 0, 1], dynamic)",
                 "tf_add(odom, base, 2.0, [3, 0, 0], [0, 0, 0.7071067811865476, 0.7071067811865476], dynamic)",
                 "tf_add(base, camera, 1.5, [0, 0, 1], [0, 0, 0, 1], dynamic)"):
        first.bridge.call_text(f"rtl_tf:{goal}, R = \"\"", "R")
    lookups = ["tf_lookup(map, camera, 1.5, P, S, R)", "tf_lookup(map, base, latest, P, S, R)",
               "tf_lookup(camera, map, 1.5, P, S, R)", "tf_lookup(map, camera, 0.5, _, _, R)",
               "tf_lookup(camera, map, 1.75, _, _, R)",
               "tf_frames(R)", "tf_records(R), tf_links(P), tf_buffer(S)"]
    expected = [first.query(q) for q in lookups]
    assert expected[0]["R"] == "ok" and expected[3]["R"].startswith("extrapolation(past")
    path = tmp_path / "tf.state"
    first.save_state(path)
    assert "data(rtl_tf,r(" in path.read_text(encoding="utf-8")
    second = Engine.from_source(program, "tf_roads.rtl")
    second.bridge.call_text(f"rtl_tf:tf_set_road({restored_on}), R = \"\"", "R")
    second.restore_state(path)
    assert second.query("tf_road(R)") == {"R": restored_on}
    assert [second.query(q) for q in lookups] == expected
    # the restored store goes on with the snapshot's buffer (3 s): the older records of base go
    second.bridge.call_text("rtl_tf:tf_add(odom, base, 6.0, [5, 0, 0], [0, 0, 0, 1], dynamic), R = \"\"", "R")
    assert second.query("tf_records(R)") == {"R": "3"}
    assert second.query("tf_lookup(odom, base, 4.0, _, _, R)") == {"R": "extrapolation(past,4000000000,6000000000,6000000000)"}
    second.close()
    first.close()


def test_a_snapshot_whose_tree_is_not_a_tree_is_refused(tmp_path):
    """The data of the tf store is checked before anything changes."""
    from retalisc.driver.engine import Engine
    from retalisc.driver.snapshot import StateError

    program = "x(A) <- y(A).\n"
    first = Engine.from_source(program, "tf_bad.rtl")
    first.bridge.call_text("rtl_tf:tf_add(odom, base, 1.0, [1, 0, 0], [0, 0, 0, 1], dynamic), R = \"\"", "R")
    first.bridge.call_text("rtl_tf:tf_add(odom, base, 2.0, [2, 0, 0], [0, 0, 0, 1], dynamic), R = \"\"", "R")
    path = tmp_path / "tf.state"
    first.save_state(path)
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    records = [i for i, line in enumerate(lines) if line.startswith("data(rtl_tf,r(")]
    assert len(records) == 2
    lines[records[0]], lines[records[1]] = lines[records[1]], lines[records[0]]   # stamps out of order
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    second = Engine.from_source(program, "tf_bad.rtl")
    second.bridge.call_text("rtl_tf:tf_add(a, b, 1.0, [1, 0, 0], [0, 0, 0, 1], static), R = \"\"", "R")
    with pytest.raises(StateError, match="data of rtl_tf"):
        second.restore_state(path)
    assert second.query("tf_frames(R)") == {"R": "[a,b]"}
    first.close()
    second.close()


def test_a_wait_times_out_on_event_time_without_tf_messages():
    """tf_wait/5 drops its goal once the clock, moved by any event, passes Time + Timeout:
    a tf message arriving later that makes the lookup possible does not run it."""
    from retalisc.driver.engine import Engine

    program = ("null do tf_wait(odom, base, T, 1.0, new_event(got(N), T, T)) <- ask(N, T).\n"
               "seen(N) <- got(N).\n")
    engine = Engine.from_source(program, "tf_wait_timeout.rtl")
    tf = ("tf2_msgs__0__TFMessage([geometry_msgs__0__TransformStamped(std_msgs__0__Header([{s},0],odom),base,"
          "geometry_msgs__0__Transform(geometry_msgs__0__Vector3({x},0.0,0.0),"
          "geometry_msgs__0__Quaternion(0.0,0.0,0.0,1.0)))])")
    outputs = engine.feed_batch([(tf.format(s=1, x=1.0), 1.0), ("ask(1, 2)", 1.5), ("ask(2, 3)", 1.6)])
    assert engine.query("tf_waiting(N)") == {"N": "2"}
    outputs += engine.feed_batch([("other(1)", 2.9)])       # before 2 + 1 s: both wait
    assert engine.query("tf_waiting(N)") == {"N": "2"}
    outputs += engine.feed_batch([("other(2)", 3.5)])       # past 2 + 1 s, before 3 + 1 s
    assert engine.query("tf_waiting(N)") == {"N": "1"}
    outputs += engine.feed_batch([(tf.format(s=5, x=5.0), 3.9)])      # data past 2 and 3 s
    assert engine.query("tf_waiting(N)") == {"N": "0"}
    assert [o.event for o in outputs if o.event.startswith("seen")] == ["seen(2)"]
    engine.close()


def test_without_the_c_library_the_prolog_road_is_used(swipl, tmp_path):
    """The C store is optional, as the other C helpers: a runtime without it answers on the
    Prolog road."""
    import shutil

    runtime = tmp_path / "prolog_runtime"
    shutil.copytree(ROOT / "prolog_runtime", runtime,
                    ignore=lambda _, names: [n for n in names if n.startswith("rtl_tfstore.")])
    goal = ("tf_road(R), writeln(R), tf_add(a, b, 1, [1, 0, 0], [0, 0, 0, 1], dynamic), "
            "tf_lookup(a, b, 1, P), writeln(P)")
    proc = subprocess.run([swipl, "-q", "-g", f"use_module('{runtime}/retalis'), {goal}", "-t", "halt"],
                          capture_output=True, text=True, timeout=120)
    assert proc.stdout.split() == ["prolog", "[[1.0,0.0,0.0],[0.0,0.0,0.0,1.0]]"], proc.stderr
