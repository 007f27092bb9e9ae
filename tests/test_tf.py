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
from tf_scenarios import differences, run_both, scenario, tf2_available

ROOT = Path(__file__).resolve().parent.parent
TF2 = tf2_available()


def test_plunit(swipl, tmp_path):
    program = tmp_path / "tf_host.pl"
    program.write_text(compile_source("host_rule(X) <- host_event(X).\n", "tf_host.rtl",
                                      module="tf_host").prolog)
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_tf.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120,
                          env={**os.environ, "TF_TEST_PROGRAM": str(program)})
    assert proc.returncode == 0, proc.stdout


@pytest.mark.skipif(not TF2, reason="tf2's Python binding is not installed (apt-get install python3-tf2)")
@settings(max_examples=6, deadline=None, phases=[Phase.explicit, Phase.reuse, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.integers(0, 2**32 - 1))
def test_same_answers_as_tf2(swipl, seed):
    ops = scenario(seed)
    ours, theirs = run_both(ops, swipl)
    assert differences(ours, theirs, ops) == []


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
