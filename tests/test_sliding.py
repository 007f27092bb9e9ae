"""Sliding aggregates by group: `sliding(F, P, Group, D, V)` outputs the
value of F over each group's matches of P that ended in the last D seconds whenever it
changes, also when a match leaves the window; exact under out-of-order arrival and deletion
(checked against a brute-force oracle), memory bounded by the matches inside the window."""
from collections import Counter, defaultdict

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine
from retalisc.frontend.errors import RetalisError

from ele_oracle import net_output
from timer_support import fresh, outputs

PROGRAM = """
occupancy(Room, N) <- sliding(count, seen(_, Room), Room, 6, N).
load(Room, S) <- sliding(sum(W), seen(W, Room), Room, 4, S).
lightest(Room, M) <- sliding(min(W), seen(W, Room), Room, 5, M).
mean(Room, A) <- sliding(avg(W), seen(W, Room), Room, 3, A).
busy(Room) <- sliding(count, seen(_, Room), Room, 6, N) where N >= 3.
"""
SPECS = {"occupancy": ("count", 6), "load": ("sum", 4), "lightest": ("min", 5), "mean": ("avg", 3)}




@pytest.fixture(scope="module")
def engine():
    engine = Engine.from_source(PROGRAM, "sliding.rtl")
    yield engine
    fresh(engine)


def test_counts_enter_and_leave_the_window(engine):
    engine = fresh(engine, "0")
    produced = [o for o in outputs(engine, [("seen(1, k)", 0), ("seen(2, k)", 2), ("seen(3, h)", 3), ("tick", 7),
                                             ("tick", 20)]) if o[0].startswith("occupancy")]
    assert produced == [("occupancy(k,1)", 0, 0, "add"), ("occupancy(k,2)", 2, 2, "add"),
                        ("occupancy(h,1)", 3, 3, "add"), ("occupancy(k,1)", 6, 6, "add"),
                        ("occupancy(k,0)", 8, 8, "add"), ("occupancy(h,0)", 9, 9, "add")]


def test_a_late_match_corrects_the_values_it_changes(engine):
    engine = fresh(engine, "5")
    outputs(engine, [("seen(1, k)", 0), ("seen(2, k)", 4), ("tick", 7)])
    late = [o for o in outputs(engine, [("seen(5, k)", 3)]) if o[0].startswith("occupancy")]
    # the value from 3 on was 2, not 1; at 4 it became 3, not 2; at 6 (the first left) 2, not 1
    assert sorted(late) == sorted([("occupancy(k,2)", 3, 3, "add"), ("occupancy(k,2)", 4, 4, "retract"),
                                   ("occupancy(k,3)", 4, 4, "add"), ("occupancy(k,1)", 6, 6, "retract"),
                                   ("occupancy(k,2)", 6, 6, "add")])


def test_a_condition_filters_the_values(engine):
    engine = fresh(engine, "0")
    produced = outputs(engine, [("seen(1, k)", 0), ("seen(2, k)", 1), ("seen(3, k)", 2), ("seen(4, k)", 3),
                                ("tick", 30)])
    assert [o for o in produced if o[0].startswith("busy")] == [("busy(k)", 2, 2, "add"), ("busy(k)", 3, 3, "add"),
                                                                ("busy(k)", 6, 6, "add")]


def test_memory_stays_flat(engine):
    engine = fresh(engine, "1")
    sizes = []
    for block in range(5):
        engine.feed_batch([(f"seen({i % 9}, r{i % 4})", block * 1000 + i * 0.5) for i in range(120)])
        sizes.append(engine.store_size())
    # a block holds 120 events, 600 matches of the five rules; the store keeps the windows' and the
    # horizon's worth, whatever the length of the run
    assert max(sizes) < 600 and max(sizes[1:]) - min(sizes[1:]) <= 20, sizes


@pytest.mark.parametrize("text, message", [
    ("x(N) <- sliding(median(W), a(W), k, 3, N).", "unknown aggregate function"),
    ("x(N) <- sliding(count, a(W), k, 0, N).", "positive number of seconds"),
    ("x(N) <- sliding(count, a(W), k, 3, 4).", "named variable"),
    ("x(N) <- sliding(sum(Z), a(W), W, 3, N).", "does not occur in the aggregated pattern"),
    ("x(N) <- sliding(count, a(W), G, 3, N).", "group"),
])
def test_bad_sliding_aggregates_are_located_errors(text, message):
    with pytest.raises(RetalisError) as error:
        compile_source(text, "bad.rtl")
    assert message in error.value.message and error.value.span is not None


# ---- against the oracle -----------------------------------------------------------------

def number_text(value):
    return str(int(value)) if float(value).is_integer() and not isinstance(value, float) else repr(value)


def aggregate(function, values):
    if function == "count":
        return len(values)
    if function == "sum":
        return sum(values)
    if not values:
        return None
    if function == "min":
        return min(values)
    total = sum(values)
    return total // len(values) if total % len(values) == 0 else total / len(values)


def oracle(events):
    """Every change of every rule's value (all decided: the runs flush their timers)."""
    result = Counter()
    for head, (function, d) in SPECS.items():
        groups = defaultdict(list)
        for w, room, t in events:
            groups[room].append((t, w))
        for room, items in groups.items():
            for t in sorted({e for e, _ in items} | {e + d for e, _ in items}):
                now = aggregate(function, [w for e, w in items if t - d < e <= t])
                before = aggregate(function, [w for e, w in items if t - d <= e < t])
                if now is not None and now != before:
                    result[f"{head}({room},{number_text(now)})@{t}-{t}"] += 1
    return result


event = st.tuples(st.integers(0, 4), st.sampled_from(["k", "h"]), st.integers(0, 20))


def run(engine, ops, max_delay, horizon="auto"):
    fresh(engine, max_delay, "true", horizon)
    produced = engine.feed_batch([(f"seen({w}, {room})", t, t, op) for op, (w, room, t) in ops])
    produced += engine.end_of_input()
    net = net_output(produced)
    return Counter({k: v for k, v in net.items() if not k.startswith("busy")})


def test_the_oracle_is_not_trivial(engine):
    events = [(1, "k", 0), (3, "k", 2), (2, "h", 2), (4, "k", 3)]
    expected = oracle(events)
    assert {k.split("(")[0] for k in expected} == set(SPECS)
    assert run(engine, [("add", e) for e in sorted(events, key=lambda e: e[2])], "0") == expected


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(event, st.integers(0, 3)), min_size=1, max_size=14))
def test_arrival_orders_within_the_delay_bound_match_the_oracle(engine, delayed):
    arrival = [e for e, _ in sorted(delayed, key=lambda ed: ed[0][2] + ed[1])]
    assert run(engine, [("add", e) for e in arrival], "3") == oracle([e for e, _ in delayed])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(event, st.integers(0, 2)), min_size=1, max_size=12), st.data())
def test_deletions_equal_recomputation(engine, delayed, data):
    arrival = [e for e, _ in sorted(delayed, key=lambda ed: ed[0][2] + ed[1])]
    doomed = data.draw(st.lists(st.integers(0, len(arrival) - 1), unique=True, max_size=len(arrival)))
    ops = [("add", e) for e in arrival]
    for index in sorted(doomed, reverse=True):
        ops.insert(data.draw(st.integers(index + 1, len(ops))), ("retract", arrival[index]))
    remaining = [e for i, e in enumerate(arrival) if i not in doomed]
    assert run(engine, ops, "2", horizon="1000") == oracle(remaining)
