"""A synthetic recording in the shape of the thesis's NAO application (A.2), written with
rosbags writers in any of the three formats: the repository's own sample bags (tests, the
benchmark, examples), so nothing depends on downloaded data.

Topics (stamps start at `start_s`, record times follow in arrival order):

- `/tf` (tf2_msgs/TFMessage, `tf_rate` per second): the chain `/odom` -> `/base_link` (with
  slashes, as the release's recordings), `base_link` -> `torso` -> `Neck` -> `Head` ->
  `CameraTop_frame`, one message holding the five transforms; recorded 1 ms after its stamp.
  The robot drives along x at 0.2 m/s and turns its head slowly.
- `/ar_pose_marker` (ar_pose/ARMarkers, a custom type, about 7 per second): markers `4x4_1`
  and `4x4_2` seen by the camera; a detection is recorded 50-300 ms after its stamp, so
  detections arrive late and their record order differs from their stamp order.
- `/robot_pose` (geometry_msgs/PoseStamped, 10 per second): the base in the odom frame.
- `/markers_viz` (visualization_msgs/MarkerArray, 2 per second): three sphere markers.

The same arguments give the same messages in every format (ROS 1 headers add `seq`).
"""
from __future__ import annotations

import argparse
import math
import random
from pathlib import Path
from typing import List, Tuple

from . import require
from .bags import BagError, typestore, write_bag

AR_MARKERS_MSG = """Header header
ARMarker[] markers
"""
AR_MARKER_MSG = """Header header
uint32 id
geometry_msgs/PoseWithCovariance pose
uint32 confidence
"""
TF_CHAIN = [("/odom", "/base_link"), ("base_link", "torso"), ("torso", "Neck"), ("Neck", "Head"),
            ("Head", "CameraTop_frame")]

Records = List[Tuple[str, str, int, object]]


def sample_store(ros_version: int):
    """The type store of the sample recording: ROS 1 noetic or ROS 2 humble, plus ar_pose."""
    typesys = require("rosbags.typesys", "writing sample bags")
    store = typestore("ros1_noetic" if ros_version == 1 else "ros2_humble")
    types = {}
    types.update(typesys.get_types_from_msg(AR_MARKERS_MSG, "ar_pose/msg/ARMarkers"))
    types.update(typesys.get_types_from_msg(AR_MARKER_MSG, "ar_pose/msg/ARMarker"))
    store.register(types)
    return store


class _Builder:
    def __init__(self, store):
        self.store = store
        self.t = store.types
        self.ros1 = "seq" in dict(store.fielddefs["std_msgs/msg/Header"][1])
        self.seq = 0

    def time(self, ns: int):
        return self.t["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def header(self, ns: int, frame: str):
        if self.ros1:
            self.seq += 1
            return self.t["std_msgs/msg/Header"](seq=self.seq, stamp=self.time(ns), frame_id=frame)
        return self.t["std_msgs/msg/Header"](stamp=self.time(ns), frame_id=frame)

    def vector(self, x, y, z):
        return self.t["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def point(self, x, y, z):
        return self.t["geometry_msgs/msg/Point"](x=x, y=y, z=z)

    def quaternion(self, yaw: float):
        return self.t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))

    def pose(self, x, y, z, yaw):
        return self.t["geometry_msgs/msg/Pose"](position=self.point(x, y, z), orientation=self.quaternion(yaw))


def nao_records(store, seconds: float = 4.0, tf_rate: float = 50.0, start_s: float = 1413748205.0,
                seed: int = 1) -> Records:
    """The messages of the sample recording for `store` (from sample_store), sorted by
    record time (ties keep the order they were made in)."""
    numpy = require("numpy", "writing sample bags")
    b = _Builder(store)
    rng = random.Random(seed)
    start = int(start_s * 1_000_000_000)
    made: List[Tuple[int, int, Tuple[str, str, int, object]]] = []

    def add(record_ns: int, topic: str, msgtype: str, msg) -> None:
        made.append((record_ns, len(made), (topic, msgtype, record_ns, msg)))

    steps = int(seconds * tf_rate)
    for k in range(steps):
        ns = start + int(k * 1_000_000_000 / tf_rate)
        t = (ns - start) / 1e9
        values = [((0.2 * t, 0.0, 0.0), 0.0), ((0.0, 0.0, 0.3), 0.0), ((0.0, 0.0, 0.1), 0.0),
                  ((0.0, 0.0, 0.05), 0.3 * math.sin(t)), ((0.05, 0.0, 0.06), 0.0)]
        transforms = [
            b.t["geometry_msgs/msg/TransformStamped"](
                header=b.header(ns, parent), child_frame_id=child,
                transform=b.t["geometry_msgs/msg/Transform"](translation=b.vector(*xyz), rotation=b.quaternion(yaw)))
            for (parent, child), (xyz, yaw) in zip(TF_CHAIN, values)]
        add(ns + 1_000_000, "/tf", "tf2_msgs/msg/TFMessage", b.t["tf2_msgs/msg/TFMessage"](transforms=transforms))
    for k in range(int(seconds * 10)):
        ns = start + k * 100_000_000
        t = k / 10
        add(ns + 2_000_000, "/robot_pose", "geometry_msgs/msg/PoseStamped",
            b.t["geometry_msgs/msg/PoseStamped"](header=b.header(ns, "/odom"), pose=b.pose(0.2 * t, 0.0, 0.0, 0.0)))
    for k in range(int(seconds * 2)):
        ns = start + k * 500_000_000
        markers = []
        for i in range(3):
            markers.append(b.t["visualization_msgs/msg/Marker"](**_marker_fields(b, store, ns, i, numpy)))
        add(ns + 3_000_000, "/markers_viz", "visualization_msgs/msg/MarkerArray",
            b.t["visualization_msgs/msg/MarkerArray"](markers=markers))
    ns = start + 120_000_000
    end = start + int(seconds * 1_000_000_000) - 400_000_000
    while ns < end:
        name, ident = rng.choice([("4x4_1", 1), ("4x4_2", 2)])
        covariance = numpy.zeros(36, dtype=numpy.float64)
        marker = b.t["ar_pose/msg/ARMarker"](
            header=b.header(ns, name), id=ident,
            pose=b.t["geometry_msgs/msg/PoseWithCovariance"](
                pose=b.pose(0.1 * ident, 0.05, 1.0 + 0.1 * rng.random(), 0.0), covariance=covariance),
            confidence=rng.randrange(50, 100))
        message = b.t["ar_pose/msg/ARMarkers"](header=b.header(ns, "CameraTop_frame"), markers=[marker])
        add(ns + rng.randrange(50, 300) * 1_000_000, "/ar_pose_marker", "ar_pose/msg/ARMarkers", message)
        ns += rng.randrange(100, 190) * 1_000_000
    made.sort(key=lambda item: (item[0], item[1]))
    return [record for _, _, record in made]


def _marker_fields(b: _Builder, store, ns: int, i: int, numpy) -> dict:
    """The fields of a sphere Marker for this store's Marker definition (ROS 2 distributions
    differ in the texture and mesh fields)."""
    t = b.t
    values = {
        "header": b.header(ns, "/odom"), "ns": "objects", "id": i, "type": 2, "action": 0,
        "pose": b.pose(1.0 + i, 0.5, 0.0, 0.0), "scale": b.vector(0.1, 0.1, 0.1),
        "color": t["std_msgs/msg/ColorRGBA"](r=1.0, g=0.2 * i, b=0.0, a=1.0),
        "lifetime": t["builtin_interfaces/msg/Duration"](sec=0, nanosec=500_000_000),
        "frame_locked": False, "points": [], "colors": [], "text": f"object {i}", "mesh_resource": "",
        "mesh_use_embedded_materials": False,
    }
    fields = dict(store.fielddefs["visualization_msgs/msg/Marker"][1])
    extra = {
        "texture_resource": "", "uv_coordinates": [],
        "texture": t.get("sensor_msgs/msg/CompressedImage") and t["sensor_msgs/msg/CompressedImage"](
            header=b.header(ns, ""), format="", data=numpy.zeros(0, dtype=numpy.uint8)),
        "mesh_file": t.get("visualization_msgs/msg/MeshFile") and t["visualization_msgs/msg/MeshFile"](
            filename="", data=numpy.zeros(0, dtype=numpy.uint8)),
    }
    for name in fields:
        if name not in values:
            values[name] = extra[name]
    return {name: values[name] for name in fields}


def write_nao_bag(path, fmt: str, seconds: float = 4.0, tf_rate: float = 50.0, seed: int = 1,
                  overwrite: bool = False) -> Path:
    """Write the sample recording in format `fmt` (`ros1`, `ros2`, `mcap`) at `path` (a .bag
    file for ros1, a folder otherwise); with `overwrite`, a recording there is replaced.
    Returns the path to open."""
    store = sample_store(1 if fmt == "ros1" else 2)
    return write_bag(path, fmt, store, nao_records(store, seconds, tf_rate, seed=seed), overwrite=overwrite)


def shared_bags_dir(root) -> "Path | None":
    """The shared sample recordings, `../shared/data/bags` next to the repository `root` (for
    a git worktree, also next to its main checkout), or None when absent. They are test input
    only: never copied into the repository (see their PROVENANCE.md)."""
    root = Path(root).resolve()
    candidates = [root.parent / "shared" / "data" / "bags"]
    dot_git = root / ".git"
    if dot_git.is_file():
        text = dot_git.read_text(encoding="utf-8").strip()
        if text.startswith("gitdir:"):
            gitdir = (root / text.split(":", 1)[1].strip()).resolve()
            common = gitdir / "commondir"
            main_git = (gitdir / common.read_text(encoding="utf-8").strip()).resolve() if common.exists() else gitdir
            candidates.append(main_git.parent.parent / "shared" / "data" / "bags")
    for candidate in candidates:
        if candidate.is_dir():
            return candidate
    return None


def main(argv=None) -> int:
    """`python -m retalisc.robot_io.samples OUT [--format ros1|ros2|mcap] [--seconds S]
    [--tf-rate HZ] [--force]`: write the sample recording."""
    parser = argparse.ArgumentParser(prog="python -m retalisc.robot_io.samples",
                                     description="Write the sample recording of the NAO application (thesis A.2).")
    parser.add_argument("out", help="a .bag file (ros1) or a folder to create (ros2, mcap)")
    parser.add_argument("--format", choices=("ros1", "ros2", "mcap"), default=None,
                        help="default: ros1 for a .bag name, else ros2")
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--tf-rate", type=float, default=50.0, help="TFMessages per second")
    parser.add_argument("--force", action="store_true", help="replace a recording already at OUT")
    args = parser.parse_args(argv)
    fmt = args.format or ("ros1" if args.out.endswith(".bag") else "ros2")
    if Path(args.out).exists() and not args.force:
        parser.error(f"{args.out} exists already (--force replaces it)")
    try:
        path = write_nao_bag(args.out, fmt, seconds=args.seconds, tf_rate=args.tf_rate, overwrite=args.force)
    except BagError as error:
        parser.error(str(error))
    print(f"{path}: {fmt}, {args.seconds:g} s", file=__import__("sys").stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
