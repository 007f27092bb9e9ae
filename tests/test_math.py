"""Property tests of prolog_runtime/rtl_math.pl against an independent computation in plain
Python: rotation matrices built from quaternions, matrix products, homogeneous transforms
and slerp by the axis/angle of the relative rotation (Rodrigues' formula).

Each hypothesis example is a *batch* of generated cases that one `swipl` subprocess
evaluates, so a test costs a few process starts, not one per case.  Numbers are compared
with a relative tolerance of 1e-9 (relative to the magnitude of the inputs, at least 1).

The plunit suite prolog_runtime/tests/test_math.pl is run from here too."""
from __future__ import annotations

import math
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from math_driver import answers, pl, run, write_driver

ROOT = Path(__file__).resolve().parent.parent
TOL = 1e-9

BATCH = settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])

@pytest.fixture(scope="module")
def driver(tmp_path_factory, swipl):
    return swipl, write_driver(tmp_path_factory.mktemp("rtl_math"))


# --------------------------------------------------------------------------- oracle

def close(a, b, scale: float = 1.0) -> bool:
    """Numbers or nested lists equal within TOL relative to max(1, scale)."""
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(close(x, y, scale) for x, y in zip(a, b))
    return abs(a - b) <= TOL * max(1.0, scale)


def norm(v) -> float:
    return math.sqrt(sum(x * x for x in v))


def magnitude(*vs) -> float:
    return max([abs(x) for v in vs for x in v], default=0.0)


def matrix(q):
    """Rotation matrix of the unit quaternion q = [x, y, z, w]."""
    x, y, z, w = q
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(len(b))) for j in range(len(b[0]))]
            for i in range(len(a))]


def matvec(a, v):
    return [sum(a[i][k] * v[k] for k in range(len(v))) for i in range(len(a))]


def transpose(a):
    return [list(r) for r in zip(*a)]


def homogeneous(pose):
    v, q = pose
    r = matrix(q)
    return [r[0] + [v[0]], r[1] + [v[1]], r[2] + [v[2]], [0.0, 0.0, 0.0, 1.0]]


def split_homogeneous(h):
    return [row[3] for row in h[:3]], [row[:3] for row in h[:3]]


def left_matrix(q):
    """4x4 matrix L(q) with L(q) @ p = q * p (Hamilton product, [x, y, z, w] order)."""
    x, y, z, w = q
    return [[w, -z, y, x],
            [z, w, -x, y],
            [-y, x, w, z],
            [-x, -y, -z, w]]


def rodrigues(axis, angle):
    """Rotation matrix of angle (radians) about the unit axis."""
    kx, ky, kz = axis
    k = [[0.0, -kz, ky], [kz, 0.0, -kx], [-ky, kx, 0.0]]
    k2 = matmul(k, k)
    s, c = math.sin(angle), 1 - math.cos(angle)
    return [[(1.0 if i == j else 0.0) + s * k[i][j] + c * k2[i][j] for j in range(3)] for i in range(3)]


def slerp_matrix(q1, q2, f):
    """Rotation matrix of slerp(q1, q2, f) along the shortest arc: q1's rotation followed
    (in q1's frame) by fraction f of the relative rotation, about its axis."""
    q1 = [c / norm(q1) for c in q1]
    q2 = [c / norm(q2) for c in q2]
    r1, r2 = matrix(q1), matrix(q2)
    # relative rotation conj(q1) * q2 via the 4x4 form; w < 0 -> the other way round
    rel = matvec(left_matrix([-q1[0], -q1[1], -q1[2], q1[3]]), q2)
    if rel[3] < 0:
        rel = [-c for c in rel]
    s = norm(rel[:3])
    if s == 0.0:
        return r1
    angle = 2 * math.atan2(s, rel[3])          # rotation angle in [0, pi]
    rm = rodrigues([c / s for c in rel[:3]], f * angle)
    # sanity of the oracle itself: the full relative rotation takes r1 to r2
    assert close(matmul(r1, rodrigues([c / s for c in rel[:3]], angle)), r2, 1e3)
    return matmul(r1, rm)


# --------------------------------------------------------------------------- strategies

coord = st.floats(-100, 100, allow_nan=False, allow_infinity=False)
vec3 = st.one_of(st.lists(coord, min_size=3, max_size=3),
                 st.lists(st.integers(-50, 50), min_size=3, max_size=3))
fraction = st.one_of(st.floats(0, 1), st.floats(-1, 2), st.sampled_from([0, 1, 0.5]))


@st.composite
def quat(draw):
    """A non-zero quaternion of any length (scaled by 1e-100 .. 1e100)."""
    q = draw(st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: norm(q) > 0.1))
    scale = 10.0 ** draw(st.integers(-100, 100))
    return [c * scale for c in q]


@st.composite
def unit_quat(draw):
    q = draw(st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: norm(q) > 0.1))
    n = norm(q)
    return [c / n for c in q]


@st.composite
def quat_pair(draw):
    """Two unit quaternions: independent, nearly equal (tiny to small perturbations,
    including below the nlerp threshold), or nearly antipodal."""
    q1 = draw(unit_quat())
    kind = draw(st.sampled_from(["any", "near", "antipodal"]))
    if kind == "any":
        q2 = draw(unit_quat())
    else:
        eps = 10.0 ** -draw(st.integers(2, 12))
        noise = draw(st.lists(st.floats(-1, 1), min_size=4, max_size=4))
        q2 = [a + eps * d for a, d in zip(q1, noise)]
        q2 = [c / norm(q2) for c in q2]
        if kind == "antipodal":
            q2 = [-c for c in q2]
    return q1, q2


pose = st.tuples(vec3, unit_quat()).map(list)


def batch(strategy, max_size=25):
    return st.lists(strategy, min_size=1, max_size=max_size)


# --------------------------------------------------------------------------- tests

def test_plunit(swipl):
    proc = subprocess.run([swipl, "--no-tty", "-q", "-g", "run_tests", "-t", "halt",
                           str(ROOT / "prolog_runtime" / "tests" / "test_math.pl")],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60)
    assert proc.returncode == 0, proc.stdout


@BATCH
@given(batch(st.integers(0, 8).flatmap(
    lambda n: st.tuples(st.lists(coord, min_size=n, max_size=n),
                        st.lists(coord, min_size=n, max_size=n), fraction))))
def test_vec_lerp(driver, cases):
    got = answers(driver, [f"vec_lerp({pl(a)},{pl(b)},{pl(f)},Out)" for a, b, f in cases])
    for (a, b, f), v in zip(cases, got):
        expected = [x + f * (y - x) for x, y in zip(a, b)]
        assert close(v, expected, 2 * magnitude(a, b)), (a, b, f, v)
        if f == 0:
            assert v == [float(x) for x in a]
        if f == 1:
            assert v == [float(y) for y in b]


@BATCH
@given(batch(quat()))
def test_quat_normalize(driver, cases):
    got = answers(driver, [f"quat_normalize({pl(q)},Out)" for q in cases])
    for q, qn in zip(cases, got):
        m = max(abs(c) for c in q)
        n = norm([c / m for c in q])
        assert close(qn, [c / m / n for c in q]), (q, qn)


@BATCH
@given(batch(st.tuples(st.lists(coord, min_size=4, max_size=4),
                       st.lists(coord, min_size=4, max_size=4))))
def test_quat_multiply_general(driver, cases):
    got = answers(driver, [f"quat_multiply({pl(a)},{pl(b)},Out)" for a, b in cases])
    for (a, b), q in zip(cases, got):
        assert close(q, matvec(left_matrix(a), b), norm(a) * norm(b)), (a, b, q)


@BATCH
@given(batch(st.tuples(unit_quat(), unit_quat())))
def test_quat_multiply_is_matrix_product(driver, cases):
    got = answers(driver, [f"quat_multiply({pl(a)},{pl(b)},Out)" for a, b in cases])
    for (a, b), q in zip(cases, got):
        assert close(matrix(q), matmul(matrix(a), matrix(b))), (a, b, q)


@BATCH
@given(batch(unit_quat()))
def test_quat_conjugate(driver, cases):
    got = answers(driver, [f"quat_conjugate({pl(q)},Out)" for q in cases])
    for q, c in zip(cases, got):
        assert c == [-q[0], -q[1], -q[2], q[3]]
        assert close(matrix(c), transpose(matrix(q)))


@BATCH
@given(batch(st.tuples(unit_quat(), vec3)))
def test_quat_rotate(driver, cases):
    got = answers(driver, [f"quat_rotate({pl(q)},{pl(v)},Out)" for q, v in cases])
    for (q, v), r in zip(cases, got):
        assert close(r, matvec(matrix(q), v), magnitude(v)), (q, v, r)


@BATCH
@given(batch(st.tuples(quat_pair(), fraction)))
def test_quat_slerp(driver, cases):
    cases = [(q1, q2, f) for (q1, q2), f in cases
             if abs(sum(a * b for a, b in zip(q1, q2))) > 1e-6]   # shortest arc is unique
    if not cases:
        return
    got = answers(driver, [f"quat_slerp({pl(q1)},{pl(q2)},{pl(f)},Out)" for q1, q2, f in cases])
    for (q1, q2, f), q in zip(cases, got):
        assert close(norm(q), 1.0), q
        assert close(matrix(q), slerp_matrix(q1, q2, f)), (q1, q2, f, q)
        if f == 0:
            assert close(q, q1)
        if f == 1:
            dot = sum(a * b for a, b in zip(q1, q2))
            assert close(q, q2 if dot >= 0 else [-c for c in q2])


@BATCH
@given(batch(st.tuples(pose, pose)))
def test_pose_compose(driver, cases):
    got = answers(driver, [f"pose_compose({pl(a)},{pl(b)},Out)" for a, b in cases])
    for (a, b), p in zip(cases, got):
        v, r = split_homogeneous(matmul(homogeneous(a), homogeneous(b)))
        assert close(p[0], v, magnitude(a[0], b[0])), (a, b, p)
        assert close(matrix(p[1]), r), (a, b, p)
        assert close(p[1], matvec(left_matrix(a[1]), b[1])), (a, b, p)


@BATCH
@given(batch(pose))
def test_pose_inverse(driver, cases):
    got = answers(driver, [f"pose_inverse({pl(p)},Out)" for p in cases])
    for p, inv in zip(cases, got):
        rt = transpose(matrix(p[1]))
        assert close(matrix(inv[1]), rt), (p, inv)
        assert close(inv[0], [-x for x in matvec(rt, p[0])], magnitude(p[0])), (p, inv)
        # and the inverse undoes the transform
        v, r = split_homogeneous(matmul(homogeneous(p), homogeneous(inv)))
        assert close(v, [0, 0, 0], magnitude(p[0])) and close(r, matrix([0, 0, 0, 1]))


@BATCH
@given(batch(st.lists(pose, max_size=5), max_size=15))
def test_pose_chain(driver, cases):
    got = answers(driver, [f"pose_chain({pl(ps)},Out)" for ps in cases])
    for ps, p in zip(cases, got):
        h = homogeneous([[0, 0, 0], [0, 0, 0, 1]])
        for q in ps:
            h = matmul(h, homogeneous(q))
        v, r = split_homogeneous(h)
        scale = sum(magnitude(q[0]) for q in ps)
        assert close(p[0], v, scale), (ps, p)
        assert close(matrix(p[1]), r, len(ps)), (ps, p)
        assert close(norm(p[1]), 1.0, len(ps)), (ps, p)


times = st.tuples(st.floats(-1e3, 1e3), st.one_of(st.just(0.0), st.floats(1e-3, 100), st.floats(-100, -1e-3)),
                  st.one_of(st.floats(-1, 2), st.sampled_from([0.0, 1.0])))


def interpolation_times(t):
    t1, dt, s = t
    t2 = t1 + dt
    return t1, t2, t1 + s * (t2 - t1)


@BATCH
@given(batch(times))
def test_time_fraction(driver, cases):
    cases = [interpolation_times(t) for t in cases]
    got = answers(driver, [f"time_fraction({pl(t1)},{pl(t2)},{pl(t)},Out)" for t1, t2, t in cases])
    for (t1, t2, t), f in zip(cases, got):
        assert isinstance(f, float)
        expected = 0.0 if t1 == t2 else (t - t1) / (t2 - t1)
        assert close(f, expected), (t1, t2, t, f)


@BATCH
@given(batch(st.tuples(times, pose, pose)))
def test_pose_interpolate(driver, cases):
    cases = [(*interpolation_times(t), p1, p2) for t, p1, p2 in cases]
    cases = [c for c in cases if abs(sum(a * b for a, b in zip(c[3][1], c[4][1]))) > 1e-6]
    if not cases:
        return
    got = answers(driver, [f"pose_interpolate({pl(t1)},{pl(p1)},{pl(t2)},{pl(p2)},{pl(t)},Out)"
                           for t1, t2, t, p1, p2 in cases])
    for (t1, t2, t, p1, p2), p in zip(cases, got):
        if t == t1 or t1 == t2:
            assert p == p1
            continue
        if t == t2:
            assert p == p2
            continue
        f = (t - t1) / (t2 - t1)
        v = [a + f * (b - a) for a, b in zip(p1[0], p2[0])]
        # the fraction itself carries rounding of the times: scale the tolerance by the
        # size of the translation step and of the times
        slack = max(1.0, abs(t1), abs(t2)) / abs(t2 - t1)
        assert close(p[0], v, magnitude(p1[0], p2[0]) * 3 * slack), (t1, t2, t, p1, p2, p)
        assert close(matrix(p[1]), slerp_matrix(p1[1], p2[1], f), 2 * slack), (t1, t2, t, p1, p2, p)


bad_vec = st.one_of(st.lists(coord, max_size=6).filter(lambda v: len(v) != 3),
                    st.lists(st.one_of(coord, st.just("a")), min_size=3, max_size=3)
                    .filter(lambda v: "a" in v))
bad_quat = st.one_of(st.lists(coord, max_size=6).filter(lambda v: len(v) != 4),
                     st.lists(st.one_of(coord, st.just("a")), min_size=4, max_size=4)
                     .filter(lambda v: "a" in v),
                     st.just([0, 0, 0, 0]))


@BATCH
@given(batch(st.one_of(
    st.tuples(unit_quat(), bad_vec).map(lambda t: f"quat_rotate({pl(t[0])},{pl(t[1])},Out)"),
    bad_quat.map(lambda q: f"quat_slerp([0,0,0,1],{pl(q)},0.5,Out)"),
    bad_quat.map(lambda q: f"quat_normalize({pl(q)},Out)" if any(q) else "quat_normalize([0,0,0,0],Out)"),
    st.tuples(bad_vec, unit_quat()).map(lambda t: f"pose_inverse([{pl(t[0])},{pl(t[1])}],Out)"),
    bad_quat.filter(lambda q: q != [0, 0, 0, 0])
            .map(lambda q: f"pose_chain([[[0,0,0],[0,0,0,1]],[[1,2,3],{pl(q)}]],Out)"),
    st.tuples(st.lists(coord, max_size=4), st.lists(coord, max_size=4))
      .filter(lambda t: len(t[0]) != len(t[1]))
      .map(lambda t: f"vec_lerp({pl(t[0])},{pl(t[1])},0.5,Out)"),
    st.sampled_from(["vec_lerp([1],[2],x,Out)", "time_fraction(0,1,_,Out)",
                     "pose_interpolate(0,[[0,0,0],[0,0,0,1]],1,[[0,0,0],[0,0,0,1]],t,Out)"]),
)))
def test_bad_arguments_raise(driver, goals):
    for goal, (kind, value) in zip(goals, run(driver, goals)):
        assert kind == "error", (goal, kind, value)
        assert value.startswith(("error(type_error(", "error(domain_error(", "error(instantiation_error")), \
            (goal, value)
