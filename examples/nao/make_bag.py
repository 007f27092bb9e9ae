"""Write a ROS 1 bag at the load of the thesis's NAO application (chapter 5) with the true
world pose of every marker detection, to check examples/nao/nao.rtl against.

    python examples/nao/make_bag.py OUT.bag [--seconds 60] [--seed 1] [--force]

writes OUT.bag and OUT.truth.jsonl. The recording:

- `/tf` (tf2_msgs/TFMessage): 52 frame pairs of a NAO-like robot, in four groups published at
  50, 25, 10 and 8 Hz (30, 12, 8 and 2 pairs): 1,896 transforms per second once the messages
  are split. Among them the camera's chain `/odom` -> `/base_link` (10 Hz: the base drives
  on a circle), `base_link` -> `torso` (25 Hz: bobs and pitches), `torso` -> `Neck` (50 Hz:
  the head turns), `Neck` -> `Head` (50 Hz: the head nods), `Head` -> `CameraTop_frame`
  (8 Hz: fixed). Every value is a smooth function of time (`chain_pose`), sampled exactly
  at the message's stamp; a message is recorded 1-3 ms after its stamp.
- `/ar_pose_marker` (ar_pose/ARMarkers, a custom type whose definition the bag embeds):
  about 7 detections per second of 8 markers `4x4_1` .. `4x4_8`; 1-7 stand still in the
  world, 4x4_8 is carried around (`marker_world_pose`). A detection holds the marker's pose
  relative to the camera at its stamp and is recorded 50-300 ms after the stamp, so
  detections arrive late and out of order with the transforms.
- `/face_recognition/feedback` (face_recognition/FaceRecognitionFeedback, custom, no
  header: its time is the record time): 5 per second; `alice` (confidence 0.6-0.95) from
  2 s to 8 s of every 10 s, otherwise `bob` at 0.2-0.45.

OUT.truth.jsonl has one line per detection: marker name, header seq, stamp `[sec, nsec]`,
and the true world `position` [x, y, z] and `orientation` [qx, qy, qz, qw] at the stamp.
The same arguments give the same bytes.
"""
from __future__ import annotations

import argparse
import json
import math
import random
import sys
from pathlib import Path
from typing import List, Sequence, Tuple

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from retalisc.robot_io import require  # noqa: E402
from retalisc.robot_io.bags import BagError, write_bag  # noqa: E402
from retalisc.robot_io.samples import sample_store  # noqa: E402

START_S = 1413748205                       # the stamp of the thesis's Figure A.1
FACE_MSG = """uint8 order_id
string[] names
float32[] confidence
"""
CHAIN = [("/odom", "/base_link"), ("base_link", "torso"), ("torso", "Neck"), ("Neck", "Head"),
         ("Head", "CameraTop_frame")]
_JOINTS = ["ShoulderPitch", "ShoulderRoll", "ElbowYaw", "ElbowRoll", "WristYaw", "Hand", "HipYawPitch",
           "HipRoll", "HipPitch", "KneePitch", "AnklePitch", "AnkleRoll", "Finger11", "Finger12",
           "Finger13", "Finger21", "Finger22", "Finger23", "Thumb1", "Thumb2", "Sonar", "Foot", "Bumper",
           "Gripper"]
_OTHERS = [("torso", side + joint) for joint in _JOINTS for side in ("L", "R")][:47]
# (rate in Hz, stamp offset in ms, pairs): 30 + 12 + 8 + 2 pairs.
GROUPS = [(50, 0, [CHAIN[2], CHAIN[3]] + _OTHERS[:28]),
          (25, 3, [CHAIN[1]] + _OTHERS[28:39]),
          (10, 7, [CHAIN[0]] + _OTHERS[39:46]),
          (8, 11, [CHAIN[4]] + _OTHERS[46:47])]
MARKERS = [f"4x4_{k}" for k in range(1, 9)]

Vec = List[float]
Quat = List[float]
Pose = Tuple[Vec, Quat]


# ---- poses (plain math; quaternions [x, y, z, w] as in ROS) -------------------------------

def axis_quat(axis: str, angle: float) -> Quat:
    s, c = math.sin(angle / 2), math.cos(angle / 2)
    return {"x": [s, 0.0, 0.0, c], "y": [0.0, s, 0.0, c], "z": [0.0, 0.0, s, c]}[axis]


def qmul(a: Quat, b: Quat) -> Quat:
    x1, y1, z1, w1 = a
    x2, y2, z2, w2 = b
    return [w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2]


def qrot(q: Quat, v: Vec) -> Vec:
    r = qmul(qmul(q, [v[0], v[1], v[2], 0.0]), [-q[0], -q[1], -q[2], q[3]])
    return r[:3]


def compose(a: Pose, b: Pose) -> Pose:
    v = qrot(a[1], b[0])
    return [a[0][i] + v[i] for i in range(3)], qmul(a[1], b[1])


def inverse(p: Pose) -> Pose:
    qc = [-p[1][0], -p[1][1], -p[1][2], p[1][3]]
    v = qrot(qc, p[0])
    return [-v[0], -v[1], -v[2]], qc


def chain_pose(pair: Tuple[str, str], t: float) -> Pose:
    """The transform of a frame pair at t seconds after the start."""
    if pair == CHAIN[0]:        # the base drives on a circle of radius 1 m at 0.15 rad/s
        w = 0.15
        return [math.sin(w * t), 1.0 - math.cos(w * t), 0.0], axis_quat("z", w * t)
    if pair == CHAIN[1]:
        return [0.0, 0.0, 0.3 + 0.01 * math.sin(2.0 * t)], axis_quat("y", 0.05 * math.sin(0.5 * t))
    if pair == CHAIN[2]:        # head yaw
        return [0.0, 0.0, 0.1265], axis_quat("z", 0.6 * math.sin(0.4 * t))
    if pair == CHAIN[3]:        # head pitch
        return [0.0, 0.0, 0.0], axis_quat("y", 0.2 * math.sin(0.3 * t + 0.5))
    if pair == CHAIN[4]:        # fixed camera mount
        return [0.0539, 0.0, 0.0679], axis_quat("y", 0.0209)
    k = _OTHERS.index(pair)
    return [0.01 * k, 0.1 if k % 2 else -0.1, 0.05], axis_quat("x", 0.3 * math.sin(0.7 * t + k))


def camera_pose(t: float) -> Pose:
    pose: Pose = ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])
    for pair in CHAIN:
        pose = compose(pose, chain_pose(pair, t))
    return pose


def marker_world_pose(k: int, t: float) -> Pose:
    """Marker 4x4_k in the world: 1-7 fixed around the robot's path, 8 carried around."""
    if k == 8:
        return ([2.0 + 0.3 * math.sin(0.5 * t), 0.4 * math.cos(0.4 * t), 0.5],
                qmul(axis_quat("z", 0.3 * t), axis_quat("x", 0.2)))
    angle = 2 * math.pi * k / 7
    return ([1.0 + 2.0 * math.cos(angle), 1.0 + 2.0 * math.sin(angle), 0.2 + 0.1 * k],
            qmul(axis_quat("z", angle + math.pi), axis_quat("y", 0.1 * k)))


# ---- the recording --------------------------------------------------------------------------

def records(seconds: float, seed: int):
    """(record_ns, topic, msgtype, msg) in record order, and the ground truth."""
    numpy = require("numpy", "writing the NAO bag")
    typesys = require("rosbags.typesys", "writing the NAO bag")
    store = sample_store(1)
    store.register(typesys.get_types_from_msg(FACE_MSG, "face_recognition/msg/FaceRecognitionFeedback"))
    T = store.types
    rng = random.Random(seed)
    start = START_S * 1_000_000_000
    end = start + int(seconds * 1e9)
    made = []
    seq = [0]

    def header(ns: int, frame: str):
        seq[0] += 1
        return T["std_msgs/msg/Header"](seq=seq[0], stamp=T["builtin_interfaces/msg/Time"](
            sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id=frame)

    def pose_msg(p: Pose):
        return T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=p[0][0], y=p[0][1], z=p[0][2]),
                                           orientation=T["geometry_msgs/msg/Quaternion"](
                                               x=p[1][0], y=p[1][1], z=p[1][2], w=p[1][3]))

    for rate, offset_ms, pairs in GROUPS:
        ns = start + offset_ms * 1_000_000
        k = 0
        while ns < end:
            t = (ns - start) / 1e9
            transforms = []
            for pair in pairs:
                v, q = chain_pose(pair, t)
                transforms.append(T["geometry_msgs/msg/TransformStamped"](
                    header=header(ns, pair[0]), child_frame_id=pair[1],
                    transform=T["geometry_msgs/msg/Transform"](
                        translation=T["geometry_msgs/msg/Vector3"](x=v[0], y=v[1], z=v[2]),
                        rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))))
            made.append((ns + rng.randrange(1_000_000, 3_000_000), "/tf", "tf2_msgs/msg/TFMessage",
                         T["tf2_msgs/msg/TFMessage"](transforms=transforms)))
            k += 1
            ns = start + offset_ms * 1_000_000 + k * 1_000_000_000 // rate

    truth = []
    ns = start + 200_000_000
    while ns < end - 500_000_000:
        t = (ns - start) / 1e9
        names = [8 if rng.random() < 0.3 else rng.randint(1, 7)]
        if rng.random() < 0.1:
            names.append(rng.choice([k for k in range(1, 9) if k != names[0]]))
        cam_inv = inverse(camera_pose(t))
        markers = []
        for k in names:
            world = marker_world_pose(k, t)
            relative = compose(cam_inv, world)
            h = header(ns, f"4x4_{k}")
            markers.append(T["ar_pose/msg/ARMarker"](
                header=h, id=k,
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose_msg(relative),
                                                               covariance=numpy.zeros(36, dtype=numpy.float64)),
                confidence=rng.randrange(60, 100)))
            truth.append({"marker": f"4x4_{k}", "seq": h.seq, "stamp": [ns // 1_000_000_000, ns % 1_000_000_000],
                          "position": world[0], "orientation": world[1]})
        made.append((ns + rng.randrange(50, 301) * 1_000_000, "/ar_pose_marker", "ar_pose/msg/ARMarkers",
                     T["ar_pose/msg/ARMarkers"](header=header(ns, "CameraTop_frame"), markers=markers)))
        ns += rng.randrange(110, 180) * 1_000_000

    ns = start + 100_000_000
    while ns < end:
        t = ((ns - start) / 1e9) % 10.0
        if 2.0 <= t < 8.0:
            name, confidence = "alice", rng.uniform(0.6, 0.95)
        else:
            name, confidence = "bob", rng.uniform(0.2, 0.45)
        made.append((ns, "/face_recognition/feedback", "face_recognition/msg/FaceRecognitionFeedback",
                     T["face_recognition/msg/FaceRecognitionFeedback"](
                         order_id=1, names=[name], confidence=numpy.array([confidence], dtype=numpy.float32))))
        ns += 200_000_000

    made.sort(key=lambda r: r[0])
    return store, made, truth


def write(out: Path, seconds: float = 60.0, seed: int = 1, overwrite: bool = False) -> Tuple[Path, Path]:
    """Write OUT (a ROS 1 .bag) and OUT.truth.jsonl (OUT without .bag); returns both paths.
    With `overwrite`, an OUT already there is replaced."""
    store, made, truth = records(seconds, seed)
    out = Path(out)
    write_bag(out, "ros1", store, [(topic, msgtype, ns, msg) for ns, topic, msgtype, msg in made],
              overwrite=overwrite)
    truth_path = truth_file(out)
    truth_path.write_text("".join(json.dumps(row) + "\n" for row in truth), encoding="utf-8")
    return out, truth_path


def truth_file(bag: Path) -> Path:
    bag = Path(bag)
    return bag.with_name(bag.name[:-4] + ".truth.jsonl" if bag.name.endswith(".bag") else bag.name + ".truth.jsonl")


def main(argv: Sequence[str] = None) -> int:
    parser = argparse.ArgumentParser(prog="make_bag.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="the .bag file to write (with OUT.truth.jsonl beside it)")
    parser.add_argument("--seconds", type=float, default=60.0, help="length of the recording (default 60)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--force", action="store_true", help="overwrite OUT and its ground truth")
    args = parser.parse_args(argv)
    if not args.out.endswith(".bag"):
        parser.error("OUT must end in .bag")
    if Path(args.out).exists() and not args.force:
        parser.error(f"{args.out} exists already (--force replaces it)")
    if args.seconds <= 1:
        parser.error("--seconds must be over 1")
    try:
        bag, truth = write(Path(args.out), args.seconds, args.seed, overwrite=args.force)
    except BagError as error:
        parser.error(str(error))
    print(f"{bag}: ROS 1, {args.seconds:g} s; ground truth in {truth}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
