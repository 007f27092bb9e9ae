"""ELE at the edges (issue 20): partial matches are the events themselves (`_` is not a
wildcard that merges different events), retractions inside the retraction horizon are exact
for every operator, retractions outside it are reported, and late blockers take back what
they block while it is inside the horizon."""
import pytest

from retalisc.driver.engine import Engine

from ele_oracle import net_output


def outputs(engine, batch):
    return [(o.event, o.start, o.end, o.op) for o in engine.feed_batch(batch)]


def fresh(engine, max_delay="inf"):
    engine.clear()
    engine.set_flag("max_delay", max_delay)
    return engine


# ---- 1. `_` under the consumption policies ------------------------------------------------

RECENT_ANONYMOUS = """
:- set_etalis_flag(event_consumption_policy, recent).
c(K) <- a(K, _) seq b(K).
"""
RECENT_NAMED = """
:- set_etalis_flag(event_consumption_policy, recent).
c(K) <- a(K, V) seq b(K).
"""
ISSUE_STREAM = [("a(1, 10)", 1), ("a(1, 20)", 2), ("b(1)", 3), ("b(1)", 4)]


@pytest.mark.parametrize("program", [RECENT_ANONYMOUS, RECENT_NAMED], ids=["anonymous", "named"])
def test_recent_does_not_take_different_events_for_twins(program):
    """The issue's minimal case: a(1,10) and a(1,20) are different events, so neither replaces
    the other; b(1)@3 takes the newest, b(1)@4 the other (as ETALIS derives)."""
    engine = fresh(Engine.from_source(program, "twins.rtl"))
    assert outputs(engine, ISSUE_STREAM) == [("c(1)", 2, 3, "add"), ("c(1)", 1, 4, "add")]


def test_recent_still_replaces_an_identical_twin():
    engine = fresh(Engine.from_source(RECENT_ANONYMOUS, "twins.rtl"))
    stream = [("a(1, 10)", 1), ("a(1, 10)", 2), ("b(1)", 3), ("b(1)", 4)]
    assert outputs(engine, stream) == [("c(1)", 2, 3, "add")]


@pytest.mark.parametrize("policy", ["recent", "chronological", "unrestricted"])
@pytest.mark.parametrize("pattern, stream, bogus", [
    # a join: the partner of b(1) differs only in the unnamed argument
    ("c(K) <- a(K, _) seq b(K).", [("a(1, 10)", 1), ("a(1, 20)", 2), ("b(1)", 3), ("b(1)", 4)], ("a(1, 30)", 2)),
    # a negation: the blocker of the pair, and one that differs only in the unnamed argument
    ("c(K) <- not(n(K, _)).[a(K), b(K)].", [("a(1)", 1), ("n(1, 5)", 2), ("b(1)", 3)], ("n(1, 6)", 2)),
    # fnot: the same
    ("c(K) <- a(K) fnot n(K, _).", [("n(1, 5)", 1), ("a(1)", 2)], ("n(1, 6)", 1)),
    # an aggregate over events that differ only in the unnamed argument
    ("c(K, N) <- a(K, _) seq aggregate(count, b(K, _), N).", [("a(1, 1)", 1), ("b(1, 5)", 2), ("b(1, 6)", 2)],
     ("a(1, 2)", 1)),
])
def test_naming_an_unused_variable_changes_nothing(policy, pattern, stream, bogus):
    """Same program with `_` and with named variables: the same output, and deleting an event
    that was never added, which differs from an added one only in the unnamed argument,
    changes nothing."""
    named = pattern
    for n in range(pattern.count("_")):
        named = named.replace("_", f"Unused{n}", 1)
    results = []
    for rule in (pattern, named):
        program = f":- set_etalis_flag(event_consumption_policy, {policy}).\n{rule}\n"
        engine = fresh(Engine.from_source(program, "named.rtl"))
        added = outputs(engine, stream)
        after_bogus = outputs(engine, [(bogus[0], bogus[1], bogus[1], "retract")])
        results.append((added, after_bogus))
    assert results[0] == results[1]
    assert results[0][1] == []
