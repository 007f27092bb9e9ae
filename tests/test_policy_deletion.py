"""Deletion under the consumption policies is exact: under `recent` and
`chronological` (program flag or rule property), deleting an input event inside the retraction
horizon nets the output to that of a run in which the event never arrived: the partner it
consumed is free again, and the later decisions of the rule are made again
(prolog_runtime/rtl_policy.pl).

Checked three ways: golden cases; a brute-force simulation of the policies in arrival order
(`simulate`, for one-step rules); and, for every rule shape (hierarchies, negation, windows,
several steps, rules fed by derived events), the engine against itself on the stream without
the deleted events, in any arrival order and within a delay bound."""
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine

from ele_oracle import net_output


def outputs(engine, batch):
    return [(o.op, o.event, o.start, o.end) for o in engine.feed_batch(batch)]


def fresh(engine, max_delay="inf"):
    engine.activate()           # one program per process: another test may have loaded its own
    engine.clear()
    engine.set_flag("max_delay", max_delay)
    return engine


# ---- golden cases ------------------------------------------------------------------------

def test_a_deleted_event_frees_the_partner_it_consumed_recent():
    program = ":- set_etalis_flag(event_consumption_policy, recent).\nr(I, X, Y) <- a(I, X) seq b(I, Y).\n"
    engine = fresh(Engine.from_source(program, "recent.rtl"))
    assert outputs(engine, [("a(1, x)", 1), ("a(1, y)", 2), ("b(1, p)", 3), ("b(1, q)", 4)]) == [
        ("add", "r(1,y,p)", 2, 3), ("add", "r(1,x,q)", 1, 4)]
    # without a(1, y): b(1, p) takes a(1, x), and b(1, q) finds nothing left
    assert outputs(engine, [("a(1, y)", 2, 2, "retract")]) == [
        ("retract", "r(1,x,q)", 1, 4), ("retract", "r(1,y,p)", 2, 3), ("add", "r(1,x,p)", 1, 3)]
    # the b(1, q) waits again: a late a(1, z) that happened before it takes it
    assert outputs(engine, [("a(1, z)", 3.5), ("b(1, s)", 5)]) == [("add", "r(1,z,q)", 3.5, 4)]


def test_a_deleted_event_frees_the_partner_it_consumed_chronological():
    program = "r1([property(consumption_policy, chronological)]) 'rule:' r(I, X, Y) <- a(I, X) seq b(I, Y).\n"
    engine = fresh(Engine.from_source(program, "chrono.rtl"))
    assert outputs(engine, [("a(1, x)", 1), ("a(1, y)", 2), ("b(1, p)", 3), ("b(1, q)", 4)]) == [
        ("add", "r(1,x,p)", 1, 3), ("add", "r(1,y,q)", 2, 4)]
    # without b(1, p): a(1, x) pairs with b(1, q), a(1, y) waits
    assert net_output(engine.feed_batch([("b(1, p)", 3, 3, "retract")])) == Counter(
        {"r(1,x,p)@1-3": -1, "r(1,y,q)@2-4": -1, "r(1,x,q)@1-4": 1})
    assert outputs(engine, [("b(1, t)", 6)]) == [("add", "r(1,y,t)", 2, 6)]


def test_a_deletion_reaches_the_later_steps_of_the_rule():
    program = ":- set_etalis_flag(event_consumption_policy, recent).\nr(X, Y, Z) <- a(X) seq b(Y) seq c(Z).\n"
    engine = fresh(Engine.from_source(program, "three.rtl"))
    events = [("a(1)", 1), ("a(2)", 2), ("b(3)", 3), ("c(4)", 4), ("b(5)", 5), ("c(6)", 6)]
    assert outputs(engine, events) == [("add", "r(2,3,4)", 2, 4), ("add", "r(1,5,6)", 1, 6)]
    # without a(2): a(1) seq b(3) takes c(4); b(5) and c(6) find nothing
    engine.feed_batch([("a(2)", 2, 2, "retract")])
    assert engine.feed("c(7)", 7) == []
    fresh(engine)
    expected = outputs(engine, [e for e in events if e[0] != "a(2)"] + [("c(7)", 7)])
    fresh(engine)
    assert net_output(engine.feed_batch(events + [("a(2)", 2, 2, "retract"), ("c(7)", 7)])) == Counter(
        f"{e}@{s}-{t}" for _, e, s, t in expected)


def test_deleting_a_blocker_under_a_policy_pairs_again():
    program = (":- set_etalis_flag(event_consumption_policy, chronological).\n"
               "r(X, Y) <- not(c).[a(X), b(Y)].\n")
    engine = fresh(Engine.from_source(program, "not.rtl"))
    assert outputs(engine, [("a(1)", 1), ("c", 2), ("b(3)", 3), ("a(4)", 4), ("b(5)", 5)]) == [
        ("add", "r(4,5)", 4, 5)]
    # without c: a(1) pairs with b(3), and a(4) with b(5) as before
    assert net_output(engine.feed_batch([("c", 2, 2, "retract")])) == Counter({"r(1,3)@1-3": 1})
    # a blocker that arrives late (after the pairs) takes nothing back: arrival order decides
    assert outputs(engine, [("c", 2)]) == []


def test_a_deletion_within_the_horizon_of_a_windowed_rule():
    program = (":- set_etalis_flag(event_consumption_policy, recent).\n"
               "r(X, Y) <- (a(X) seq b(Y)).5.\n")
    engine = fresh(Engine.from_source(program, "window.rtl"), "1")
    assert outputs(engine, [("a(1)", 1), ("a(2)", 2), ("b(3)", 3), ("b(4)", 4), ("a(7)", 7)]) == [
        ("add", "r(2,3)", 2, 3), ("add", "r(1,4)", 1, 4)]
    assert net_output(engine.feed_batch([("a(2)", 2, 2, "retract")])) == Counter(
        {"r(2,3)@2-3": -1, "r(1,4)@1-4": -1, "r(1,3)@1-3": 1})


def test_a_rule_fed_by_a_derived_event_follows_the_deletion():
    program = (":- set_etalis_flag(event_consumption_policy, recent).\n"
               "x(X, Y) <- a(X) seq b(Y).\n"
               "y(X, Z) <- x(X, _) seq c(Z).\n")
    engine = fresh(Engine.from_source(program, "hierarchy.rtl"))
    events = [("a(1)", 1), ("a(2)", 2), ("b(3)", 3), ("b(4)", 4), ("c(5)", 5)]
    before = outputs(engine, events)
    assert ("add", "y(1,5)", 1, 5) in before
    # without a(1): x(2, 3) is the only x, and c(5) pairs with it
    assert net_output(engine.feed_batch([("a(1)", 1, 1, "retract")])) == Counter(
        {"x(1,4)@1-4": -1, "y(1,5)@1-5": -1, "y(2,5)@2-5": 1})


def test_a_replaced_twin_from_one_branch_of_an_or_waits_again():
    """The partial match of `a` leaves Y (the `c` branch) unbound; under `recent` the second
    a(1, 0) replaces the first, and deleting it lets the first wait again."""
    program = ":- set_etalis_flag(event_consumption_policy, recent).\nr(I, Z) <- (a(I, X) or c(I, Y)) seq b(I, Z).\n"
    engine = fresh(Engine.from_source(program, "twin_or.rtl"))
    assert outputs(engine, [("a(1, 0)", 0), ("a(1, 0)", 0), ("a(1, 0)", 0, 0, "retract"), ("b(1, 5)", 1)]) == [
        ("add", "r(1,5)", 0, 1)]


def test_a_or_b_of_the_same_arguments_are_different_partial_matches():
    """a(2, 0) and b(2, 0) are different events: neither replaces the other, and deleting b
    takes b's partial match, not a's."""
    program = (":- set_etalis_flag(event_consumption_policy, recent).\n"
               "r(I, X) <- (a(I, X) or b(I, X)) seq c(I, _).\n")
    engine = fresh(Engine.from_source(program, "branches.rtl"))
    assert outputs(engine, [("b(2, 0)", 0), ("a(2, 0)", 0), ("c(2, 1)", 1), ("c(2, 2)", 2)]) == [
        ("add", "r(2,0)", 0, 1), ("add", "r(2,0)", 0, 2)]
    # without b(2, 0): c(2, 1) takes a's partial match, and c(2, 2) waits
    assert net_output(engine.feed_batch([("b(2, 0)", 0, 0, "retract")])) == Counter({"r(2,0)@0-2": -1})


def test_an_event_reaching_a_step_twice_is_replayed_in_the_order_it_arrived():
    """b reaches the second step through `a seq b` (its right side) before it reaches it
    directly (its left side); a replay keeps that order."""
    program = (":- set_etalis_flag(event_consumption_policy, recent).\n"
               "r(I, X, Z) <- b(I, X) and (a(I, _) seq b(I, Z)).\n")
    events = [("a(1, 1)", 0), ("b(1, 2)", 0), ("a(1, 2)", 3), ("b(1, 0)", 2)]
    engine = fresh(Engine.from_source(program, "twice.rtl"))
    expected = outputs(engine, [e for e in events if e[0] != "a(1, 2)"])
    assert expected == [("add", "r(1,2,0)", 0, 2)]
    fresh(engine)
    assert net_output(engine.feed_batch(events + [("a(1, 2)", 3, 3, "retract")])) == Counter(
        f"{e}@{s}-{t}" for _, e, s, t in expected)


def test_a_partial_match_with_an_unbound_key_is_restored_as_it_was():
    """c(_, X) leaves the join key unbound: c's partial match pairs with a b of any key, and
    when that b is deleted it waits again for any key."""
    for policy in ("recent", "chronological", "first"):
        program = f"r1([property(consumption_policy, {policy})]) 'rule:' r(X) <- (a(I, X) or c(_, X)) seq b(I, _).\n"
        engine = fresh(Engine.from_source(program, f"loose_{policy}.rtl"))
        assert outputs(engine, [("c(1, 0)", 0), ("b(2, 0)", 1)]) == [("add", "r(0)", 0, 1)]
        assert outputs(engine, [("b(2, 0)", 1, 1, "retract")]) == [("retract", "r(0)", 0, 1)]
        assert outputs(engine, [("b(3, 0)", 2)]) == [("add", "r(0)", 0, 2)]


def test_a_match_taken_back_deletes_the_instance_it_passed_on():
    """Two rules derive x(1) over [1, 3]; deleting the a of the first takes back the x(1)
    that its match passed on, not the later one of the second rule."""
    program = (":- set_etalis_flag(event_consumption_policy, chronological).\n"
               "x(I) <- a(I, _) seq b(I, _).\n"
               "x(I) <- d(I).\n"
               "y(I, Z) <- x(I) seq c(I, Z).\n")
    events = [("a(1, p)", 1), ("b(1, u)", 3), ("c(1, k)", 5), ("d(1)", 0, 3), ("d(1)", 1, 3)]
    engine = fresh(Engine.from_source(program, "passed_on.rtl"))
    expected = outputs(engine, [e for e in events if e[0] != "a(1, p)"])
    assert ("add", "y(1,k)", 0, 5) in expected
    fresh(engine)
    assert net_output(engine.feed_batch(events + [("a(1, p)", 1, 1, "retract")])) == Counter(
        f"{e}@{s}-{t}" for _, e, s, t in expected)


def test_a_deletion_of_an_event_that_arrived_twice_takes_back_its_latest_arrival():
    """Which of two arrivals of the same event "never arrived" matters under a policy: without
    the first a(1, x), b(1, p) would take a(1, y). A deletion takes back the latest arrival (as
    the oracle of the property tests, `with_deletions`, does), so the output is that of the
    run without the second a(1, x)."""
    program = ":- set_etalis_flag(event_consumption_policy, chronological).\nr(X, Y) <- a(1, X) seq b(1, Y).\n"
    engine = fresh(Engine.from_source(program, "twice_in.rtl"))
    events = [("a(1, x)", 1), ("a(1, y)", 2), ("b(1, p)", 3), ("a(1, x)", 1)]
    assert outputs(engine, events) == [("add", "r(x,p)", 1, 3)]
    assert outputs(engine, [("a(1, x)", 1, 1, "retract")]) == []
    # the first a(1, x) is still there, consumed by b(1, p); a(1, y) waits
    assert outputs(engine, [("b(1, q)", 4)]) == [("add", "r(y,q)", 2, 4)]
    # a second deletion takes back the first arrival: b(1, p) takes a(1, y) instead
    assert net_output(engine.feed_batch([("a(1, x)", 1, 1, "retract")])) == Counter(
        {"r(x,p)@1-3": -1, "r(y,q)@2-4": -1, "r(y,p)@2-3": 1})


def test_identical_events_of_an_unrestricted_rule_feeding_a_policy_rule():
    """An unrestricted rule takes back one of two identical results (the same event over the
    same interval, made from different input events): the policy rule it feeds deletes the
    arrival that result made, not the latest identical one. Without a(1, p), c(1, 0) takes the
    x(1) over [0, 3]."""
    program = ("x(I) <- a(I, _) seq b(I, _).\n"
               "r1([property(consumption_policy, chronological)]) 'rule:' y(I) <- x(I) seq c(I, _).\n")
    engine = fresh(Engine.from_source(program, "identical.rtl"))
    events = [("a(1, p)", 1), ("b(1, z)", 3), ("c(1, 0)", 5), ("a(1, r)", 0), ("a(1, q)", 1)]
    assert ("add", "y(1)", 1, 5) in outputs(engine, events)
    assert net_output(engine.feed_batch([("a(1, p)", 1, 1, "retract")])) == Counter(
        {"x(1)@1-3": -1, "y(1)@1-5": -1, "y(1)@0-5": 1})
    deleted = net_output(engine.feed_batch([]))
    fresh(engine)
    without = net_output(engine.feed_batch([e for e in events if e[0] != "a(1, p)"]))
    fresh(engine)
    with_deletion = net_output(engine.feed_batch(events + [("a(1, p)", 1, 1, "retract")]))
    assert with_deletion == without and not deleted


def test_a_result_taken_back_by_a_blocker_comes_back_at_its_old_position():
    """A rule without a policy loses a result to a late blocker: the policy rule it feeds
    gives its partner to another instance. When the blocker is deleted, the result arrives
    where it first arrived (before that instance), so the policy rule pairs it again."""
    program = ("un(I) <- not(c(I, _)).[a(I, _), b(I, _)].\n"
               "hc([property(consumption_policy, chronological)]) 'rule:' hc(I, Y) <- un(I) seq d(I, Y).\n")
    engine = fresh(Engine.from_source(program, "withdrawn.rtl"))
    events = [("a(1, 1)", 0), ("b(1, 0)", 3), ("a(1, 0)", 1), ("d(1, 0)", 5)]
    assert ("add", "hc(1,0)", 0, 5) in outputs(engine, events)
    assert net_output(engine.feed_batch([("c(1, 0)", 0.5)])) == Counter(
        {"un(1)@0-3": -1, "hc(1,0)@0-5": -1, "hc(1,0)@1-5": 1})
    assert net_output(engine.feed_batch([("c(1, 0)", 0.5, 0.5, "retract")])) == Counter(
        {"un(1)@0-3": 1, "hc(1,0)@0-5": 1, "hc(1,0)@1-5": -1})


def test_rules_added_at_run_time_record_the_results_a_policy_rule_takes():
    """The same through the sandbox: a rule without a policy added with the policy rule it feeds."""
    engine = fresh(Engine.from_source("base(X) <- a(X, _).\n", "base_made.rtl"))
    engine.add_rules("ux(I) <- a(I, _) seq b(I, _).\n"
                     "hr([property(consumption_policy, chronological)]) 'rule:' y(I) <- ux(I) seq c(I, _).\n")
    engine.feed_batch([("a(1, p)", 1), ("b(1, z)", 3), ("c(1, 0)", 5), ("a(1, r)", 0), ("a(1, q)", 1)])
    assert net_output(engine.feed_batch([("a(1, p)", 1, 1, "retract")])) == Counter(
        {"base(1)@1-1": -1, "ux(1)@1-3": -1, "y(1)@1-5": -1, "y(1)@0-5": 1})



def nets_to_the_run_without(program, name, events, deleted):
    """The net output with `deleted` retracted at the end, checked against the run in which
    it never arrived (its latest arrival, for an event that arrived twice)."""
    engine = fresh(Engine.from_source(program, name))
    with_deletion = net_output(engine.feed_batch(events + [deleted + (deleted[1], "retract")]))
    fresh(engine)
    latest = len(events) - 1 - events[::-1].index(deleted)
    without = net_output(engine.feed_batch(events[:latest] + events[latest + 1:]))
    assert with_deletion == without
    return with_deletion


def test_a_result_whose_blocker_came_first_arrives_where_its_last_input_arrived():
    """The blocker d(1, 0) comes before the a and b it blocks: un(1) over [0, 3] is never made,
    and c takes un(1) over [2, 3]. Deleting d makes the first un(1) where b arrived, before the
    second, so c takes it."""
    program = ("un(I) <- not(d(I, _)).[a(I, _), b(I, _)].\n"
               "pn([property(consumption_policy, chronological)]) 'rule:' pn(I, Y) <- un(I) seq c(I, Y).\n")
    events = [("d(1, 0)", 1), ("a(1, 0)", 0), ("b(1, 0)", 3), ("a(1, 1)", 2), ("c(1, 0)", 6)]
    assert nets_to_the_run_without(program, "blocker_first.rtl", events, ("d(1, 0)", 1)) == Counter(
        {"un(1)@0-3": 1, "un(1)@2-3": 1, "pn(1,0)@0-6": 1})


def test_a_first_pair_made_again_arrives_where_its_last_input_arrived():
    """Under `first`, a(1, 0) pairs with b at 3; deleting it pairs a(1, 0) with b at 5, as
    when b at 5 arrived, before a(1, 1) paired with it: c takes that pair."""
    program = ("ff([property(consumption_policy, first)]) 'rule:' ff(I) <- a(I, _) seq b(I, _).\n"
               "pr([property(consumption_policy, chronological)]) 'rule:' pr(I, Y) <- ff(I) seq c(I, Y).\n")
    events = [("a(1, 0)", 0), ("b(1, 0)", 3), ("b(1, 1)", 5), ("a(1, 1)", 4), ("c(1, 0)", 6)]
    assert nets_to_the_run_without(program, "first_again.rtl", events, ("b(1, 0)", 3)) == Counter(
        {"ff(1)@0-5": 1, "ff(1)@4-5": 1, "pr(1,0)@0-6": 1})


def test_an_absence_blocked_from_the_start_arrives_where_it_was_decided():
    """c blocks the absence after a(1, 0) before it is decided; the one after a(1, 1) is
    decided later, and d(1, 0) takes it. Deleting c (inside the horizon, max_delay 0 + 2 * 3 s)
    makes the first absence where it was decided, before the second, so d(1, 0) takes it."""
    program = ("ab(I) <- not(c(I, _)).[a(I, _), 3].\n"
               "pab([property(consumption_policy, chronological)]) 'rule:' pab(I, Y) <- ab(I) seq d(I, Y).\n")
    engine = fresh(Engine.from_source(program, "absence_first.rtl"), "0")
    events = [("a(1, 0)", 0), ("c(1, 0)", 2), ("a(1, 1)", 2.5), ("d(1, 0)", 6), ("d(1, 1)", 7)]
    with_deletion = net_output(engine.feed_batch(events + [("c(1, 0)", 2, 2, "retract")]))
    fresh(engine, "0")
    assert with_deletion == net_output(engine.feed_batch([e for e in events if e[0] != "c(1, 0)"])) == Counter(
        {"ab(1)@0-3": 1, "ab(1)@2.5-5.5": 1, "pab(1,0)@0-6": 1, "pab(1,1)@2.5-7": 1})

def test_values_an_aggregate_gives_again_arrive_where_they_were_first_given():
    """Deleting one of two b's takes back the count 2 and gives the count 1 again where it was
    first given, before d arrived: d takes it (recent: the newest value waiting)."""
    program = ("ua(I, N) <- a(I, _) seq aggregate(count, b(I, _), N).\n"
               "pa([property(consumption_policy, recent)]) 'rule:' pa(I, N, Y) <- ua(I, N) seq d(I, Y).\n")
    events = [("a(1, 2)", 1), ("b(1, 1)", 2), ("b(1, 0)", 2), ("d(1, 0)", 6)]
    assert nets_to_the_run_without(program, "aggregate_again.rtl", events, ("b(1, 1)", 2)) == Counter(
        {"ua(1,0)@1-1": 1, "ua(1,1)@1-2": 1, "pa(1,1,0)@1-6": 1})
    # of two arrivals of the same b, the deletion takes back the latest (after d)
    events = [("a(1, 1)", 1), ("b(1, 1)", 3), ("b(1, 1)", 3), ("d(1, 2)", 6), ("b(1, 1)", 3)]
    assert nets_to_the_run_without(program, "aggregate_twice.rtl", events, ("b(1, 1)", 3)) == Counter(
        {"ua(1,0)@1-1": 1, "ua(1,1)@1-3": 1, "ua(1,2)@1-3": 1, "pa(1,2,2)@1-6": 1})

def test_an_aggregate_gives_its_values_in_the_arrival_order_of_their_start_events():
    """Deleting b(1, 0) gives a(1, 0) at 2 its count 0 again, after a(1, 0) at 0 in the
    aggregate's store; the next b must still give the value of the a that arrived first
    before the other, as in the run without the deleted b: the third d (chronological)
    takes the value given first. The second case: an update moves an accumulator to the end
    of the store too (b(1, 0) at 3 counts for a(1, 0) at 0, not for the one at 5)."""
    program = ("ua(I, N) <- a(I, _) seq aggregate(count, b(I, _), N).\n"
               "pa([property(consumption_policy, chronological)]) 'rule:' pa(I, N, Y) <- ua(I, N) seq d(I, Y).\n")
    engine = fresh(Engine.from_source(program, "aggregate_order.rtl"))
    cases = [([("a(1, 0)", 2), ("b(1, 0)", 3), ("a(1, 0)", 0)], ("b(1, 0)", 3), [("d(1, 0)", 4)] * 3 + [("b(1, 1)", 3)],
              "pa(1,1,0)@2-4"),
             ([("a(1, 0)", 0), ("a(1, 0)", 5), ("b(1, 0)", 3)], ("b(1, 0)", 3), [("d(1, 0)", 7)] * 3 + [("b(1, 1)", 6)],
              "pa(1,1,0)@0-7")]
    for before, deleted, after, taken in cases:
        fresh(engine)
        with_deletion = net_output(engine.feed_batch(before + [deleted + (deleted[1], "retract")] + after))
        fresh(engine)
        without = net_output(engine.feed_batch([e for e in before if e != deleted] + after))
        assert with_deletion == without
        assert without[taken] == 1


def test_the_rule_without_a_policy_deletes_the_latest_arrival_of_an_event():
    """a(1, 0) at 1 arrives twice; its deletion takes back the second arrival, so the first
    stays the first a the b pairs with, and c takes its result."""
    program = ("ux(I) <- a(I, _) seq b(I, _).\n"
               "px([property(consumption_policy, chronological)]) 'rule:' px(I, Y) <- ux(I) seq c(I, Y).\n")
    events = [("a(1, 0)", 1), ("a(1, 0)", 0), ("a(1, 0)", 1), ("c(1, 0)", 6)]
    engine = fresh(Engine.from_source(program, "twice_unrestricted.rtl"))
    engine.feed_batch(events + [("a(1, 0)", 1, 1, "retract")])
    assert net_output(engine.feed_batch([("b(1, 1)", 4)])) == Counter(
        {"ux(1)@1-4": 1, "ux(1)@0-4": 1, "px(1,0)@1-6": 1})


def test_identical_partial_matches_of_a_rule_without_a_policy_are_told_apart():
    """a(1, 0) over [0, 0] and over [0, 1] make identical partial matches of `a seq b` (over
    [0, 4]: only their inner times differ), with one from a(1, 2) between them. Deleting the
    second a(1, 0) takes back its own: the first partial match stays first, and c takes its
    result."""
    program = ("u3(I) <- a(I, _) seq b(I, _) seq d(I, _).\n"
               "p3([property(consumption_policy, chronological)]) 'rule:' p3(I, Y) <- u3(I) seq c(I, Y).\n")
    events = [("c(1, 1)", 8), ("a(1, 0)", 0), ("b(1, 0)", 4), ("a(1, 2)", 1), ("a(1, 0)", 0, 1)]
    engine = fresh(Engine.from_source(program, "inner.rtl"))
    engine.feed_batch(events + [("a(1, 0)", 0, 1, "retract")])
    assert net_output(engine.feed_batch([("d(1, 0)", 5)])) == Counter(
        {"u3(1)@0-5": 1, "u3(1)@1-5": 1, "p3(1,1)@0-8": 1})

# ---- a brute-force simulation of the policies ----------------------------------------------

SIMULATED = {
    "sq": ("seq", None, lambda s1, e1, s2, e2: e1 < s2, lambda s1, e1, s2, e2: (s1, e2)),
    "wa": ("and", 3, lambda s1, e1, s2, e2: True, lambda s1, e1, s2, e2: (min(s1, s2), max(e1, e2))),
    "nt": ("not", None, lambda s1, e1, s2, e2: e1 < s2, lambda s1, e1, s2, e2: (s1, e2)),
}


def simulated_program(policy):
    return (f":- set_etalis_flag(event_consumption_policy, {policy}).\n"
            "sq(I, X, Y) <- a(I, X) seq b(I, Y).\n"
            "wa(I, X, Y) <- (a(I, X) and b(I, Y)).3.\n"
            "nt(I, X, Y) <- not(c(I, _)).[a(I, X), b(I, Y)].\n")


def simulate(policy, arrival):
    """Each rule in arrival order: an instance pairs with the newest (recent) or oldest
    (chronological) waiting partner of the other side with its key that fits, and both are
    consumed; else it waits, under `recent` replacing a waiting identical twin. A blocker
    blocks the pairs made after it arrived."""
    result = Counter()
    for name, (op, window, relation, interval) in SIMULATED.items():
        waiting = {"a": [], "b": []}
        blockers = []
        for kind, key, value, start, duration in arrival:
            end = start + duration
            if kind == "c":
                blockers.append((key, start, end))
                continue
            other = "b" if kind == "a" else "a"

            def fits(partner):
                (k2, v2, s2, e2) = partner
                if k2 != key:
                    return False
                (ls, le, rs, re_) = (start, end, s2, e2) if kind == "a" else (s2, e2, start, end)
                if not relation(ls, le, rs, re_):
                    return False
                s, e = interval(ls, le, rs, re_)
                if window is not None and e - s > window:
                    return False
                if op == "not" and any(bk == key and le < bs and be < rs for bk, bs, be in blockers):
                    return False
                return True
            candidates = [p for p in waiting[other] if fits(p)]
            if candidates:
                partner = candidates[-1] if policy == "recent" else candidates[0]
                waiting[other].remove(partner)
                (_, v2, s2, e2) = partner
                (x, ls, le, y, rs, re_) = (value, start, end, v2, s2, e2) if kind == "a" else (v2, s2, e2, value, start, end)
                s, e = interval(ls, le, rs, re_)
                result[f"{name}({key},{x},{y})@{s}-{e}"] += 1
            else:
                if policy == "recent":
                    waiting[kind] = [w for w in waiting[kind] if (w[0], w[1]) != (key, value)]
                waiting[kind].append((key, value, start, end))
    return result


event = st.tuples(st.sampled_from("aabbc"), st.integers(1, 2), st.integers(0, 2), st.integers(0, 8),
                  st.sampled_from([0, 0, 1]))


def with_deletions(data, arrival):
    """The operations: every event added in arrival order, some deleted again at a later point;
    and the events that remain, in arrival order (a deletion removes the latest arrival of an
    identical event added before it)."""
    doomed = data.draw(st.lists(st.integers(0, len(arrival) - 1), unique=True, max_size=len(arrival)))
    ops = [("add", e) for e in arrival]
    for index in sorted(doomed, reverse=True):
        ops.insert(data.draw(st.integers(index + 1, len(ops))), ("retract", arrival[index]))
    present = []
    for op, e in ops:
        if op == "add":
            present.append(e)
        else:
            del present[len(present) - 1 - present[::-1].index(e)]
    return ops, present


def feed(engine, ops, max_delay="inf"):
    fresh(engine, max_delay)
    return net_output(engine.feed_batch([(f"{k}({i}, {x})", s, s + d, op)
                                         for op, (k, i, x, s, d) in ops]))


@pytest.fixture(scope="module", params=["recent", "chronological"])
def simulated(request):
    engine = Engine.from_source(simulated_program(request.param), f"{request.param}.rtl")
    yield request.param, engine
    fresh(engine, "1.0")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(event, min_size=2, max_size=12), st.data())
def test_deletions_match_the_simulation_without_the_deleted_events(simulated, events, data):
    policy, engine = simulated
    arrival = data.draw(st.permutations(events))
    ops, remaining = with_deletions(data, arrival)
    assert feed(engine, ops) == simulate(policy, remaining)


# ---- every rule shape against a run without the deleted events ----------------------------

SHAPES = [
    "sq{p}(I, X, Y) <- a(I, X) seq b(I, Y).",
    "th{p}(I, X, Z) <- a(I, X) seq b(I, _) seq c(I, Z).",
    "wd{p}(I, X, Y) <- (a(I, X) and b(I, Y)).3.",
    "wh{p}(I, X, Y) <- a(I, X) seq b(I, Y) where X =< Y.",
    "nt{p}(I, X) <- not(c(I, _)).[a(I, X), b(I, _)].",
    "cn{p}(I, X) <- (a(I, X) seq b(I, _)) cnot c(_, _).",
    "hi{p}(I, X) <- sq{p}(I, X, _) seq c(I, _).",
    "nk{p}(X, Y) <- a(_, X) seq b(_, Y).",
]


def policy_program(shapes, label="", policies=(("recent", "r"), ("chronological", "c"), ("unrestricted", "u"))):
    """Each shape once under each policy, as a rule labelled `label` + policy tag + its number."""
    rules = []
    for policy, tag in policies:
        for n, shape in enumerate(shapes):
            rules.append(f"{label}{tag}{n}([property(consumption_policy, {policy})]) 'rule:' " + shape.format(p=tag))
    return "\n".join(rules) + "\n"


def shapes_program():
    return policy_program(SHAPES)


def program_engine(lines, name):
    """An engine running the program of `lines`, shared by a module's properties; reset after."""
    engine = Engine.from_source("\n".join(lines) + "\n", name)
    yield engine
    fresh(engine, "1.0")


@pytest.fixture(scope="module")
def shapes():
    engine = Engine.from_source(shapes_program(), "shapes.rtl")
    yield engine
    fresh(engine, "1.0")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(event, min_size=2, max_size=12), st.data())
def test_every_shape_nets_to_the_run_without_the_deleted_events(shapes, events, data):
    arrival = data.draw(st.permutations(events))
    ops, remaining = with_deletions(data, arrival)
    assert feed(shapes, ops) == feed(shapes, [("add", e) for e in remaining])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(event, st.integers(0, 2)), min_size=2, max_size=14), st.data())
def test_deletions_inside_the_horizon_within_the_delay_bound(shapes, delayed, data):
    """Events arrive up to 2 s late (the delay bound); deletions come at a random later point
    and only while the event is inside the retraction horizon (H = 2 + 3 s, the largest window)."""
    kept, present = late_arrivals_with_deletions(data, delayed, horizon=5)
    assert feed(shapes, kept, "2") == feed(shapes, [("add", e) for e in present], "2")


def late_arrivals_with_deletions(data, delayed, horizon):
    """The events in the order they arrive (each late by its delay), with deletions drawn at
    random later points; a deletion is kept only while its event ends inside the retraction
    horizon. Returns the operations and the events present at the end (of several identical
    ones, a deletion takes back the latest arrival)."""
    arrival = [e for e, _ in sorted(delayed, key=lambda ed: ed[0][3] + ed[0][4] + ed[1])]
    ops, _ = with_deletions(data, arrival)
    kept, clock, present = [], float("-inf"), []
    for op, e in ops:
        end = e[3] + e[4]
        if op == "add":
            clock = max(clock, end)
            present.append(e)
        elif end >= clock - horizon:
            del present[len(present) - 1 - present[::-1].index(e)]
        else:
            continue
        kept.append((op, e))
    return kept, present


def test_a_rule_added_at_run_time_deletes_exactly_too():
    """Rules added while events flow pass the sandbox (rtl_sandbox.pl) with the policy runtime."""
    engine = fresh(Engine.from_source("base(X) <- a(X, _).\n", "base.rtl"))
    assert engine.add_rules("late([property(consumption_policy, recent)]) 'rule:' pair(X, Y) <- a(1, X) seq b(1, Y).\n"
                            ) == ["late"]
    engine.feed_batch([("a(1, x)", 1), ("a(1, y)", 2), ("b(1, p)", 3), ("b(1, q)", 4)])
    assert net_output(engine.feed_batch([("a(1, y)", 2, 2, "retract")])) == Counter(
        {"base(1)@2-2": -1, "pair(y,p)@2-3": -1, "pair(x,q)@1-4": -1, "pair(x,p)@1-3": 1})


# ---- harder shapes: partial matches with unbound variables, an event reaching a step twice,
# identical events, the `first` selection, and rules fed by identical derived events ---------

HARD_SHAPES = [
    # one branch of an `or` leaves the other branch's variables unbound in the stored match
    "ol{p}(I, Z) <- (a(I, X) or c(I, Y)) seq b(I, Z).",
    "or{p}(I, X) <- a(I, X) seq (b(I, Y) or c(I, Z)).",
    # the same input event reaches both sides of a step (and, below, two steps of the rule)
    "rp{p}(I, X, Y) <- a(I, X) seq a(I, Y).",
    "ra{p}(I, X, Y) <- (b(I, X) and b(I, Y)).3.",
    "r3{p}(I, X, Z) <- a(I, X) seq b(I, _) seq a(I, Z).",
    "ro{p}(I, X) <- (a(I, X) or b(I, X)) seq (b(I, _) or c(I, _)).",
    # ... and reaches the second step of the rule through the first one before it reaches it
    # directly: its arrivals there come right, then left
    "rb{p}(I, X, Z) <- b(I, X) and (a(I, _) seq b(I, Z)).",
    # a partial match whose join key is unbound (the `c` branch) pairs with every key
    "nk{p}(X) <- (a(I, X) or c(_, X)) seq b(I, _).",
]


def hard_program(policies=(("recent", "r"), ("chronological", "c"), ("unrestricted", "u"), ("first", "f"))):
    return policy_program(HARD_SHAPES, "h", policies)


@pytest.fixture(scope="module")
def hard():
    engine = Engine.from_source(hard_program(), "hard.rtl")
    yield engine
    fresh(engine, "1.0")


def with_duplicates(data, events):
    """Some events twice (the same event, at the same times), in a random order."""
    twice = data.draw(st.lists(st.sampled_from(events), max_size=3))
    return data.draw(st.permutations(events + twice))


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(event, min_size=2, max_size=11), st.data())
def test_hard_shapes_net_to_the_run_without_the_deleted_events(hard, events, data):
    arrival = with_duplicates(data, events)
    ops, remaining = with_deletions(data, arrival)
    assert feed(hard, ops) == feed(hard, [("add", e) for e in remaining])


@pytest.fixture(scope="module")
def hard_added():
    engine = fresh(Engine.from_source("base(X) <- a(X, _).\n", "base_hard.rtl"))
    engine.add_rules(hard_program((("recent", "r"), ("chronological", "c"), ("first", "f"))))
    yield engine
    fresh(engine, "1.0")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(event, min_size=2, max_size=10), st.data())
def test_hard_shapes_added_at_run_time_net_to_the_run_without_the_deleted_events(hard_added, events, data):
    """The same rules added while the program runs (through the sandbox)."""
    arrival = with_duplicates(data, events)
    ops, remaining = with_deletions(data, arrival)
    assert feed(hard_added, ops) == feed(hard_added, [("add", e) for e in remaining])


# ---- hierarchies: rules without a policy feeding policy rules -------------------------------

HIERARCHY = [
    "ux(I) <- a(I, _) seq b(I, _).",
    "uw(I) <- (a(I, _) and c(I, _)).2.",
    "hr([property(consumption_policy, recent)]) 'rule:' hr(I, Y) <- ux(I) seq c(I, Y).",
    "hc([property(consumption_policy, chronological)]) 'rule:' hc(I, Y) <- ux(I) seq c(I, Y).",
    "hw([property(consumption_policy, chronological)]) 'rule:' hw(I) <- uw(I) seq b(I, _).",
    "hn([property(consumption_policy, chronological)]) 'rule:' hn(I) <- not(ux(I)).[a(I, _), c(I, _)].",
]


# a's before b's before c's: the a's make identical ux(1) over [0, 3] or [1, 3] with each b
staged_event = st.one_of(st.tuples(st.just("a"), st.just(1), st.integers(0, 2), st.integers(0, 1), st.just(0)),
                         st.tuples(st.just("b"), st.just(1), st.integers(0, 1), st.just(3), st.just(0)),
                         st.tuples(st.just("c"), st.just(1), st.integers(0, 1), st.sampled_from([2, 4, 5]), st.just(0)))


@pytest.fixture(scope="module")
def hierarchy():
    yield from program_engine(HIERARCHY, "hierarchy.rtl")


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(staged_event, st.integers(0, 2)), min_size=4, max_size=10, unique_by=lambda ed: ed[0]),
       st.data())
def test_unrestricted_rules_feeding_policy_rules_net_to_the_run_without_the_deleted_events(hierarchy, delayed, data):
    """Identical derived events (the same event over the same interval from different input
    events, or from input events that arrived twice) reach the policy rules; events arrive up
    to 2 s late; deletions come inside the retraction horizon (H = 2 + 2 s)."""
    kept, present = late_arrivals_with_deletions(data, delayed, horizon=4)
    assert feed(hierarchy, kept, "2") == feed(hierarchy, [("add", e) for e in present], "2")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(staged_event, min_size=5, max_size=10, unique=True), st.data())
def test_unrestricted_rules_feeding_policy_rules_in_any_arrival_order(hierarchy, events, data):
    """The same without a delay bound: any arrival order."""
    arrival = list(dict.fromkeys(events))                   # (the list is the arrival order)
    ops, remaining = with_deletions(data, arrival)
    assert feed(hierarchy, ops) == feed(hierarchy, [("add", e) for e in remaining])


# Rules without a policy that tell their input events apart by arrival: results made late (a
# blocker deleted, a `first` partner deleted), the same input event arriving twice, and
# identical partial matches of earlier steps (from a's over [0, 0] and [0, 1] with the same b).
EXACT_HIERARCHY = [
    "un(I) <- not(d(I, _)).[a(I, _), b(I, _)].",
    "uf(I) <- (b(I, _) seq c(I, _)) fnot d(I, _).",
    "ff([property(consumption_policy, first)]) 'rule:' ff(I) <- a(I, _) seq b(I, _).",
    "u3(I) <- a(I, _) seq b(I, _) seq c(I, _).",
    "pn([property(consumption_policy, chronological)]) 'rule:' pn(I, Y) <- un(I) seq c(I, Y).",
    "pf([property(consumption_policy, recent)]) 'rule:' pf(I, Y) <- uf(I) seq d(I, Y).",
    "pr([property(consumption_policy, chronological)]) 'rule:' pr(I, Y) <- ff(I) seq c(I, Y).",
    "p3([property(consumption_policy, chronological)]) 'rule:' p3(I, Y) <- u3(I) seq d(I, Y).",
    "uw(I) <- (a(I, _) and b(I, _)).3.",
    "pw([property(consumption_policy, recent)]) 'rule:' pw(I, Y) <- uw(I) seq c(I, Y).",
    "ua(I, N) <- a(I, _) seq aggregate(count, b(I, _), N).",
    "pa([property(consumption_policy, chronological)]) 'rule:' pa(I, N, Y) <- ua(I, N) seq d(I, Y).",
]

# a's before b's before c's; d's between them (blockers) and last: identical results over
# the same interval from different events, or from events that arrived twice
exact_event = st.one_of(st.tuples(st.just("a"), st.just(1), st.integers(0, 2), st.sampled_from([0, 2]), st.integers(0, 1)),
                        st.tuples(st.just("b"), st.just(1), st.integers(0, 1), st.sampled_from([3, 5]), st.just(0)),
                        st.tuples(st.just("c"), st.just(1), st.integers(0, 1), st.sampled_from([6, 7]), st.just(0)),
                        st.tuples(st.just("d"), st.just(1), st.integers(0, 1), st.sampled_from([1, 4, 8]), st.just(0)))


@pytest.fixture(scope="module")
def exact_hierarchy():
    yield from program_engine(EXACT_HIERARCHY, "exact_hierarchy.rtl")


@settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(exact_event, min_size=4, max_size=10), st.data())
def test_rules_without_a_policy_feeding_policy_rules_tell_arrivals_apart(exact_hierarchy, events, data):
    """Results made late (a deleted blocker, a deleted `first` partner), events that arrived
    twice and identical partial matches: in any arrival order, the output nets to the run
    without the deleted events."""
    arrival = with_duplicates(data, events)
    ops, remaining = with_deletions(data, arrival)
    assert feed(exact_hierarchy, ops) == feed(exact_hierarchy, [("add", e) for e in remaining])


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(exact_event, st.integers(0, 2)), min_size=4, max_size=10), st.data())
def test_rules_without_a_policy_feeding_policy_rules_tell_arrivals_apart_within_the_delay_bound(
        exact_hierarchy, delayed, data):
    """The same with events up to 2 s late and deletions inside the retraction horizon
    (H = 2 + 3 s, the window of uw)."""
    kept, present = late_arrivals_with_deletions(data, delayed, horizon=5)
    assert feed(exact_hierarchy, kept, "2") == feed(exact_hierarchy, [("add", e) for e in present], "2")


# Aggregates with a window feeding policy rules: their accumulators move between the window's
# stores as the clock passes, and are still taken in the arrival order of their start events.
WINDOWED_AGGREGATES = [
    "ua(I, N) <- (a(I, _) seq aggregate(count, b(I, _), N)).4.",
    "pa([property(consumption_policy, chronological)]) 'rule:' pa(I, N, Y) <- ua(I, N) seq d(I, Y).",
    "us(I, N) <- (a(I, _) seq aggregate(sum(V), c(I, V), N)).6.",
    "ps([property(consumption_policy, recent)]) 'rule:' ps(I, N, Y) <- us(I, N) seq d(I, Y).",
]

# over 40 s, so that the windows' stores age while events arrive
spread_event = st.one_of(st.tuples(st.just("a"), st.just(1), st.integers(0, 2), st.integers(0, 40), st.integers(0, 1)),
                         st.tuples(st.sampled_from(["b", "c", "d"]), st.just(1), st.integers(0, 1), st.integers(0, 40),
                                   st.just(0)))


@pytest.fixture(scope="module")
def windowed_aggregates():
    yield from program_engine(WINDOWED_AGGREGATES, "windowed_aggregates.rtl")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(spread_event, min_size=4, max_size=25), st.data())
def test_windowed_aggregates_feeding_policy_rules_net_to_the_run_without_the_deleted_events(
        windowed_aggregates, events, data):
    """In any arrival order, with events that arrive twice."""
    arrival = with_duplicates(data, events)
    ops, remaining = with_deletions(data, arrival)
    assert feed(windowed_aggregates, ops) == feed(windowed_aggregates, [("add", e) for e in remaining])


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(spread_event, st.integers(0, 2)), min_size=4, max_size=25), st.data())
def test_windowed_aggregates_feeding_policy_rules_within_the_delay_bound(windowed_aggregates, delayed, data):
    """Events up to 2 s late, deletions inside the retraction horizon (H = 2 + 6 s)."""
    kept, present = late_arrivals_with_deletions(data, delayed, horizon=8)
    assert feed(windowed_aggregates, kept, "2") == feed(windowed_aggregates, [("add", e) for e in present], "2")


# ---- sliding aggregates feeding policy rules ------------------------------------------------

def test_a_change_a_sliding_aggregate_gives_after_a_deletion_arrives_where_it_is_given_without_the_event():
    """Without seen(1, b), the count drops to 0 at 6 (seen(1, a) leaves the window) when
    c(1, x) moves the clock past 6, just before c arrives: c (recent) takes it. With the
    deletion made after c, the count 0 at 6 is given at the deletion, after c."""
    program = ("occ(R, N) <- sliding(count, seen(R, _), R, 5, N).\n"
               "ps([property(consumption_policy, recent)]) 'rule:' ps(R, N, Y) <- occ(R, N) seq c(R, Y).\n")
    events = [("seen(1, a)", 1), ("seen(1, b)", 2), ("c(1, x)", 6.5)]
    assert nets_to_the_run_without(program, "sliding_again.rtl", events, ("seen(1, b)", 2)) == Counter(
        {"occ(1,1)@1-1": 1, "occ(1,0)@6-6": 1, "ps(1,0,x)@6-6.5": 1})


def test_sliding_aggregates_added_at_run_time_place_their_changes_too():
    """The same hierarchy added while the program runs (through the sandbox)."""
    rules = ("occ(R, N) <- sliding(count, seen(R, _), R, 5, N).\n"
             "ps([property(consumption_policy, recent)]) 'rule:' ps(R, N, Y) <- occ(R, N) seq c(R, Y).\n")
    events = [("seen(1, a)", 1), ("seen(1, b)", 2), ("c(1, x)", 6.5)]
    engine = fresh(Engine.from_source("base(X) <- c(X, _).\n", "base_sliding.rtl"))
    engine.add_rules(rules)
    with_deletion = net_output(engine.feed_batch(events + [("seen(1, b)", 2, 2, "retract")]))
    assert with_deletion == Counter({"occ(1,1)@1-1": 1, "occ(1,0)@6-6": 1, "ps(1,0,x)@6-6.5": 1,
                                     "base(1)@6.5-6.5": 1})


SLIDING_HIERARCHY = [
    "sl(I, N) <- sliding(count, a(I, _), I, 3, N).",
    "su(I, S) <- sliding(sum(X), a(I, X), I, 3, S).",
    "sm(I, M) <- sliding(max(X), a(I, X), I, 2, M).",
    "sr([property(consumption_policy, recent)]) 'rule:' sr(I, N, Y) <- sl(I, N) seq c(I, Y).",
    "sc([property(consumption_policy, chronological)]) 'rule:' sc(I, S, Y) <- su(I, S) seq c(I, Y).",
    "sx([property(consumption_policy, recent)]) 'rule:' sx(I, M, Y) <- sm(I, M) seq c(I, Y).",
    # the values taken inside a policy rule, not as a derived event
    "sw([property(consumption_policy, chronological)]) 'rule:' sw(I, N, Y) <- "
    "sliding(count, a(I, _), I, 2, N) seq c(I, Y).",
]

sliding_event = st.one_of(st.tuples(st.just("a"), st.integers(1, 2), st.integers(0, 2), st.integers(0, 6), st.just(0)),
                          st.tuples(st.just("c"), st.integers(1, 2), st.integers(0, 1), st.integers(1, 9), st.just(0)))


@pytest.fixture(scope="module")
def sliding_hierarchy():
    yield from program_engine(SLIDING_HIERARCHY, "sliding_hierarchy.rtl")


def without_clock_movers(ops):
    """The operations less the deletions of events whose arrival moved the clock: a deletion
    does not move the clock back, so the leaves such an event made due stay given (as for a
    sliding aggregate without a policy), where the run without it gives them later or not
    at all. Returns the operations and the events present at the end."""
    kept, clock, present = [], float("-inf"), []
    for op, e in ops:
        end = e[3] + e[4]
        if op == "add":
            present.append((e, end > clock))
            clock = max(clock, end)
        else:
            latest = len(present) - 1 - [p for p, _ in present][::-1].index(e)
            if present[latest][1]:
                continue
            del present[latest]
        kept.append((op, e))
    return kept, [e for e, _ in present]


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(sliding_event, st.integers(0, 2)), min_size=3, max_size=10), st.data())
def test_sliding_aggregates_feeding_policy_rules_net_to_the_run_without_the_deleted_events(
        sliding_hierarchy, delayed, data):
    """Events up to 2 s late, deletions inside the retraction horizon (H = 2 + 3 s, the
    sliding window) of events that did not move the clock: the output nets to the run
    without the deleted events."""
    ops, _ = late_arrivals_with_deletions(data, delayed, horizon=5)
    kept, present = without_clock_movers(ops)
    assert feed(sliding_hierarchy, kept, "2") == feed(sliding_hierarchy, [("add", e) for e in present], "2")
