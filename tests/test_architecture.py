"""The layers of `retalisc/` (docs/architecture.md, "Layers"): every import of a module, at its
top, inside a function or under `TYPE_CHECKING`, goes to a module of its own layer or a lower
one, and no modules import each other in a circle."""
from __future__ import annotations

import ast
from pathlib import Path
from typing import Dict, List, Set, Tuple

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "retalisc"

#: The layers, lowest first: the modules (or packages, with their submodules) of each. A module
#: belongs to the layer of the longest name here that is it or a package holding it.
LAYERS: List[Tuple[str, Tuple[str, ...]]] = [
    ("foundation", ("retalisc", "retalisc.runtime_location", "retalisc.frontend")),
    ("passes", ("retalisc.passes",)),
    ("backends", ("retalisc.backends",)),
    ("compiler", ("retalisc.compiler", "retalisc.compile_cache", "retalisc.runtime_rules", "retalisc.load_check")),
    ("engine", ("retalisc.driver", "retalisc.driver.bridge", "retalisc.driver.values",
                "retalisc.driver.event_lines", "retalisc.driver.snapshot", "retalisc.driver.outputs",
                "retalisc.driver.signals",
                "retalisc.driver.engine")),
    ("feed loop", ("retalisc.driver.feed",)),
    ("robot_io", ("retalisc.robot_io",)),
    ("run loops", ("retalisc.driver.run", "retalisc.driver.recovery", "retalisc.driver.explain",
                   "retalisc.driver.active_queries", "retalisc.driver.swipl_handover")),
    ("robapl", ("retalisc.robapl",)),
    ("live", ("retalisc.live",)),
    ("commands", ("retalisc.commands",)),
    ("entry points", ("retalisc.cli", "retalisc.__main__", "retalisc.live.roslaunch_node")),
]


def module_files() -> Dict[str, Path]:
    modules = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        modules[".".join(parts)] = path
    return modules


def imports(modules: Dict[str, Path]) -> Dict[str, Set[Tuple[str, int]]]:
    """Each module's imports of retalisc modules (name, line), wherever they stand in the file."""
    graph: Dict[str, Set[Tuple[str, int]]] = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        found = graph[name] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                    source = ".".join(base + ([node.module] if node.module else []))
                else:
                    source = node.module or ""
                targets = [f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules else source
                           for alias in node.names]
            else:
                continue
            for target in targets:
                while target not in modules and "." in target:
                    target = target.rpartition(".")[0]
                if target in modules and target != name:
                    found.add((target, node.lineno))
    return graph


def layer_of(module: str) -> int:
    best, layer = "", None
    for index, (_, names) in enumerate(LAYERS):
        for prefix in names:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > len(best):
                best, layer = prefix, index
    assert layer is not None, f"{module} is in no layer of LAYERS"
    return layer


def circles(graph: Dict[str, Set[str]]) -> List[List[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: Dict[str, int] = {}
    low: Dict[str, int] = {}
    stack: List[str] = []
    on_stack: Set[str] = set()
    found: List[List[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for successor in sorted(graph.get(node, ())):
            if successor not in index:
                visit(successor)
                low[node] = min(low[node], low[successor])
            elif successor in on_stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_every_module_has_a_layer():
    for module in module_files():
        layer_of(module)


def test_no_import_goes_up_a_layer():
    modules = module_files()
    upward = [f"{modules[name].relative_to(ROOT)}:{line}: {name} ({LAYERS[layer_of(name)][0]}) imports "
              f"{target} ({LAYERS[layer_of(target)][0]})"
              for name, targets in imports(modules).items() for target, line in sorted(targets)
              if layer_of(target) > layer_of(name)]
    assert upward == []


def test_no_import_circle():
    graph = {name: {target for target, _ in targets} for name, targets in imports(module_files()).items()}
    assert circles(graph) == []


def test_the_checks_see_function_level_and_type_checking_imports(tmp_path, monkeypatch):
    """The checks themselves: an import hidden in a function or under TYPE_CHECKING counts."""
    package = tmp_path / "retalisc"
    (package / "driver").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "driver" / "__init__.py").write_text("")
    (package / "driver" / "engine.py").write_text("def f():\n    from . import recovery\n")
    (package / "driver" / "recovery.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .engine import Engine\n")
    monkeypatch.setitem(globals(), "ROOT", tmp_path)
    monkeypatch.setitem(globals(), "PACKAGE", package)
    modules = module_files()
    graph = imports(modules)
    assert graph["retalisc.driver.engine"] == {("retalisc.driver.recovery", 2)}
    assert graph["retalisc.driver.recovery"] == {("retalisc.driver.engine", 3)}
    assert circles({name: {t for t, _ in targets} for name, targets in graph.items()}) == [
        ["retalisc.driver.engine", "retalisc.driver.recovery"]]
    assert layer_of("retalisc.driver.recovery") > layer_of("retalisc.driver.engine")


# ---- the pass lists of docs/architecture.md ------------------------------------------------

DOC = ROOT / "docs" / "architecture.md"
BEGIN = "<!-- pass lists: generated from retalisc/passes/pipeline.py by `python tests/test_architecture.py` -->"
END = "<!-- end of the pass lists -->"


def pass_lists_text() -> str:
    """The pass lists of `retalisc/passes/pipeline.py`, as docs/architecture.md shows them."""
    from retalisc.passes import pipeline

    def names(passes) -> str:
        return ", ".join(f"`{p.name}`" + (f" (`{p.mode}` only)" if getattr(p, "mode", None) else "")
                         for p in passes)

    return "\n".join([
        BEGIN,
        f"- `EVENT_PIPELINE` (event programs): {names(pipeline.EVENT_PIPELINE)}",
        f"- `ADDED_RULES_PIPELINE` (rules added to a running program): {names(pipeline.ADDED_RULES_PIPELINE)}",
        f"- `ACTIVE_QUERY_PIPELINE` (definite programs for active queries): {names(pipeline.ACTIVE_QUERY_PIPELINE)}",
        END,
    ])


def documented_pass_lists(text: str) -> str:
    start = text.index(BEGIN)
    return text[start:text.index(END, start) + len(END)]


def test_the_documented_pass_lists_are_the_pipelines():
    assert documented_pass_lists(DOC.read_text(encoding="utf-8")) == pass_lists_text(), (
        "docs/architecture.md: run `python tests/test_architecture.py` to write the pass lists again")


if __name__ == "__main__":          # write the pass lists of docs/architecture.md again
    import sys

    sys.path.insert(0, str(ROOT))
    old = DOC.read_text(encoding="utf-8")
    DOC.write_text(old.replace(documented_pass_lists(old), pass_lists_text()), encoding="utf-8")
