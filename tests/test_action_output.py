"""Standard output carries only JSON Lines: text that actions, conditions and
static rules print goes to standard error, or to the file named by `--action-output`."""
import pytest

from stream_paths import PATHS, jsonl, run_path

# ETALIS's do_01 example prints with write/1; a condition and a static rule print too.
PROGRAM = """
null do write(hello) <- a(_).
b(X) <- a(X) where (format("checking ~w~n", [X]), X > 0).
shout(X) :- print(shout(X)), nl.
c(X) <- a(X) where shout(X).
"""

EVENTS = jsonl(("a(1)", 1), ("a(2)", 2))


@pytest.mark.parametrize("path", PATHS)
def test_printed_text_goes_to_standard_error(path, tmp_path, capfd):
    result = run_path(path, tmp_path, PROGRAM, EVENTS, capfd=capfd)
    assert result.returncode == 0, result.stderr
    assert result.events == ["b(1)", "c(1)", "b(2)", "c(2)"]     # every stdout line is JSON
    assert result.stderr.count("hello") == 2
    assert "checking 1\n" in result.stderr and "shout(2)\n" in result.stderr


@pytest.mark.parametrize("path", PATHS)
def test_action_output_file(path, tmp_path, capfd):
    target = tmp_path / "actions.txt"
    result = run_path(path, tmp_path, PROGRAM, EVENTS, "--action-output", str(target), capfd=capfd)
    assert result.returncode == 0, result.stderr
    assert result.events == ["b(1)", "c(1)", "b(2)", "c(2)"]
    assert "hello" not in result.stderr and "checking" not in result.stderr
    assert target.read_text() == "hellochecking 1\nshout(1)\nhellochecking 2\nshout(2)\n"


@pytest.mark.parametrize("path", PATHS)
def test_unwritable_action_output_is_a_usage_error(path, tmp_path, capfd):
    target = tmp_path / "no" / "such" / "dir.txt"
    result = run_path(path, tmp_path, PROGRAM, EVENTS, "--action-output", str(target), capfd=capfd)
    assert result.returncode == 2
    assert result.stdout == "" and "Traceback" not in result.stderr
    assert "action output" in result.stderr
