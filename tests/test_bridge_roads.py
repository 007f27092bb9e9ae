"""The two roads of a bridge call answer alike: on the calling-thread road (Bridge.run_in_calling_thread)
the C library calls the API predicate itself, resolved once, and reads numbers without text; on the
handoff road bridge_apply/6 builds the goal in the bridge's thread. The handoff road is the oracle:
the same script runs in a process on each road and prints the same lines (answers, failures, errors
with their messages and terms, typed tf lookups)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

SCRIPT = r"""
import sys
from retalisc.driver.bridge import Bridge, GoalFailed, PrologError
from retalisc.driver.engine import Engine, TfLookupError

bridge = Bridge()
if sys.argv[1] == "calling":
    assert bridge.run_in_calling_thread()
bridge.consult(sys.argv[2])

def show(label, call):
    try:
        print(label, "->", repr(call()))
    except GoalFailed as failed:
        print(label, "failed", failed)
    except PrologError as error:
        print(label, "error", error.message, "|", error.term)
    except (TypeError, ValueError) as error:
        print(label, type(error).__name__, error)

for name, args in [("answer_string", ()), ("answer_atom", ()), ("answer_int", ()), ("answer_float", ()),
                   ("answer_codes", ()), ("answer_term", ()), ("answer_unbound", ()), ("answer_fails", ()),
                   ("answer_raises", ()), ("answer_type_error", ()), ("no_such_predicate", ()),
                   ("echo", ("text é",)), ("echo", (-3,)), ("echo", (2.5,)), ("echo", ([1, ["a", 2.0]],)),
                   ("echo", (b"\xff\x00",)), ("echo", (2**64,)), ("echo", (None,)), ("echo", ()),
                   ("answer_numbers", ())]:
    show(f"{name}{args!r}", lambda: bridge.apply("user", name, *args))
for _ in range(3):      # the handle resolved once serves every later call
    show("echo again", lambda: bridge.apply("user", "echo", "again"))
show("numbers", lambda: bridge.apply_numbers("user", "answer_numbers", 2, 1) or "text road")
show("numbers (text answer)", lambda: bridge.apply_numbers("user", "answer_string", 2, 1) or "text road")
show("numbers (raises)", lambda: bridge.apply_numbers("user", "answer_raises", 2, 1) or "text road")

def message(parent, child, secs, x, qz, qw):
    return ("tf2_msgs__0__TFMessage([geometry_msgs__0__TransformStamped("
            f"std_msgs__0__Header([{secs},0],'{parent}'),'{child}',"
            f"geometry_msgs__0__Transform(geometry_msgs__0__Vector3({x!r},0.5,0.0),"
            f"geometry_msgs__0__Quaternion(0.0,0.0,{qz!r},{qw!r})))])")

with Engine.from_source("unused(X) <- tf_api_input(X).\n", "tf_api.rtl") as engine:
    for secs in (1, 2, 3):
        engine.feed(message("odom", "base", secs, float(secs), 0.0, 1.0), secs)
        engine.feed(message("base", "camera", secs, 0.1, 0.3826834323650898, 0.9238795325119648), secs)
    for target, source, time in [("odom", "camera", "latest"), ("odom", "camera", 2.25), ("camera", "odom", (1, 7)),
                                 ("odom", "base", ("ns", 2_500_000_001)), ("odom", "nowhere", "latest"),
                                 ("odom", "base", 10)]:
        try:
            print("tf", target, source, time, "->", engine.tf_lookup(target, source, time))
        except TfLookupError as error:
            print("tf", target, source, time, "fails", error.kind, error.reason)
    print("feed", [str(e.event) for e in engine.feed("tf_api_input(1)", 4)])
    print("query", engine.query("X = 1"))
"""

HELPERS = """\
answer_string("a string").
answer_atom('an atom').
answer_int(42).
answer_float(0.1).
answer_codes(`codes`).
answer_term(f(x, "s", 1.5)).
answer_unbound(_).
answer_fails(_) :- fail.
answer_raises(_) :- throw(my_ball(1)).
answer_type_error(X) :- atom_length(f(x), X).
answer_numbers(tf(1.5, 2, 7)).
echo(X, X).
"""


def test_both_roads_answer_alike(tmp_path):
    helpers = tmp_path / "helpers.pl"
    helpers.write_text(HELPERS)
    env = dict(os.environ, PYTHONPATH=str(ROOT), RETALISC_BRIDGE_BACKEND="pyswip")
    lines = {}
    for road in ("handoff", "calling"):
        proc = subprocess.run([sys.executable, "-c", SCRIPT, road, str(helpers)], capture_output=True, text=True,
                              timeout=180, env=env, cwd=ROOT)
        assert proc.returncode == 0, proc.stderr
        lines[road] = [re.sub(r"\b_\d+", "_", line) for line in proc.stdout.splitlines()]   # variable names
    handoff, calling = lines["handoff"], lines["calling"]
    # only the typed call differs: numbers on the calling-thread road, the text road's None on the other
    assert [line for line in handoff if not line.startswith("numbers")] == \
           [line for line in calling if not line.startswith("numbers")]
    assert "numbers -> ([1.5, 2.0], [7])" in calling
    assert "numbers (text answer) -> 'a string'" in calling
    assert "numbers -> 'text road'" in handoff
    assert any(line.startswith("numbers (raises) error") and "my_ball(1)" in line for line in calling)
    assert "answer_float() -> '0.1'" in calling
    assert "answer_term() -> 'f(x,s,1.5)'" in calling
    assert "echo('text é',) -> 'text é'" in calling
    assert any(line.startswith("answer_raises() error") and line.endswith("| my_ball(1)") for line in calling)
    assert any(line.startswith("no_such_predicate() error") and "no_such_predicate" in line for line in calling)
    assert any(line.startswith("tf odom camera latest -> TfTransform(") for line in calling)
    assert "tf odom nowhere latest fails unknown_frame unknown_frame(nowhere)" in calling
