"""An Engine works from any thread: every call runs in the bridge's one
Prolog thread, so the runtime's per-thread state (clock, output buffer, program) is the same
whoever calls. Concurrent feeding gives what one thread feeding the same events gives, and a
bad value leaves the engine usable."""
from __future__ import annotations

import math
import random
import threading
from typing import List

import pytest

from retalisc.driver.bridge import Bridge, PrologError
from retalisc.driver.engine import Engine, OutputEvent

PROGRAM = """
pair(X) <- a(X) seq b(X).
both(K) <- c(K) and d(K).
big(X) <- price(X) where X > 1.
echo(X) <- ping(X).
"""


@pytest.fixture
def engine():
    e = Engine.from_source(PROGRAM, "threads.rtl")
    e.set_flag("max_delay", "inf")          # arrival order does not matter without forgetting
    e.set_flag("echo_input", "false")
    return e


def derived(out: List[OutputEvent]):
    return sorted((o.event, o.start, o.end) for o in out)


def events(n: int):
    evs = []
    for i in range(n):
        evs.append((f"a({i})", 3.0 * i))
        evs.append((f"b({i})", 3.0 * i + 1 + (i % 3)))
        evs.append((f"c({i % 5})", 1.5 * i))
        evs.append((f"d({i % 5})", 1.5 * i + 0.25))
    return evs


def test_four_threads_feeding_give_what_one_thread_gives(engine):
    evs = events(60)
    engine.clear()
    alone = derived(engine.feed_batch(evs))
    assert len(alone) > 100

    engine.clear()
    seen: List[OutputEvent] = []
    engine.on_output(seen.append)
    returned: List[List[OutputEvent]] = [[] for _ in range(4)]
    errors: List[BaseException] = []

    def feeder(k: int) -> None:
        mine = evs[k::4]
        rnd = random.Random(k)
        try:
            i = 0
            while i < len(mine):
                size = rnd.randint(1, 5)
                returned[k].extend(engine.feed_batch(mine[i:i + size]))
                i += size
        except BaseException as e:      # reported by the assertion below
            errors.append(e)

    threads = [threading.Thread(target=feeder, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    together = derived([o for out in returned for o in out])
    assert together == alone
    assert derived(seen) == alone                   # callbacks saw each output once
    assert engine.stats()["events"] == len(evs)     # one clock and one set of counters


def test_an_engine_made_in_one_thread_is_used_from_others():
    made: List[Engine] = []
    maker = threading.Thread(target=lambda: made.append(Engine.from_source(PROGRAM, "made.rtl")))
    maker.start()
    maker.join()
    engine = made[0]
    engine.set_flag("max_delay", "inf")
    results = []

    def use(t: float) -> None:
        results.append(derived(engine.feed("ping(x)", t)))

    for t in (1.0, 2.0, 3.0):
        th = threading.Thread(target=use, args=(t,))      # a new thread each time
        th.start()
        th.join()
    results.append(derived(engine.feed("ping(x)", 4.0)))  # and the main thread
    assert results == [[("echo(x)", t, t)] for t in (1.0, 2.0, 3.0, 4.0)]
    assert engine.clock() == 4.0
    assert engine.query("rtl_clock(C)") == {"C": "4.0"}


def test_many_short_lived_threads():
    engine = Engine.from_source(PROGRAM, "churn.rtl")
    engine.set_flag("max_delay", "inf")
    out: List[OutputEvent] = []
    for i in range(30):
        th = threading.Thread(target=lambda i=i: out.extend(engine.feed(f"ping({i})", float(i))))
        th.start()
        th.join()
    assert [o.event for o in out] == [f"echo({i})" for i in range(30)]


def test_bad_values_leave_the_engine_usable(engine):
    bridge = engine.bridge
    engine.set_flag("max_delay", "2.5")
    for value in ("foo", "-1", "nan", "inf_and_more", "f(x)", "X"):
        with pytest.raises(PrologError):
            engine.set_flag("max_delay", value)
    assert engine.query("rtl_flag(max_delay, D)") == {"D": "2.5"}     # unchanged
    with pytest.raises(PrologError):
        engine.set_flag("no_such_flag", "1")
    with pytest.raises(ValueError):
        engine.feed("ping(a)", math.inf)
    with pytest.raises(PrologError, match="finite"):
        bridge.apply("rtl_api", "rtl_api_feed_events", [["add", "ping(a)", math.inf, math.inf]])
    assert engine.clock() == -math.inf                                  # no infinite clock
    assert derived(engine.feed("ping(a)", 1)) == [("echo(a)", 1, 1)]
    engine.set_flag("max_delay", "inf")


def test_an_event_that_raises_stops_its_batch_and_nothing_is_delivered_twice(engine):
    seen: List[OutputEvent] = []
    engine.on_output(seen.append)
    with pytest.raises(PrologError, match=r"event 1 of the batch \('price\(abc\)'\)"):
        engine.feed_batch([("price(5)", 1), ("price(abc)", 2), ("price(7)", 3)])
    assert [o.event for o in seen] == ["big(5)"]                        # delivered once, before the error
    assert derived(engine.feed("price(9)", 4)) == [("big(9)", 4, 4)]    # no big(5) again, no big(7)
    assert [o.event for o in seen] == ["big(5)", "big(9)"]


def test_errors_in_one_thread_do_not_disturb_the_others(engine):
    good: List[OutputEvent] = []
    failures = []

    def good_feeder() -> None:
        for i in range(40):
            good.extend(engine.feed(f"ping({i})", float(i)))

    def bad_feeder() -> None:
        for i in range(40):
            try:
                engine.feed("price(abc)", float(i))
            except PrologError:
                failures.append(i)
            try:
                engine.set_flag("max_delay", "oops")
            except PrologError:
                failures.append(i)

    threads = [threading.Thread(target=good_feeder), threading.Thread(target=bad_feeder)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(o.event for o in good) == sorted(f"echo({i})" for i in range(40))
    assert len(failures) == 80
    assert engine.query("rtl_flag(max_delay, D)") == {"D": "inf"}


def test_global_variables_are_the_same_from_every_thread():
    bridge = Bridge()
    bridge.once("nb_setval(threads_test_key, main_value)")
    seen: List[str] = []
    th = threading.Thread(target=lambda: seen.append(bridge.once("nb_getval(threads_test_key, V)", "V")))
    th.start()
    th.join()
    assert seen == ["main_value"]


def test_a_call_that_ends_the_prolog_thread_does_not_hang_the_bridge():
    bridge = Bridge()
    with pytest.raises(PrologError, match="thread ended"):
        bridge.once("abort")            # trusted text only: the sandbox refuses abort/0 from outside
    assert bridge.once("X is 6 * 7", "X") == "42"      # a new Prolog thread serves the next calls
