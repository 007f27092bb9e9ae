"""Control lines (`add_rule`, `delete_rule`) in an event stream are refused unless the run
allows them: event files are data."""
import pytest

from retalisc.driver.engine import Engine

from stream_paths import PATHS, jsonl, run_path

PROGRAM = "r1 : seen(X) <- a(X).\n"

# A control line that would create a file if it were obeyed, one that would disable the
# program's own rule, and one that would add a harmless rule.
EVENTS = jsonl(
    ("a(1)", 1),
    {"op": "add_rule", "rule": "null do (open('MARKER', write, S), close(S)) <- trig."},
    {"op": "delete_rule", "rule": "r1"},
    {"op": "add_rule", "rule": "late : pair(X) <- a(X) seq b(X)."},
    ("trig", 2),
    ("a(2)", 3),
    ("b(2)", 4),
)


@pytest.mark.parametrize("path", PATHS)
def test_control_lines_are_refused_by_default(path, tmp_path, capfd):
    result = run_path(path, tmp_path, PROGRAM, EVENTS, capfd=capfd)
    assert result.returncode == 0, result.stderr
    assert not (tmp_path / "MARKER").exists()
    assert result.events == ["seen(1)", "seen(2)"]            # r1 still runs, `late` was never added
    for line in (2, 3, 4):
        assert f"{result.location(line)} error: control lines are disabled (pass --allow-control)" in result.stderr
    assert "3 rejected" in result.stderr


@pytest.mark.parametrize("path", PATHS)
def test_allow_control_obeys_them(path, tmp_path, capfd):
    events = jsonl(("a(1)", 1), {"op": "add_rule", "rule": "late : pair(X) <- a(X) seq b(X)."},
                   ("a(2)", 3), ("b(2)", 4), {"op": "delete_rule", "rule": "r1"}, ("a(3)", 5))
    result = run_path(path, tmp_path, PROGRAM, events, "--allow-control", capfd=capfd)
    assert result.returncode == 0, result.stderr
    assert result.events == ["seen(1)", "seen(2)", "pair(2)"]
    assert "control lines are disabled" not in result.stderr


def test_engine_feed_lines_refuses_control_lines_unless_allowed():
    engine = Engine.from_source(PROGRAM, "control.rtl")
    text = jsonl({"op": "delete_rule", "rule": "r1"}, ("a(1)", 1)).rstrip("\n")
    produced, rejected = engine.feed_lines(text)
    assert [e.event for e in produced] == ["seen(1)"]
    assert [(r.line, r.kind, r.reason) for r in rejected] == [
        (1, "error", "control lines are disabled (pass --allow-control)")]
    produced, rejected = engine.feed_lines(text.replace('"t": 1', '"t": 2'), allow_control=True)
    assert produced == [] and rejected == []                  # r1 is gone now
