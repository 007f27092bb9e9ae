"""examples/nao/nao_tf.rtl and examples/nao_markers/nao_markers_tf.rtl (the NAO component written with
the tf library) against the originals examples/nao/nao.rtl and nao_markers.rtl on the same recording.

The same detections get a world pose, with the same stamps. The poses agree to 1e-6 m and
1e-5 degree, not 1e-9: the original turns each stamp into seconds as a float (about 0.2 us
of resolution at 1.4e9 s) before interpolating, which moves its poses by up to about 1e-7 m
at the robot's speeds, where the tf library interpolates at the integer-nanosecond stamp as
tf2 does (its lookups are checked against tf2 to 1e-9 m in tests/test_tf.py)."""
from __future__ import annotations

import json
import math
import re

import pytest

from test_nao_application import angle_between, load_make_bag, retalisc, world_poses


@pytest.fixture(scope="module")
def bag4(tmp_path_factory):
    bag, _ = load_make_bag().write(tmp_path_factory.mktemp("nao_tf") / "nao.bag", seconds=4.0, seed=6)
    return bag


def poses(program, bag):
    run = retalisc("run", program, "--bag", str(bag))
    assert run.returncode == 0, run.stderr
    derived, _ = world_poses(run.stdout)
    return {key: pose for key, _, pose in derived}


def assert_same_poses(mine, original):
    """The same detections, at 1e-6 m and 1e-5 degree (see the module docstring)."""
    assert len(mine) >= 20 and set(mine) == set(original)
    worst_m = max(math.dist(mine[k][0], original[k][0]) for k in mine)
    worst_degree = max(math.degrees(angle_between(mine[k][1], original[k][1])) for k in mine)
    assert worst_m < 1e-6 and worst_degree < 1e-5, (worst_m, worst_degree)


def test_same_world_poses_as_the_original(bag4):
    mine = poses("examples/nao/nao_tf.rtl", bag4)
    original = poses("examples/nao/nao.rtl", bag4)
    assert_same_poses(mine, original)


MARKER_POSE = re.compile(r"marker_pose\('([^']+)',geometry_msgs__0__PoseStamped\(std_msgs__0__Header\(\[(\d+),(\d+)\],odom\),"
                         r"geometry_msgs__0__Pose\(geometry_msgs__0__Point\(([^,]+),([^,]+),([^)]+)\),"
                         r"geometry_msgs__0__Quaternion\(([^,]+),([^,]+),([^,]+),([^)]+)\)\)\)\)")


def marker_poses(program, bag):
    run = retalisc("run", program, "--bag", str(bag))
    assert run.returncode == 0, run.stderr
    found = {}
    for line in run.stdout.splitlines():
        row = json.loads(line)
        match = MARKER_POSE.fullmatch(row["event"])
        if match:                     # a derived pose, or its delivery (printed once)
            numbers = [float(x) for x in match.groups()[3:]]
            found[(match[1], int(match[2]), int(match[3]))] = (numbers[:3], numbers[3:])
    return found


def test_nao_markers_same_world_poses_as_the_original(bag4):
    mine = marker_poses("examples/nao_markers/nao_markers_tf.rtl", bag4)
    original = marker_poses("examples/nao_markers/nao_markers.rtl", bag4)
    assert_same_poses(mine, original)
