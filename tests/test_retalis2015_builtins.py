"""The builtins of the Retalis 2015 release (prolog_runtime/rtl_math.pl: datime_interpolate/4,
convert_to_datime/2, interpolate_quaternion/6, transform_quaternion/2), which the thesis's
NAO application (Listings A.3-A.4) calls, against an independent computation with numpy:
rotation matrices, 4x4 homogeneous transforms, and the interpolated rotation as
R1 * exp(F * log(R1^T R2)) (axis and angle of the relative rotation), never quaternion slerp.

One swipl subprocess evaluates a whole batch of cases."""
from __future__ import annotations

import calendar
import datetime
import math
from fractions import Fraction

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

np = pytest.importorskip("numpy")

from math_driver import answers as values, pl, run, write_driver  # noqa: E402

BATCH = settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])

@pytest.fixture(scope="module")
def driver(tmp_path_factory, swipl):
    return swipl, write_driver(tmp_path_factory.mktemp("rtl2015"))


# ---- the oracle ------------------------------------------------------------------------------

def rot(q):
    """Rotation matrix of a quaternion [x, y, z, w] (normalised here)."""
    x, y, z, w = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def hom(pose):
    h = np.eye(4)
    h[:3, :3] = rot(pose[1])
    h[:3, 3] = pose[0]
    return h


def log_rot(r):
    """Axis * angle of a rotation matrix whose angle is below pi."""
    angle = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1) / 2)))
    if angle < 1e-12:
        return np.zeros(3)
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / (2 * math.sin(angle))
    return axis * angle


def exp_rot(w):
    angle = np.linalg.norm(w)
    if angle < 1e-15:
        return np.eye(3)
    k = w / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx @ kx


def rotation_angle(r1, r2) -> float:
    return math.acos(max(-1.0, min(1.0, (np.trace(r1.T @ r2) - 1) / 2)))


# ---- strategies --------------------------------------------------------------------------------

coord = st.floats(-10, 10, allow_nan=False)
vec = st.lists(coord, min_size=3, max_size=3)


@st.composite
def quat(draw):
    q = draw(st.lists(st.floats(-1, 1, allow_nan=False), min_size=4, max_size=4))
    if sum(c * c for c in q) < 0.01:
        q = [0.0, 0.0, 0.0, 1.0]
    return q


@st.composite
def quat_pair(draw):
    """Two quaternions whose rotations are less than 179 degrees apart (where the shortest
    arc is unique and the oracle's logarithm is well conditioned)."""
    q1 = draw(quat())
    q2 = draw(quat())
    if rotation_angle(rot(q1), rot(q2)) > math.radians(179):
        q2 = q1
    return q1, q2


def batch(strategy, size=20):
    return st.lists(strategy, min_size=1, max_size=size)


# ---- datime_interpolate/4 and convert_to_datime/2 ------------------------------------------------

stamp = st.tuples(st.integers(1_000_000_000, 2_000_000_000), st.integers(0, 999_999_999))


@BATCH
@given(batch(st.tuples(stamp, stamp, stamp)))
def test_datime_interpolate_on_ros_stamps(driver, cases):
    goals = [f"datime_interpolate({pl(a)}, {pl(b)}, {pl(t)}, Out)" for a, b, t in cases]
    for (a, b, t), f in zip(cases, values(driver, goals)):
        na, nb, nt = (s * 10**9 + n for s, n in (a, b, t))
        expected = 0.0 if na == nb else (nt - na) / (nb - na)
        assert f == pytest.approx(expected, rel=1e-12, abs=1e-12)


@BATCH
@given(batch(st.tuples(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4), st.floats(-1e4, 1e4))))
def test_datime_interpolate_on_numbers(driver, cases):
    goals = [f"datime_interpolate({pl(a)}, {pl(b)}, {pl(t)}, Out)" for a, b, t in cases]
    for (a, b, t), (kind, f) in zip(cases, run(driver, goals)):
        expected = 0.0 if a == b else (t - a) / (b - a)
        if math.isinf(expected):  # times a subnormal apart: no float fraction
            assert kind == "error" and "float_overflow" in f
        else:
            assert kind == "ok" and f == pytest.approx(expected, rel=1e-6, abs=1e-6)


def test_datime_interpolate_between_times_too_close_for_a_float_fraction(driver):
    [(kind, message)] = run(driver, ["datime_interpolate(0.0, 2.2250738585e-313, 1.0, Out)"])
    assert kind == "error" and "float_overflow" in message


def test_datime_interpolate_edges(driver):
    goals = [
        "datime_interpolate(5, 5, 7, Out)",                      # equal times: 0
        "datime_interpolate([10, 5], [10, 5], [10, 5], Out)",
        "datime_interpolate([10, 0], [11, 0], [10, 0], Out)",    # T at the first stamp
        "datime_interpolate([10, 0], [11, 0], [11, 0], Out)",    # T at the second stamp
        "datime_interpolate([1413748205, 981209993], [1413748206, 1209993], [1413748205, 991209993], Out)",
        "convert_to_datime([1413748205, 981209993], T), datime_interpolate(T, 1413748206.981209993, T, Out)",
        "datime_interpolate(datime(2014, 10, 19, 20, 0, 0, 0), datime(2014, 10, 19, 20, 0, 10, 0), 1413748805, Out)",
        "datime_interpolate(0, 4, [1, 0], Out)",                 # mixed forms
    ]
    got = values(driver, goals)
    assert got[:4] == [0.0, 0.0, 0.0, 1.0]
    assert got[4] == pytest.approx(0.5, abs=1e-12)
    assert got[5] == 0.0
    assert got[6] == pytest.approx(0.5, abs=1e-9)       # 2014-10-19T20:00:05 UTC
    assert got[7] == 0.25


def test_convert_to_datime_is_the_event_time(driver):
    """The time of a stamp is exactly the time new_event/3 gives an event of that stamp,
    so a record is found at its own stamp."""
    goals = ["convert_to_datime([1413748205, 981209993], Out)",
             "rtl_time:rtl_time_seconds([1413748205, 981209993], Out)",
             "convert_to_datime(12.5, Out)",
             "convert_to_datime([3, 0], Out)",
             "convert_to_datime(datime(1970, 1, 1, 0, 0, 10, 0), Out)"]
    got = values(driver, goals)
    assert got[0] == got[1] == pytest.approx(1413748205.981209993, abs=1e-6)
    assert got[2:] == [12.5, 3, 10.0]
    bad = run(driver, ["convert_to_datime(foo, Out)", "convert_to_datime(_, Out)",
                       "datime_interpolate(1, x, 2, Out)"])
    assert bad[0][0] == "error" and "type_error(time,foo)" in bad[0][1]
    assert bad[1][0] == "error" and "instantiation_error" in bad[1][1]
    assert bad[2][0] == "error" and "type_error(time,x)" in bad[2][1]


# ---- interpolate_quaternion/6 ----------------------------------------------------------------------

@BATCH
@given(batch(st.tuples(vec, vec, quat_pair(), st.floats(0, 1))))
def test_interpolate_quaternion_against_rotation_matrices(driver, cases):
    goals = [f"interpolate_quaternion({pl(v1)}, {pl(q1)}, {pl(v2)}, {pl(q2)}, [{pl(f)}], Out)"
             for v1, v2, (q1, q2), f in cases]
    for (v1, v2, (q1, q2), f), (v, q) in zip(cases, values(driver, goals)):
        expected_v = (1 - f) * np.array(v1) + f * np.array(v2)
        assert np.allclose(v, expected_v, atol=1e-9)
        r1 = rot(q1)
        expected_r = r1 @ exp_rot(f * log_rot(r1.T @ rot(q2)))
        assert abs(np.linalg.norm(q) - 1) < 1e-12
        assert rotation_angle(rot(q), expected_r) < 1e-6


def test_interpolate_quaternion_edges(driver):
    q = [0.1, -0.2, 0.3, 0.9]
    anti = [-c for c in q]
    goals = [f"interpolate_quaternion([0,0,0], {pl(q)}, [1,1,1], {pl(anti)}, [{f}], Out)" for f in (0, 0.3, 1)]
    goals += ["interpolate_quaternion([1,2,3], [0,0,0,1], [1,2,3], [0,0,1,0], 0.5, Out)",   # plain number
              "interpolate_quaternion([0,0,0], [0,0,0,1], [2,0,0], [0,0,0,1], [0], Out)",
              "interpolate_quaternion([0,0,0], [0,0,0,1], [2,0,0], [0,0,0,1], [1], Out)"]
    got = values(driver, goals)
    for v, out_q in got[:3]:
        assert rotation_angle(rot(out_q), rot(q)) < 1e-9     # antipodal: the same rotation throughout
    assert [v for v, _ in got[:3]] == [[0.0, 0.0, 0.0], [0.3, 0.3, 0.3], [1.0, 1.0, 1.0]]
    v, out_q = got[3]
    assert v == [1.0, 2.0, 3.0]
    assert rotation_angle(rot(out_q), exp_rot(np.array([0, 0, math.pi / 2]))) < 1e-9
    assert got[4] == [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    assert got[5] == [[2.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    bad = run(driver, ["interpolate_quaternion([0,0], [0,0,0,1], [0,0,0], [0,0,0,1], [0.5], Out)",
                       "interpolate_quaternion([0,0,0], [0,0,0,0], [0,0,0], [0,0,0,1], [0.5], Out)"])
    assert bad[0][0] == "error" and "vector3" in bad[0][1]
    assert bad[1][0] == "error" and "non_zero_quaternion" in bad[1][1]


# ---- transform_quaternion/2 ----------------------------------------------------------------------

@BATCH
@given(batch(st.lists(st.tuples(vec, quat()), min_size=1, max_size=6)))
def test_transform_quaternion_against_homogeneous_matrices(driver, cases):
    goals = [f"transform_quaternion({pl([[list(v), list(q)] for v, q in poses])}, Out)" for poses in cases]
    for poses, (v, q) in zip(cases, values(driver, goals)):
        h = np.eye(4)
        for pose in poses:
            h = h @ hom(pose)
        assert np.allclose(v, h[:3, 3], atol=1e-8 * max(1.0, np.abs(h[:3, 3]).max()))
        assert abs(np.linalg.norm(q) - 1) < 1e-12
        assert rotation_angle(rot(q), h[:3, :3]) < 1e-6


def test_transform_quaternion_marker_in_world(driver):
    """Listing A.4's use: the chain of five links, then the marker relative to the camera."""
    chain = [[[1, 0, 0], [0, 0, math.sin(0.25), math.cos(0.25)]], [[0, 0, 0.3], [0, 0, 0, 1]],
             [[0, 0, 0.1], [0, 0, 0, 1]], [[0, 0, 0.05], [0, math.sin(0.1), 0, math.cos(0.1)]],
             [[0.05, 0, 0.06], [0, 0, 0, 1]], [[0.2, 0.05, 1.0], [0, 0, 0, 1]]]
    [(v, q)] = values(driver, [f"transform_quaternion({pl(chain)}, Out)"])
    h = np.eye(4)
    for pose in chain:
        h = h @ hom(pose)
    assert np.allclose(v, h[:3, 3], atol=1e-12)
    assert values(driver, ["transform_quaternion([], Out)"]) == [[[0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]]


# ---- exact interpolation at ROS times (issue 40 item 5) ------------------------------------------

def _exact(t) -> Fraction:
    """The exact time a time term stands for: a float's own value, a stamp's Sec + NSec/10^9,
    a datime/7's UTC seconds + Counter/10^9 (the counter is nanoseconds)."""
    if isinstance(t, tuple) and t[0] == "datime":
        _, y, mo, d, h, mi, s, ns = t
        base = calendar.timegm((y, mo, d, h, mi, s, 0, 0, 0))
        return Fraction(base) + Fraction(ns, 10**9)
    if isinstance(t, list):
        return Fraction(t[0]) + Fraction(t[1], 10**9)
    return Fraction(t)


def _time_text(t) -> str:
    if isinstance(t, tuple):
        return "datime(" + ", ".join(str(a) for a in t[1:]) + ")"
    return pl(t)


@st.composite
def epoch_time(draw, base: int):
    """A time within a few ms of `base` (epoch-sized seconds) as a float, a stamp or a datime/7."""
    ns = base * 10**9 + draw(st.integers(0, 5_000_000))
    sec, nsec = divmod(ns, 10**9)
    form = draw(st.sampled_from(["float", "stamp", "stamp", "datime"]))
    if form == "float":
        return sec + nsec / 1e9
    if form == "stamp":
        return [sec, nsec]
    y, mo, d, h, mi, s = datetime.datetime.fromtimestamp(sec, datetime.timezone.utc).timetuple()[:6]
    return ("datime", y, mo, d, h, mi, s, nsec)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(1_400_000_000, 1_500_000_000).flatmap(
    lambda base: st.lists(st.tuples(epoch_time(base), epoch_time(base), epoch_time(base)), min_size=1, max_size=20)))
def test_interpolation_subtracts_exactly_before_it_divides(driver, cases):
    """datime_interpolate/4, time_fraction/4 and pose_interpolate/6 give the fraction of the
    exact times, rounded once: floats taken at their own value, stamps and datime/7 exact."""
    goals = []
    for a, b, t in cases:
        args = f"{_time_text(a)}, {_time_text(b)}, {_time_text(t)}"
        goals += [f"datime_interpolate({args}, Out)", f"time_fraction({args}, Out)",
                  f"pose_interpolate({_time_text(a)}, [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]], {_time_text(b)}, "
                  f"[[1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]], {_time_text(t)}, [[Out|_]|_])"]
    got = values(driver, goals)
    for i, (a, b, t) in enumerate(cases):
        x1, x2, x = _exact(a), _exact(b), _exact(t)
        f = 0.0 if x1 == x2 else float((x - x1) / (x2 - x1))
        pose_f = 0.0 if x == x1 or x1 == x2 else 1.0 if x == x2 else f
        assert got[3 * i:3 * i + 3] == [f, f, pose_f], (a, b, t)


def test_the_issue_40_interpolation_value(driver):
    """The fraction of the floats' own values (the oracle: Fraction arithmetic), not of their
    nanoseconds rounded at epoch size (0.5000984639621898)."""
    x1, x2, x = (Fraction(v) for v in (1433161805.0, 1433161805.0026, 1433161805.0013))
    assert float((x - x1) / (x2 - x1)) == 0.500045850527281
    assert values(driver, ["datime_interpolate(1433161805.0, 1433161805.0026, 1433161805.0013, Out)"]) \
        == [0.500045850527281]


def test_the_datime_counter_is_nanoseconds_and_is_checked(driver):
    """A 2015-style datime/7 carries the stamp's nanoseconds in its counter (thesis A.2.5):
    it is the same time as the stamp, and a counter outside [0, 10^9) is refused."""
    got = run(driver, [
        "datime_interpolate([1433161805, 0], [1433161805, 2600000], datime(2015, 6, 1, 12, 30, 5, 1300000), Out)",
        "convert_to_datime(datime(1970, 1, 1, 0, 0, 10, 500000000), Out)",
        "datime_interpolate(0, 1, datime(2015, 6, 1, 12, 30, 5, 1000000000), Out)",
        "datime_interpolate(0, 1, datime(2015, 6, 1, 12, 30, 5, 1.5), Out)",
    ])
    assert got[:2] == [("ok", 0.5), ("ok", 10.5)]
    assert all(kind == "error" and "datime_nanoseconds" in text for kind, text in got[2:])
