"""`retalisc explain` and the compiled program agree: for random programs over the operators
with a temporal relation (the binary operators, `or`, `not(N).[L, R]`, `fnot`, absence,
windows, `where`), sliding aggregates and timers over them, and random event streams, the
events explain's evaluation of the rules matches in the log (rtl_trace.pl,
rtl_trace_matches/3) are exactly the events the program detected, and explain accounts for
every detection by its rule. Both read the operators'
relations from prolog_runtime/rtl_relations.pl (the compiler through
retalisc/frontend/relations.py), and a sliding aggregate's changes from rtl_sliding.pl
(rtl_sliding_change/5): a relation written twice, or read differently, fails here."""
from __future__ import annotations

from collections import Counter
from itertools import count

from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from retalisc.compiler import compile_source
from retalisc.driver.explain import Explainer
from retalisc.frontend.errors import RetalisError

_PROGRAMS = count()     # (each program its own module in the one SWI-Prolog of the process)

BINARY = ["seq", "and", "par", "or", "equals", "meets", "during", "starts", "finishes"]

leaves = st.sampled_from(["a(X)", "b(X)", "c(X)"])


def _extend(inner):
    return st.one_of(
        st.tuples(st.sampled_from(BINARY), inner, inner).map(lambda t: f"({t[1]} {t[0]} {t[2]})"),
        st.tuples(inner, leaves).map(lambda t: f"({t[0]} fnot {t[1]})"),
        st.tuples(leaves, inner, inner).map(lambda t: f"not({t[0]}).[{t[1]}, {t[2]}]"),
        st.tuples(leaves, inner, st.sampled_from([1, 2, 3])).map(lambda t: f"not({t[0]}).[{t[1]}, {t[2]}]"),
        st.tuples(inner, st.sampled_from([1, 2, 3, 5])).map(lambda t: f"({t[0]}).{t[1]}"),
        inner.map(lambda p: f"({p} where X =:= 1)"),
    )


patterns = st.recursive(leaves, _extend, max_leaves=4)


@st.composite
def streams(draw):
    """Event lines in the order of their ends (none late): atomic events and intervals of
    a(K), b(K), c(K), then a tick far after them that lets every absence be decided."""
    lines, end = [], 0
    for _ in range(draw(st.integers(1, 12))):
        end += draw(st.sampled_from([0, 1, 1, 2, 4]))
        name, key = draw(st.sampled_from("abc")), draw(st.sampled_from([1, 2]))
        length = draw(st.sampled_from([0, 0, 1, 2]))
        if length:
            lines.append(f'{{"event": "{name}({key})", "start": {end - length}, "end": {end}}}')
        else:
            lines.append(f'{{"event": "{name}({key})", "t": {end}}}')
    lines.append(f'{{"event": "tick", "t": {end + 100}}}')
    return "\n".join(lines) + "\n"


def _detections(outputs) -> set:
    """The derived h events the program gave and did not take back."""
    net = Counter()
    for out in outputs:
        if out.event.startswith("h("):
            net[(out.event, float(out.start), float(out.end))] += -1 if out.op == "retract" else 1
    return {key for key, count in net.items() if count > 0}


def _agree(rule: str, events: str, tmp_path_factory, target: str = "h(_)") -> None:
    try:
        result = compile_source(rule + "\n", f"agree_{next(_PROGRAMS)}.rtl")
    except RetalisError:
        assume(False)
    path = tmp_path_factory.mktemp("agree") / "events.jsonl"
    path.write_text(events)
    explainer = Explainer(result)
    explainer.feed_file(str(path))
    assert explainer.rejections == []
    detected = _detections(explainer.outputs)
    explained = {(event, start, end) for event, start, end, _rule in explainer.matches(target)}
    assert explained == detected, (rule, events)
    if detected:
        text = explainer.explain(target, limit=len(detected) + 10)
        tops = [line for line in text.splitlines() if line.startswith("h(")]
        assert all("derived by rule r1" in line for line in tops), text


SETTINGS = settings(max_examples=120, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@SETTINGS
@given(pattern=patterns, events=streams())
# (an N long before L does not block `L fnot N` inside a window: docs/language.md)
@example(pattern="((a(X) fnot b(X))).2", events='{"event": "b(1)", "t": 0}\n{"event": "a(1)", "t": 5}\n'
                                             '{"event": "tick", "t": 105}\n')
def test_explain_matches_exactly_what_the_program_detects(pattern, events, tmp_path_factory):
    _agree(f"h(X) <- {pattern}.", events, tmp_path_factory)


@settings(SETTINGS, max_examples=60)
@given(function=st.sampled_from(["count", "sum(X)", "min(X)", "max(X)", "avg(X)"]), pattern=patterns,
       seconds=st.sampled_from([1, 2, 3, 5]), events=streams())
# (the value is output where it changes only, as the compiled rule outputs it)
@example(function="count", pattern="a(X)", seconds=5,
         events='{"event": "a(1)", "t": 0}\n{"event": "a(1)", "t": 5}\n{"event": "tick", "t": 105}\n')
def test_explain_matches_exactly_the_values_a_sliding_aggregate_gives(function, pattern, seconds, events,
                                                                       tmp_path_factory):
    _agree(f"h(X, V) <- sliding({function}, {pattern}, X, {seconds}, V).", events, tmp_path_factory, "h(_, _)")


@settings(SETTINGS, max_examples=40)
@given(pattern=patterns, delay=st.sampled_from([1, 2, 3]), events=streams())
def test_explain_matches_exactly_the_events_a_timer_raises(pattern, delay, events, tmp_path_factory):
    _agree(f"alarm(h(X), {delay}) <- {pattern}.", events, tmp_path_factory)
