"""The NAO application (examples/nao_markers/nao_markers.rtl) fed as the live node feeds it:
tf and marker messages come on two connections, each in its own order, interleaved as they
happen to arrive, and a TFMessage (no header) is stamped with its first transform's stamp.

Oracle: the in-order replay (record order, a header-less message at its record time). The
promise of arrival-order independence: any interleaving in which no event comes later than
the delay bound (1 s) gives the same poses; an interleaving that gives other poses shows up
in the `late` count. With the sample's own 2014 stamps played live years later, the arrival
times do not matter: every message carries its time.
"""
from pathlib import Path

import pytest

pytest.importorskip("rosbags", reason="the sample recording needs rosbags")

from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

from retalisc.driver.engine import Engine  # noqa: E402
from retalisc.robot_io.messages import MessageConverter  # noqa: E402
from retalisc.robot_io.samples import nao_records, sample_store  # noqa: E402

PROGRAM = Path(__file__).resolve().parent.parent / "examples" / "nao_markers" / "nao_markers.rtl"
TOPICS = ("/tf", "/ar_pose_marker")
STORE = sample_store(1)
CONVERTER = MessageConverter(STORE)
RECORDS = [r for r in nao_records(STORE, seconds=2.0) if r[0] in TOPICS]
MARKERS = sum(1 for r in RECORDS if r[0] == "/ar_pose_marker")


@pytest.fixture(scope="module")
def engine():
    return Engine.load(PROGRAM)


def _poses(engine, arrivals):
    """Sorted (consumer, event) deliveries and the late count of the messages fed in arrival
    order: `arrivals` is [(arrival_ns, index into RECORDS)]."""
    engine.clear()
    batch = []
    for arrival_ns, index in sorted(arrivals):
        topic, msgtype, _, msg = RECORDS[index]
        batch.append(CONVERTER.event(msg, msgtype, topic, arrival_ns))     # no header: its arrival
    delivered = sorted((e.consumer, e.event) for e in engine.feed_batch(batch) if e.consumer)
    return delivered, engine.stats()["late"]


def _arrivals(delays_ms, shift_ns=0):
    """Each message delayed by its delay after its record time, each topic first in, first
    out (one connection each); `shift_ns` moves the arrivals (the wall clock) only."""
    arrivals, last = [], dict.fromkeys(TOPICS, 0)
    for index, ((topic, _, record_ns, _), delay) in enumerate(zip(RECORDS, delays_ms)):
        last[topic] = max(last[topic], record_ns + shift_ns + delay * 1_000_000)
        arrivals.append((last[topic], index))
    return arrivals


@pytest.fixture(scope="module")
def in_order(engine):
    delivered, late = _poses(engine, [(record_ns, i) for i, (_, _, record_ns, _) in enumerate(RECORDS)])
    assert late == 0 and len(delivered) >= 5
    return delivered


def _delays(high_ms):
    return st.lists(st.integers(0, high_ms), min_size=len(RECORDS), max_size=len(RECORDS))


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_delays(400))
def test_interleavings_within_the_delay_bound_give_the_in_order_poses(engine, in_order, delays):
    assert _poses(engine, _arrivals(delays)) == (in_order, 0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.sampled_from([TOPICS, ("/tf",), ("/ar_pose_marker",)]), _delays(2500))
def test_an_interleaving_that_changes_a_pose_has_late_events(engine, in_order, delayed, delays):
    """Beyond the bound: late detections still get their poses (their transforms are there);
    transforms more than the bound behind let the clock release a detection without them;
    either way the late count says that the promise no longer holds."""
    delays = [delay if topic in delayed else 0 for (topic, *_), delay in zip(RECORDS, delays)]
    delivered, late = _poses(engine, _arrivals(delays))
    assert delivered == in_order or late > 0


def _stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def _markers_early(arrivals, ms):
    return [(arrival - (ms * 1_000_000 if RECORDS[i][0] == "/ar_pose_marker" else 0), i) for arrival, i in arrivals]


def _overtaking(arrivals) -> int:
    """How many detections arrive before the first transform stamped after them."""
    tf = sorted((arrival, _stamp_ns(RECORDS[i][3].transforms[0].header)) for arrival, i in arrivals
                if RECORDS[i][0] == "/tf")
    count = 0
    for arrival, i in arrivals:
        if RECORDS[i][0] == "/ar_pose_marker":
            stamp = _stamp_ns(RECORDS[i][3].header)
            count += arrival < min(a for a, tf_stamp in tf if tf_stamp > stamp)
    return count


def test_detections_that_overtake_their_transforms_wait_for_them(engine, in_order):
    """Markers 100 ms early against the tf connection: a detection that comes before the
    transform after its stamp waits for it (the synchronized rule), and nothing is late."""
    early = _markers_early(_arrivals([0] * len(RECORDS)), 100)
    assert _overtaking(early) > 0
    assert _poses(engine, early) == (in_order, 0)


def test_old_stamps_on_todays_clock_stay_on_their_own_clock(engine, in_order):
    """The sample's 2014 stamps played live 12 years later (what the live test's client did):
    a TFMessage carries its transforms' stamps, which are its time (the one clock rule,
    docs/robot_io.md), so the arrival times do not move the clock: nothing is late, and a
    detection that overtakes its next transform still waits for it. (When a TFMessage was
    stamped with its arrival, the clock went years ahead and every stamped event was late.)"""
    later = _arrivals([0] * len(RECORDS), 12 * 365 * 86_400 * 1_000_000_000)
    assert _poses(engine, later) == (in_order, 0)
    early = _markers_early(later, 100)
    assert _overtaking(early) > 0
    assert _poses(engine, early) == (in_order, 0)
