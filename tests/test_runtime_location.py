"""Where a compiled program finds the Prolog runtime (retalisc/runtime_location.py and the
generated `runtime_location.pl.j2` block; docs/runtime.md, "Installing and finding the
runtime").

A generated file looks in this order: $RETALIS_RUNTIME, `prolog_runtime/` next to the file,
the directory recorded at compile time, the runtime of the package that $RETALISC_PYTHON (else
python3) imports. Each case below loads a program with copies of the runtime in several of those
places and asks SWI-Prolog which `retalis.pl` (or `rtl_aq.pl`) it loaded.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path


from retalisc import runtime_location
from retalisc.compiler import AqOptions, compile_source

ROOT = Path(__file__).resolve().parent.parent
RUNTIME = ROOT / "prolog_runtime"
FIRE = ROOT / "examples" / "fire_alarm"


def _copy_runtime(target: Path) -> Path:
    shutil.copytree(RUNTIME, target, ignore=shutil.ignore_patterns("tests"))
    return target


def _compile(monkeypatch, recorded: Path, text: str, file: str, **options) -> str:
    """Compile with `recorded` as the runtime directory written into the program."""
    monkeypatch.setenv("RETALIS_RUNTIME", str(recorded))
    prolog = compile_source(text, file, **options).prolog
    monkeypatch.delenv("RETALIS_RUNTIME")
    return prolog


def _env(**extra: str) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("RETALIS_RUNTIME", "RETALISC_PYTHON", "PYTHONPATH")}
    # No python3 on PATH imports retalisc unless a case asks for it.
    env["RETALISC_PYTHON"] = "/bin/false"
    env.update(extra)
    return env


def _loaded(swipl, program: Path, env: dict, module: str = "retalis") -> subprocess.CompletedProcess:
    goal = f"module_property({module}, file(F)), writeln(loaded(F)), halt"
    return subprocess.run([swipl, "-g", goal, "-t", "halt(3)", str(program)], cwd=program.parent,
                          env=env, capture_output=True, text=True, timeout=60)


def _loaded_from(result: subprocess.CompletedProcess) -> Path:
    assert result.returncode == 0, result.stderr
    line = [ln for ln in result.stdout.splitlines() if ln.startswith("loaded(")][-1]
    return Path(line[len("loaded("):-1]).parent


def test_bundled_runtime_of_a_checkout_and_the_override(monkeypatch, tmp_path):
    monkeypatch.delenv("RETALIS_RUNTIME", raising=False)
    assert runtime_location.bundled_runtime_dir() == RUNTIME
    assert runtime_location.runtime_dir() == RUNTIME
    monkeypatch.setenv("RETALIS_RUNTIME", str(tmp_path / "x" / ".." / "rt"))
    assert runtime_location.runtime_dir() == (tmp_path / "rt").resolve()
    assert runtime_location.bundled_runtime_dir() == RUNTIME


def test_module_prints_the_runtime_directory(tmp_path):
    env = _env(PYTHONPATH=str(ROOT))
    env.pop("RETALISC_PYTHON")
    cmd = [sys.executable, "-m", "retalisc.runtime_location"]
    out = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    assert (out.returncode, out.stdout, out.stderr) == (0, f"{RUNTIME}\n", "")
    env["RETALIS_RUNTIME"] = str(tmp_path)
    out = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 1 and out.stdout == ""
    assert f"no retalis.pl in {tmp_path}" in out.stderr


def test_search_order_env_then_sibling_then_recorded_then_python(monkeypatch, tmp_path, swipl):
    recorded = _copy_runtime(tmp_path / "recorded")
    from_env = _copy_runtime(tmp_path / "from_env")
    program_dir = tmp_path / "deploy"
    program_dir.mkdir()
    sibling = _copy_runtime(program_dir / "prolog_runtime")
    program = program_dir / "fire_alarm.pl"
    program.write_text(_compile(monkeypatch, recorded, (FIRE / "fire_alarm.rtl").read_text(),
                                "fire_alarm.rtl"))
    assert str(ROOT) not in program.read_text()

    assert _loaded_from(_loaded(swipl, program, _env(RETALIS_RUNTIME=str(from_env)))) == from_env
    # An override without the runtime in it is passed over.
    assert _loaded_from(_loaded(swipl, program, _env(RETALIS_RUNTIME=str(tmp_path)))) == sibling
    assert _loaded_from(_loaded(swipl, program, _env())) == sibling
    shutil.rmtree(sibling)
    assert _loaded_from(_loaded(swipl, program, _env())) == recorded
    shutil.rmtree(recorded)
    # Compiled elsewhere: the package that the Python imports says where its runtime is.
    asks_python = _env(RETALISC_PYTHON=sys.executable, PYTHONPATH=str(ROOT))
    assert _loaded_from(_loaded(swipl, program, asks_python)) == RUNTIME
    # The runtime found that way runs the program.
    run = subprocess.run([swipl, str(program), str(FIRE / "events.jsonl")], cwd=tmp_path,
                         env=asks_python, capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == (FIRE / "expected.jsonl").read_text().splitlines()


def test_no_runtime_anywhere_is_a_clear_error(monkeypatch, tmp_path, swipl):
    program = tmp_path / "fire_alarm.pl"
    program.write_text(_compile(monkeypatch, tmp_path / "gone", (FIRE / "fire_alarm.rtl").read_text(),
                                "fire_alarm.rtl"))
    run = subprocess.run([swipl, str(program), str(FIRE / "events.jsonl")], cwd=tmp_path,
                         env=_env(), capture_output=True, text=True, timeout=60)
    assert run.returncode != 0
    assert run.stdout == ""
    assert "cannot find the Retalis runtime (retalis.pl): set RETALIS_RUNTIME" in run.stderr


def test_active_query_programs_search_the_same_way(monkeypatch, tmp_path, swipl):
    source = "edge(1, 2).\nedge(2, 3).\npath(X, Y) :- edge(X, Y).\npath(X, Z) :- edge(X, Y), path(Y, Z).\n"
    program = tmp_path / "paths.pl"
    program.write_text(_compile(monkeypatch, tmp_path / "gone", source, "paths.pl",
                                active_queries=AqOptions(mode="tabled")))
    sibling = _copy_runtime(tmp_path / "prolog_runtime")
    assert _loaded_from(_loaded(swipl, program, _env(), module="rtl_aq")) == sibling
    shutil.rmtree(sibling)
    env = _env(RETALIS_RUNTIME=str(RUNTIME))
    goal = "aq_register(q1, path(1, X), As), writeln(As), halt"
    run = subprocess.run([swipl, "-g", goal, "-t", "halt(3)", str(program)], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=60)
    assert (run.returncode, run.stdout) == (0, "[path(1,2),path(1,3)]\n"), run.stderr
