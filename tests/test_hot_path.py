"""The fast paths of event processing give what the general paths give: batches of input
lines. (Outputs reach Python as data, one JSON decoding a call: tests/test_output_data_c.py.)"""
import io

from hypothesis import given, settings
from hypothesis import strategies as st

from retalisc.driver.run import _batches


@settings(max_examples=100, deadline=None)
@given(st.lists(st.text(alphabet=st.sampled_from(list("ab \r{}é\ufeff")), max_size=5), max_size=30),
       st.booleans(), st.integers(1, 7))
def test_batches_hold_every_line_once_in_order(lines, final_newline, size):
    text = ("\n".join(lines) + ("\n" if final_newline and lines else "")).encode("utf-8")
    batches = list(_batches(io.BytesIO(text), size))
    expected = text.split(b"\n")
    if expected[-1] == b"":
        expected.pop()
    assert [line for _, batch, _ in batches for line in batch] == expected
    assert all(len(batch) == size for _, batch, _ in batches[:-1])
    assert [first for first, _, _ in batches] == [1 + size * k for k in range(len(batches))]
    assert sum(n for _, _, n in batches) == len(text)


# ---- the `seq` skip (rtl_started_after/1) ------------------------------------------------

import pytest  # noqa: E402
from hypothesis import HealthCheck  # noqa: E402

from retalisc.driver.engine import Engine  # noqa: E402

SKIP_PROGRAM = """
:- set_etalis_flag(event_consumption_policy, {policy}).
pair(I, X, Y) <- a(I, X) seq b(I, Y).
chain(I, X, Z) <- a(I, X) seq b(I, _) seq c(I, Z).
gap(I, X, Y) <- (a(I, X) seq b(I, Y)) cnot c(I, _).
window(I) <- (b(I, _) seq a(I, _)).3.
"""

STREAM = st.lists(st.tuples(st.sampled_from("abc"), st.integers(1, 2), st.integers(0, 3), st.integers(0, 12),
                            st.integers(0, 2), st.integers(0, 5)), min_size=3, max_size=25)


@pytest.fixture(scope="module", params=["unrestricted", "recent", "chronological"])
def skip_engine(request):
    return Engine.from_source(SKIP_PROGRAM.format(policy=request.param), "skip.rtl")


def _skip_run(engine, events, scan_always):
    """The output of the events (kind, id, value, start, length, retracted-after) in arrival
    order, a retraction of an event following it when asked; with `scan_always` the latest
    start is unknown for the whole run, so every `seq` step searches its store."""
    engine.clear()
    engine.set_flag("max_delay", "inf")
    if scan_always:
        engine.bridge.once("nb_delete(rtl_latest_start)")
    batch = []
    for kind, i, x, t, length, retract in events:
        batch.append((f"{kind}({i}, {x})", t, t + length))
        if retract == 0:
            batch.append((f"{kind}({i}, {x})", t, t + length, "retract"))
    return [(e.event, e.start, e.end, e.op) for e in engine.feed_batch(batch)]


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(STREAM)
def test_skipping_the_search_changes_no_output(skip_engine, events):
    # arrival in any order, intervals, deletions: the output is that of a search every time
    assert _skip_run(skip_engine, events, False) == _skip_run(skip_engine, events, True)


def test_the_latest_start_is_known_and_a_late_partner_still_matches(skip_engine):
    out = _skip_run(skip_engine, [("b", 1, 1, 5, 0, 1), ("a", 1, 2, 1, 0, 1)], False)
    assert ("pair(1,2,1)", 1, 5, "add") in out       # a arrives after b, ending before it
    assert skip_engine.bridge.call_text("( nb_current(rtl_latest_start, L) -> format(string(R), '~w', [L]) "
                                        "; R = none )", "R") == "5"
