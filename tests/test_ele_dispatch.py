"""The dispatch of events nothing uses (rtl_ele.pl, event_dispatch/2): an event whose type no
rule, hook or echo takes only moves the clock and counts. Checked against the same program
with one more rule that takes that type but never derives anything (so every event goes the
full road): outputs, clock and counters agree on random streams, late and out of order events
included; and a type becomes used as soon as a rule or a subscription takes it."""
from hypothesis import given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine

PROGRAM = """
:- set_etalis_flag(event_consumption_policy, recent).
r(K) <- a(K) seq b(K).
s(K) <- (a(K) seq b(K)) cnot c(K).
"""
# zzz and other are used there (the full road), and nothing is ever derived from them.
USED = PROGRAM + "u(K) <- zzz(K) seq never(K).\nv(K) <- other(K) seq never(K).\n"

KINDS = ("a", "b", "c", "zzz", "other")
events = st.lists(st.tuples(st.sampled_from(KINDS), st.integers(1, 3), st.integers(0, 40)), max_size=60)


def run(engine, stream, max_delay):
    engine.activate()
    engine.clear()
    engine.set_flag("max_delay", max_delay)
    out = [(o.event, o.start, o.end, o.op) for o in
           engine.feed_batch([(f"{kind}({k})", t / 4) for kind, k, t in stream])]
    return out, engine.clock(), engine.stats()


QUIET = Engine.from_source(PROGRAM, "quiet.rtl")
FULL = Engine.from_source(USED, "full.rtl")


@settings(max_examples=60, deadline=None)
@given(events, st.sampled_from(["2", "inf"]))
def test_an_event_nothing_uses_changes_nothing_but_the_clock_and_counters(stream, max_delay):
    # the tail (times in quarters): a quiet event moves the clock on, then an `a` comes late
    stream = stream + [("other", 1, 400), ("a", 1, 380), ("b", 1, 401), ("other", 2, 402)]
    assert run(QUIET, stream, max_delay) == run(FULL, stream, max_delay)


def test_a_rule_added_later_takes_the_type():
    engine = Engine.from_source(PROGRAM, "later.rtl")
    engine.feed_batch([("zzz(1)", 1), ("zzz(1)", 2)])
    engine.add_rules("w(K) <- zzz(K).")
    assert [o.event for o in engine.feed_batch([("zzz(5)", 3)])] == ["w(5)"]
    assert engine.stats()["events"] == 3


def test_a_subscription_added_later_takes_the_type():
    engine = Engine.from_source(PROGRAM, "subscribed.rtl")
    engine.feed_batch([("zzz(1)", 1)])
    engine.subscribe("ops", "zzz(X)")
    delivered = engine.feed_batch([("zzz(7)", 2)])
    assert [(o.event, o.consumer) for o in delivered] == [("zzz(7)", "ops")]
