"""Helpers of the robot I/O tests: the sample recordings and message comparison."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

rosbags = pytest.importorskip("rosbags", reason="the robot I/O tests need the 'ros' extra (rosbags)")

from retalisc.driver.values import Term, read_term  # noqa: E402
from retalisc.robot_io.samples import shared_bags_dir  # noqa: E402

SHARED_BAGS = shared_bags_dir(ROOT)
SHARED_REASON = ("the shared sample bags (../shared/data/bags next to the repository, see its "
                 "PROVENANCE.md) are not on this machine")
SHARED_NAMES = ["evo_nav2_turtlebot.mcap", "evo_tf_example.bag", "evo_tf_example_ros2",
                "fiducials_aruco_transforms.bag", "tf_bag_franka.bag", "tf_bag_franka_ros2"]
ROS1_ROS2_PAIRS = [("evo_tf_example.bag", "evo_tf_example_ros2"), ("tf_bag_franka.bag", "tf_bag_franka_ros2")]


def shared_bag(name: str) -> Path:
    if SHARED_BAGS is None:
        pytest.skip(SHARED_REASON)
    path = SHARED_BAGS / name
    if not path.exists():
        pytest.skip(f"{path} is missing from the shared sample bags")
    return path


def same_value(a, b) -> bool:
    """Deep equality of decoded messages: numpy arrays by element, NaN equal to NaN."""
    if hasattr(a, "__dataclass_fields__") and hasattr(b, "__dataclass_fields__"):
        return type(a).__name__ == type(b).__name__ and all(
            same_value(getattr(a, name), getattr(b, name)) for name in a.__dataclass_fields__)
    if hasattr(a, "tolist"):
        a = a.tolist()
    if hasattr(b, "tolist"):
        b = b.tolist()
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and a == b


def without_seq(text: str):
    """An event term with the ROS 1 header's seq dropped and the package prefix of every
    message functor set aside (`tf2_msgs__0__TFMessage` -> `TFMessage`): what a ROS 1 and a
    ROS 2 recording of the same data have in common."""
    def walk(value):
        if isinstance(value, list):
            return [walk(v) for v in value]
        if isinstance(value, Term):
            args = value.args
            if value.name == "std_msgs__0__Header" and len(args) == 3:
                args = args[1:]
            return Term(re.sub(r"^.*__0__", "", value.name), tuple(walk(a) for a in args))
        return value
    return walk(read_term(text))
