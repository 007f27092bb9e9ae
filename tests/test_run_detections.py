"""Detections per rule: `Engine.detections()` and the line `retalis: detections per rule: ...`
that `retalisc run` writes before its summary line (which stays the last line, unchanged)."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retalisc.cli import main
from retalisc.driver.engine import Engine
from retalisc.driver.run import detections_line

PROGRAM = """\
alarm(X) <- (smoke(X) seq heat(X)).10.
hot(X) <- heat(X) where X > 50.
null do true <- tick.
never_fires(X) <- nothing(X).
"""


def test_detections_per_rule_in_program_order_with_zeros():
    with Engine.from_source(PROGRAM, "house.rtl") as engine:
        engine.set_flag("max_delay", "inf")
        assert engine.detections() == {"r1": 0, "r2": 0, "r3": 0, "r4": 0}
        engine.feed_batch([("smoke(60)", 1), ("heat(60)", 2), ("heat(40)", 3), ("smoke(7)", 4), ("heat(7)", 30),
                           ("tick", 31), ("tick", 32)])
        counts = engine.detections()
        assert list(counts) == ["r1", "r2", "r3", "r4"]
        # r1: smoke(60)-heat(60) in the window, smoke(7)-heat(7) 26 s apart is not; r2: heat(60);
        # r3 derives nothing (a null head) but its matches are detections
        assert counts == {"r1": 1, "r2": 1, "r3": 2, "r4": 0}
        assert engine.stats()["derived"] == 2
        engine.clear()
        assert engine.detections() == {"r1": 0, "r2": 0, "r3": 0, "r4": 0}


def test_labels_and_rules_added_at_runtime():
    with Engine.from_source("door_alarm: alarm(D) <- open(D) where D \\= back.\n", "doors.rtl") as engine:
        [added] = engine.add_rules("late_alarm: late(D) <- open(D).\n")
        assert added == "late_alarm"
        engine.feed_batch([("open(front)", 1), ("open(back)", 2)])
        assert engine.detections() == {"door_alarm": 1, "late_alarm": 2}
        assert detections_line(engine.detections()) == "retalis: detections per rule: door_alarm 1, late_alarm 2"


def test_detections_line_groups_digits_and_is_absent_without_rules():
    assert detections_line({"r1": 12345, "r2": 0}) == "retalis: detections per rule: r1 12,345, r2 0"
    assert detections_line({}) is None


@pytest.fixture(scope="module")
def threshold_engine():
    engine = Engine.from_source("high(X) <- reading(X) where X > 10.\nlow(X) <- reading(X) where X =< 10.\n",
                                "threshold.rtl")
    engine.set_flag("max_delay", "inf")
    return engine


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.integers(-100, 100), max_size=30))
def test_detections_count_the_matches_that_pass_the_conditions(threshold_engine, values):
    threshold_engine.clear()
    threshold_engine.feed_batch([(f"reading({v})", t) for t, v in enumerate(values, start=1)])
    assert threshold_engine.detections() == {"r1": sum(v > 10 for v in values), "r2": sum(v <= 10 for v in values)}


def test_run_writes_the_detections_before_the_unchanged_summary(tmp_path):
    (tmp_path / "house.rtl").write_text(PROGRAM)
    (tmp_path / "events.jsonl").write_text("\n".join(json.dumps(line) for line in [
        {"event": "smoke(60)", "t": 1}, {"event": "heat(60)", "t": 2}, {"event": "tick", "t": 3}]) + "\n")
    result = CliRunner().invoke(main, ["run", str(tmp_path / "house.rtl"), "--events", str(tmp_path / "events.jsonl")])
    assert result.exit_code == 0, result.output
    *_, detections, summary = result.stderr.splitlines()
    assert detections == "retalis: detections per rule: r1 1, r2 1, r3 1, r4 0"
    assert summary.startswith("retalis: 3 events in, 2 derived, 0 rejected, ") and summary.endswith(" s")
