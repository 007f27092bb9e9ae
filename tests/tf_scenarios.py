"""Random tf scenarios (operations of tests/tf_driver.pl) and the comparison of two runs of
one, for tests/test_tf.py and benchmarks/tf_lookup.py."""
from __future__ import annotations

import json
import math
import os
import random
import subprocess
import tempfile
from pathlib import Path
from typing import List, Optional

ROOT = Path(__file__).resolve().parent.parent
SYSTEM_PYTHON = "/usr/bin/python3"
SECOND = 1_000_000_000


def tf2_available() -> bool:
    try:
        return subprocess.run([SYSTEM_PYTHON, "-c", "import tf2_py, rospy"], capture_output=True,
                              timeout=60).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def unit_quaternion(rng: random.Random) -> List[float]:
    q = [rng.gauss(0, 1) for _ in range(4)]
    n = math.sqrt(sum(x * x for x in q))
    return [x / n for x in q]


def scenario(seed: int, frames: int = 8, steps: int = 120) -> list:
    """A tree of `frames` frames (f1.. each under an earlier one, some static), a second
    tree g0-g1, transforms arriving mostly in stamp order (some late, some repeated, a few
    changing parent), and lookups between random frames at the latest time, at stamps, between
    them and outside the data."""
    rng = random.Random(seed)
    ops: list = []
    if rng.random() < 0.5:
        ops.append(["buffer", rng.choice([1, 2, 5])])
    names = [f"f{i}" for i in range(frames)]
    parent = {i: rng.randrange(i) for i in range(1, frames)}
    static = {i: rng.random() < 0.3 for i in range(1, frames)}
    t0 = 1_000 * SECOND + rng.randrange(SECOND)
    for i in range(1, frames):
        if static[i]:
            ops.append(["add", names[parent[i]], names[i], 0, [rng.uniform(-1, 1) for _ in range(3)],
                        unit_quaternion(rng), True])
    ops.append(["add", "g0", "g1", t0, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], False])
    stamps: list = []
    now = t0
    for _ in range(steps):
        now += rng.randrange(SECOND // 20, SECOND // 2)
        for i in range(1, frames):
            if static[i] or rng.random() < 0.3:
                continue
            stamp = now - (rng.randrange(3 * SECOND) if rng.random() < 0.1 else 0)
            if rng.random() < 0.05 and stamps:
                stamp = rng.choice(stamps)
            if rng.random() < 0.03:
                parent[i] = rng.randrange(i)
            stamps.append(stamp)
            ops.append(["add", names[parent[i]], names[i], stamp,
                        [rng.uniform(-2, 2) for _ in range(3)], unit_quaternion(rng), False])
        for _ in range(rng.randrange(3)):
            ops.append([rng.choice(["lookup", "lookup", "can"]), *lookup_pair(rng, names), lookup_time(rng, now, stamps)])
    for _ in range(40):
        ops.append(["lookup", *lookup_pair(rng, names), lookup_time(rng, now, stamps)])
    return ops


def lookup_pair(rng: random.Random, names: List[str]) -> List[str]:
    pool = names + ["g0", "g1"] + (["nowhere"] if rng.random() < 0.05 else [])
    return [rng.choice(pool), rng.choice(pool)]


def lookup_time(rng: random.Random, now: int, stamps: List[int]) -> int:
    choice = rng.random()
    if choice < 0.2:
        return 0
    if choice < 0.4 and stamps:
        return rng.choice(stamps)
    return now - rng.randrange(-SECOND, 12 * SECOND)


def run_library(ops: list, swipl: str = "swipl", road: Optional[str] = None) -> list:
    """The tf library's lines of one scenario (on `road`, c or prolog, else the default), as
    parsed JSON."""
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump({"ops": ops}, f)
        path = f.name
    env = {**os.environ, **({"RTL_TF_ROAD": road} if road else {})}
    try:
        ours = subprocess.run([swipl, str(ROOT / "tests" / "tf_driver.pl"), path], capture_output=True,
                              text=True, timeout=300, check=True, env=env).stdout
    finally:
        Path(path).unlink()
    return [json.loads(x) for x in ours.splitlines()]


def run_both(ops: list, swipl: str = "swipl") -> tuple:
    """(tf library lines, tf2 lines) of one scenario, as parsed JSON."""
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump({"ops": ops}, f)
        path = f.name
    try:
        ours = subprocess.run([swipl, str(ROOT / "tests" / "tf_driver.pl"), path], capture_output=True,
                              text=True, timeout=300, check=True).stdout
        theirs = subprocess.run([SYSTEM_PYTHON, str(ROOT / "tests" / "tf2_oracle.py"), path],
                                capture_output=True, text=True, timeout=300, check=True).stdout
    finally:
        Path(path).unlink()
    return [json.loads(x) for x in ours.splitlines()], [json.loads(x) for x in theirs.splitlines()]


def rotation_degrees(q1, q2) -> float:
    """The angle between two rotations (well conditioned for close ones, unlike acos)."""
    if sum(a * b for a, b in zip(q1, q2)) < 0:
        q2 = [-x for x in q2]
    diff = math.sqrt(sum((a - b) ** 2 for a, b in zip(q1, q2)))
    total = math.sqrt(sum((a + b) ** 2 for a, b in zip(q1, q2)))
    return math.degrees(4 * math.atan2(diff, total))


def differences(ours: list, theirs: list, ops: list) -> List[str]:
    """What differs between the two runs (empty when they agree within 1e-9 m, 1e-6 degree,
    with the same stamps and the same failures)."""
    queries = [op for op in ops if op[0] in ("lookup", "can")]
    found = []
    if len(ours) != len(theirs):
        return [f"{len(ours)} answers against tf2's {len(theirs)}"]
    for op, a, b in zip(queries, ours, theirs):
        if "can" in b:
            if a != b:
                found.append(f"{op}: {a} against tf2's {b}")
        elif "pose" in b:
            # (tf2's Python binding carries times as a double number of seconds: exact to
            # about 0.2 us at 1.7e9 s; benchmarks/tf_lookup.py compares stamps exactly with tf2 C++)
            if "pose" not in a or abs(a["stamp"] - b["stamp"]) > 1000 \
                    or max(abs(x - y) for x, y in zip(a["pose"][:3], b["pose"][:3])) > 1e-9 \
                    or rotation_degrees(a["pose"][3:], b["pose"][3:]) > 1e-6:
                found.append(f"{op}: {a} against tf2's {b}")
        elif not same_reason(a.get("error"), b["error"]):
            found.append(f"{op}: {a} against tf2's {b}")
    return found


def same_reason(ours, theirs) -> bool:
    if ours is None:
        return False
    if theirs[0] != "extrapolation" or ours[0] != "extrapolation":
        return ours == theirs
    _, direction, requested, earliest, latest = ours
    bound = earliest if direction == "past" else latest
    # tf2 writes the times of its message as a double number of seconds (printf %.09f):
    # at 1.7e9 s that is exact to about 0.2 us only
    return direction == theirs[1] and abs(requested - theirs[2]) <= 1000 and abs(bound - theirs[3]) <= 1000
