"""The Python/Prolog boundary has one side in Python: the API layer (docs/architecture.md, "The
Python/Prolog boundary"). Outside it no module of retalisc/ calls the bridge at all; inside it,
goal *text* is passed only as constant literals written there (never built from values: a
format string, a concatenation or a variable would be), and everything else goes to a fixed
predicate of an API module with values as data (`Bridge.apply`).

The check reads the source (ast), so it fails on the first new call of `bridge.once(...)` in
another file; it is checked against made-up sources too, so that it is known to see what it
must see."""
from __future__ import annotations

import ast
from pathlib import Path
from typing import List

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "retalisc"

# The API layer: the bridge itself, and the classes that call the API modules of the runtime
# (rtl_api.pl, rtl_aq_api.pl, rtl_trace.pl through Engine.trace, rtl_text.pl).
API_LAYER = {"driver/bridge.py", "driver/engine.py", "driver/values.py", "driver/active_queries.py"}
GOAL_TEXT = {"once", "all", "call_text"}           # the bridge's calls that take goal text
BRIDGE_CALLS = GOAL_TEXT | {"apply", "consult"}     # every call that runs something in Prolog


def _is_bridge(node: ast.AST) -> bool:
    """`bridge`, `x.bridge`, `self.bridge`, `Bridge()`, `Bridge.instance()`."""
    if isinstance(node, ast.Name):
        return node.id in ("bridge", "_bridge")
    if isinstance(node, ast.Attribute):
        return node.attr in ("bridge", "_bridge")
    if isinstance(node, ast.Call):
        func = node.func
        return (isinstance(func, ast.Name) and func.id == "Bridge") or (
            isinstance(func, ast.Attribute) and func.attr == "instance" and isinstance(func.value, ast.Name)
            and func.value.id == "Bridge")
    return False


def boundary_problems(source: str, name: str, in_api_layer: bool) -> List[str]:
    problems = []
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
            continue
        method = node.func.attr
        if method not in BRIDGE_CALLS or not _is_bridge(node.func.value):
            continue
        where = f"{name}:{node.lineno}"
        if not in_api_layer:
            problems.append(f"{where}: calls the bridge ({method}) outside the API layer")
        elif method in GOAL_TEXT and not all(isinstance(arg, ast.Constant) and isinstance(arg.value, str)
                                             for arg in node.args):
            problems.append(f"{where}: goal text that is not a constant literal ({method})")
    return problems


def test_no_goal_text_outside_the_api_layer():
    problems = []
    files = sorted(PACKAGE.rglob("*.py"))
    assert len(files) > 50
    for path in files:
        name = path.relative_to(PACKAGE).as_posix()
        problems += boundary_problems(path.read_text(encoding="utf-8"), name, name in API_LAYER)
    assert problems == []


def test_the_check_sees_what_it_must():
    outside = """
def f(engine, goal):
    engine.bridge.once("retalis:rtl_close_action_output")
    Bridge().apply("rtl_api", "rtl_api_clock")
    bridge.call_text(f"rtl_flag({goal}, V)", "V")
    engine.query(goal)                      # the Engine's API: fine
    other.once("x")                         # not a bridge
"""
    assert [p.split(": ", 1)[1] for p in boundary_problems(outside, "m.py", False)] == [
        "calls the bridge (once) outside the API layer",
        "calls the bridge (apply) outside the API layer",
        "calls the bridge (call_text) outside the API layer",
    ]
    inside = """
def g(self, goal, name):
    self.bridge.once("set_prolog_flag(retalis_embedded, true)")
    self.bridge.once("X = " + goal)
    self.bridge.call_text(f"rtl_flag({name}, V)", "V")
    self.bridge.apply("rtl_api", "rtl_api_query", goal, "inf", "first")
"""
    assert [p.split(": ", 1)[1] for p in boundary_problems(inside, "m.py", True)] == [
        "goal text that is not a constant literal (once)",
        "goal text that is not a constant literal (call_text)",
    ]


def test_the_state_journal_uses_the_live_nodes_public_interface():
    """live/state.py drives LiveNode through its public methods (its "recovery" section), never
    through the node's private ones."""
    source = (PACKAGE / "live" / "state.py").read_text(encoding="utf-8")
    private = sorted({f"node.{node.attr}" for node in ast.walk(ast.parse(source))
                      if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                      and node.value.id == "node" and node.attr.startswith("_")})
    assert private == []
