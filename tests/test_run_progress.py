"""`retalisc run` progress display and its one-line closing summary."""
import io
import re

import pytest

from retalisc.driver.run import Progress

from stream_paths import PATHS, jsonl, run_path

SUMMARY = re.compile(r"^retalis: (\d+) events in, (\d+) derived, (\d+) rejected(, \d+ \w+)*, \d+\.\d\d s$")
PROGRAM = "b(X) <- a(X).\n"


class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


@pytest.mark.parametrize("path", PATHS)
def test_one_line_summary_on_both_paths(path, tmp_path, capfd):
    events = jsonl(("a(1)", 1), "oops", ("a(2)", 2), ("a(2)", 2, "retract"))
    result = run_path(path, tmp_path, PROGRAM, events, capfd=capfd)
    last = result.stderr.splitlines()[-1]
    match = SUMMARY.match(last)
    assert match and match.groups()[:3] == ("2", "2", "1"), last     # a retraction is not an event in
    assert ", 1 retracted, " in last


def test_progress_is_shown_on_a_terminal_for_big_inputs_only():
    small = FakeTerminal()
    progress = Progress(stream=small, total=1000, threshold=5000)
    progress.update(1000, 10, 2)
    progress.close()
    assert small.getvalue() == ""
    big = FakeTerminal()
    progress = Progress(stream=big, total=20_000, threshold=5000, interval=0)
    progress.update(10_000, 200, 7)
    progress.update(10_000, 200, 7)
    progress.close()
    text = big.getvalue()
    assert "100%" in text and "400 events" in text and "14 derived" in text and "events/s" in text
    assert text.endswith("\n")
    pipe = io.StringIO()                                    # not a terminal: nothing
    progress = Progress(stream=pipe, total=20_000, threshold=5000, interval=0)
    progress.update(20_000, 400, 14)
    progress.close()
    assert pipe.getvalue() == ""


def test_progress_from_a_pipe_starts_once_enough_was_read():
    terminal = FakeTerminal()
    progress = Progress(stream=terminal, total=None, threshold=5000, interval=0)
    progress.update(4000, 80, 1)
    assert terminal.getvalue() == ""
    progress.update(4000, 80, 1)
    progress.close()
    text = terminal.getvalue()
    assert "160 events" in text and "2 derived" in text and "%" not in text


def test_progress_option_forces_the_display(tmp_path, capfd):
    events = jsonl(*[(f"a({i})", i) for i in range(1, 50)])
    result = run_path("run", tmp_path, PROGRAM, events, "--progress", capfd=capfd)
    assert result.returncode == 0
    progress, detections, summary = result.stderr.splitlines()[-3:]
    assert "[####################] 100%" in progress and "49 events" in progress and "49 derived" in progress
    assert detections == "retalis: detections per rule: r1 49"
    assert SUMMARY.match(summary)
    assert len(result.lines) == 49
