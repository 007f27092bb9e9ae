"""Synchronized rules against an oracle of the thesis's definitions (4.2.5, Def. 25-29) and
docs/runtime.md's delay bound, for issue 40 items 3, 4 and 7.

A rule `synchronized(sb(K, T, NP, NQ), Query, [[mp, T], [mq, T]]) <- trig(K)^T` waits until
both memories are up to date for T. Memory mp records p/1 (delay bound DP), mq records q/1
(delay bound DQ). The oracle (`release_step`) says at which input the match is released:
the first input, from the trigger's own on, after which each condition `[Id, T]` holds, by
itself: the memory holds a record ending after T, or its history up to T is complete by the
delay bound, `T + D < clock` (a record ending at T may still arrive exactly D seconds late,
which the bound allows). Each condition is met on its own; the match goes when the last one
is. What the query then counts (the records ending at or before T) is what the definitions
give for the whole history: arrivals keep every event within its type's bound (some exactly
at it) and each type in end-time order (the thesis's assumption that lets a later record
clear a condition), while the types interleave in any order.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Dict, List, Optional, Tuple

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine

PROGRAM = """
c_mem(mp, p(_)-[], inf, inf).
c_mem(mq, q(_)-[], inf, inf).
max_delay(p/1, {dp}).
max_delay(q/1, {dq}).
synchronized(sb(K, T, NP, NQ),
             ( aggregate_all(count, ( mem(mp, p(_)^E1), E1 =< T ), NP),
               aggregate_all(count, ( mem(mq, q(_)^E2), E2 =< T ), NQ) ),
             [[mp, T], [mq, T]]) <- trig(K)^T.
"""

DELAYS = [1, 2, 3]
_ENGINES: Dict[Tuple[int, int], Engine] = {}


def _engine(dp: int, dq: int) -> Engine:
    if (dp, dq) not in _ENGINES:
        _ENGINES[(dp, dq)] = Engine.from_source(PROGRAM.format(dp=dp, dq=dq), f"sync_oracle_{dp}_{dq}.rtl")
    e = _ENGINES[(dp, dq)]
    e.activate()
    e.end_of_input(drop_pending=True)
    e.clear()
    return e


@dataclass(frozen=True)
class Ev:
    name: str            # trig, p, q or z (moves the clock only)
    arg: int
    end: Fraction

    def text(self) -> str:
        return f"{self.name}({self.arg})"


def _num(x: Fraction):
    return int(x) if x.denominator == 1 else float(x)


def release_step(arrivals: List[Ev], trig_index: int, delays: Dict[str, int]) -> Optional[int]:
    """The index of the input at which the match of arrivals[trig_index] is released (None:
    only at the end of the input). Def. 27 with docs/runtime.md's bound: the history of a
    type up to T is complete at clock C when T + D < C; a memory is up to date for T when it
    holds a record ending after T, or when its history up to T is complete."""
    t = arrivals[trig_index].end
    clock = max(e.end for e in arrivals[:trig_index + 1])
    met = {"p": False, "q": False}
    for i in range(trig_index, len(arrivals)):
        clock = max(clock, arrivals[i].end)
        for kind in met:
            later_record = any(e.name == kind and e.end > t for e in arrivals[:i + 1])
            met[kind] = met[kind] or later_record or t + delays[kind] < clock
        if all(met.values()):
            return i
    return None


def full_history_count(arrivals: List[Ev], kind: str, t: Fraction) -> int:
    return sum(1 for e in arrivals if e.name == kind and e.end <= t)


times = st.integers(0, 24).map(lambda i: Fraction(i, 2))


@st.composite
def scenario(draw):
    dp = draw(st.sampled_from(DELAYS))
    dq = draw(st.sampled_from(DELAYS))
    delays = {"p": dp, "q": dq, "trig": 0, "z": 0}
    events = [Ev(name, i, draw(times)) for i, name in
              enumerate(draw(st.lists(st.sampled_from(["p", "q", "trig", "z", "z"]), min_size=3, max_size=14)))]
    # Each event arrives at end + a delay within its type's bound (often exactly the bound);
    # one type's events in end-time order (a later one never arrives before an earlier one).
    keyed = []
    for e in events:
        bound = delays[e.name]
        lateness = draw(st.sampled_from([Fraction(0), Fraction(bound), Fraction(bound, 2)])) if bound else Fraction(0)
        keyed.append((e.end + lateness, draw(st.integers(0, 3)), e))
    keyed.sort(key=lambda k: (k[0], k[1]))
    for kind in ("p", "q"):
        slots = [i for i, k in enumerate(keyed) if k[2].name == kind]
        in_order = sorted((keyed[i][2] for i in slots), key=lambda e: e.end)
        for i, e in zip(slots, in_order):
            keyed[i] = (keyed[i][0], keyed[i][1], e)
    return dp, dq, [k[2] for k in keyed]


def _lateness_ok(arrivals: List[Ev], delays: Dict[str, int]) -> bool:
    clock = None
    for e in arrivals:
        if clock is not None and clock - e.end > delays.get(e.name, 0) and e.name in ("p", "q"):
            return False
        clock = e.end if clock is None else max(clock, e.end)
    return True


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenario())
def test_synchronized_matches_are_released_when_each_condition_is_met(case):
    dp, dq, arrivals = case
    delays = {"p": dp, "q": dq}
    assume(_lateness_ok(arrivals, delays))           # the reordering of a type could exceed the bound
    engine = _engine(dp, dq)
    got: Dict[int, List[str]] = {}
    for i, e in enumerate(arrivals):
        got[i] = sorted(o.event for o in engine.feed(e.text(), _num(e.end)) if o.name == "sb")
    got[len(arrivals)] = sorted(o.event for o in engine.end_of_input() if o.name == "sb")
    expected: Dict[int, List[str]] = {i: [] for i in got}
    for i, e in enumerate(arrivals):
        if e.name != "trig":
            continue
        step = release_step(arrivals, i, delays)
        at = len(arrivals) if step is None else step
        counts = (full_history_count(arrivals, "p", e.end), full_history_count(arrivals, "q", e.end))
        expected[at].append(f"sb({e.arg},{_num(e.end)},{counts[0]},{counts[1]})")
    expected = {i: sorted(v) for i, v in expected.items()}
    story = f"max_delay p {dp}, q {dq}: " + ", ".join(f"{e.text()}@{_num(e.end)}" for e in arrivals)
    assert got == expected, story


def _feed_all(engine: Engine, items) -> List[List[str]]:
    return [[o.event for o in engine.feed(text, t)] for text, t in items]


def test_each_condition_has_its_own_deadline():
    """Issue 40 item 3: mp (p, bound 1) is complete up to 16 by the clock at 17.5, mq (q,
    bound 3) by the record q(0)@18.5: sb(a, 16) is due at 18.5, not at the latest deadline."""
    engine = _engine(1, 3)
    out = _feed_all(engine, [("trig(a)", 16), ("z(0)", 17.5), ("q(0)", 18.5), ("z(0)", 25)])
    assert out == [[], [], ["sb(a,16,0,0)"], []]


def test_an_event_exactly_at_the_delay_bound_is_waited_for():
    """Issue 40 item 4: max_delay 2, trig(a)@3, z@5, then p(0)@3 (exactly 2 s late, within the
    bound): the query waits for it, as the in-order run says."""
    engine = _engine(2, 1)
    late = _feed_all(engine, [("trig(a)", 3), ("q(0)", 3.5), ("z(0)", 5), ("p(0)", 3), ("z(0)", 9)])
    assert late == [[], [], [], [], ["sb(a,3,1,0)"]]
    engine = _engine(2, 1)
    in_order = _feed_all(engine, [("p(0)", 3), ("trig(a)", 3), ("q(0)", 3.5), ("z(0)", 5), ("z(0)", 9)])
    assert in_order == [[], [], [], [], ["sb(a,3,1,0)"]]


def test_a_record_ending_exactly_at_t_does_not_release_the_match():
    """Issue 40 item 7: a record ending at T does not make the memory up to date for T, since
    a second record ending at T may still come and change what prev, next and mem answer at
    T (docs/slr.md); one ending after T does (events of a type arrive in end-time order)."""
    engine = _engine(3, 3)
    out = _feed_all(engine, [("trig(a)", 4), ("p(0)", 4), ("q(0)", 4), ("q(1)", 4), ("p(2)", 5),
                             ("q(3)", 4.5)])
    assert out == [[], [], [], [], [], ["sb(a,4,1,2)"]]


def test_a_synchronized_query_waits_for_an_event_exactly_at_the_delay_bound():
    """Issue 40 item 4, the query side: `--query 3 'prev(m, p(a, V)^T, 3)'` with
    max_delay(p/2, 2) and trig(a)@3, z@5, p(a, 1)@3, z@9 answers p(a, 1), as the in-order
    run does: at clock 5 the p(a, 1) ending at 3 may still come (exactly 2 s late)."""
    engine = Engine.from_source("max_delay(p/2, 2).\nc_mem(m, p(_, _)-[], inf, inf).\n", "sync_query_bound.rtl")
    future = engine.query_synchronized("prev(m, p(a, V)^T, 3)", at=3)
    for text, t in [("trig(a)", 3), ("z", 5)]:
        engine.feed(text, t)
    assert not future.done()
    engine.feed("p(a, 1)", 3)
    engine.feed("z", 9)
    assert future.result(timeout=0) == [{"V": "1", "T": "3"}]
