"""retalisc installs like a package: the wheel holds every module and the
Prolog runtime, and installed into a new virtualenv it works from a directory that has nothing to
do with the repository: `python -m retalisc run`, `retalisc compile` + `swipl OUT.pl EVENTS`, and
`ins_event_rule/1` in that standalone program.

The wheel is built from a copy of the sources (the repository's own `build/` is never used), with
the interpreter running the tests (without build isolation when it can build wheels, otherwise
pip fetches setuptools). The new virtualenv gets no pip and no network: its dependencies are
links to the distributions the test interpreter already has, and the test interpreter's pip
installs the wheel into it with `--python`. Takes a few seconds.
"""
from __future__ import annotations

import importlib.metadata
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FIRE = ROOT / "examples" / "fire_alarm"

# Top-level entries of the repository that a wheel build needs no part of.
_NOT_SOURCES = {".git", ".venv", ".ci", "build", "dist", "tests", "benchmarks", "docs", "examples",
                ".pytest_cache", ".hypothesis", "tmp"}


def _run(cmd, **kwargs) -> subprocess.CompletedProcess:
    kwargs.setdefault("timeout", 300)
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kwargs)


def _check(result: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    assert result.returncode == 0, f"{result.args}\nstdout:\n{result.stdout}\nstderr:\n{result.stderr}"
    return result


def _version(name: str):
    try:
        return tuple(int(n) for n in re.findall(r"\d+", importlib.metadata.version(name))[:2])
    except importlib.metadata.PackageNotFoundError:
        return None


def _can_build_wheels_here() -> bool:
    """setuptools (>= 61, pyproject.toml) with `wheel`, or >= 70.1, which builds wheels itself."""
    setuptools = _version("setuptools")
    return setuptools is not None and setuptools >= (61, 0) and (
        _version("wheel") is not None or setuptools >= (70, 1))


def _build_wheel(tmp: Path) -> Path:
    source = tmp / "src"
    shutil.copytree(ROOT, source, ignore=lambda d, names: [
        n for n in names
        if n in ("__pycache__",) or n.endswith(".egg-info")
        or (Path(d) == ROOT and n in _NOT_SOURCES)])
    out = tmp / "wheel"
    cmd = [sys.executable, "-m", "pip", "wheel", source, "--no-deps", "--disable-pip-version-check",
           "-q", "-w", out]
    if _can_build_wheels_here():
        cmd.append("--no-build-isolation")
    _check(_run(cmd, cwd=tmp))
    (wheel,) = out.glob("retalisc-*.whl")
    return wheel


def _requirement_names(requires) -> list:
    """Names of the requirements that are not extras (markers are not evaluated: a dependency
    this interpreter does not have is left to pip to report)."""
    names = []
    for line in requires or []:
        if re.search(r"""extra\s*==""", line):
            continue
        match = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", line)
        if match:
            names.append(match.group(1))
    return names


def _link_dependencies(wheel: Path, site_packages: Path) -> None:
    """Make the wheel's dependencies (and theirs) installed in the new environment, as links to
    the distributions of the test interpreter."""
    with zipfile.ZipFile(wheel) as archive:
        metadata = next(n for n in archive.namelist() if n.endswith(".dist-info/METADATA"))
        text = archive.read(metadata).decode()
    todo = _requirement_names(re.findall(r"^Requires-Dist: (.*)$", text, re.M))
    seen = set()
    while todo:
        name = todo.pop()
        key = re.sub(r"[-_.]+", "-", name).lower()
        if key in seen:
            continue
        seen.add(key)
        try:
            dist = importlib.metadata.distribution(name)
        except importlib.metadata.PackageNotFoundError:
            continue
        for top in {Path(str(f)).parts[0] for f in dist.files or []}:
            if top in ("..", "__pycache__") or (site_packages / top).exists():
                continue
            (site_packages / top).symlink_to(Path(dist.locate_file(top)).resolve())
        todo.extend(_requirement_names(dist.requires))


def _clean_env(venv: Path) -> dict:
    """An environment in which nothing points at the repository or the test interpreter."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "RETALIS_RUNTIME", "RETALISC_PYTHON", "VIRTUAL_ENV")}
    path = [p for p in env.get("PATH", "").split(os.pathsep)
            if p and not Path(p).resolve().is_relative_to(ROOT)
            and Path(p).resolve() != Path(sys.executable).parent.resolve()]
    env["PATH"] = os.pathsep.join([str(venv / "bin")] + path)
    return env


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("packaging")
    venv = tmp / "venv"
    made = _run([sys.executable, "-m", "venv", "--without-pip", venv])
    if made.returncode != 0:
        pytest.skip(f"cannot create a virtualenv here: {made.stderr.strip()}")
    wheel = _build_wheel(tmp)
    site_packages = Path(_check(_run([venv / "bin" / "python", "-c",
                                      "import sysconfig; print(sysconfig.get_paths()['purelib'])"])
                                ).stdout.strip())
    _link_dependencies(wheel, site_packages)
    _check(_run([sys.executable, "-m", "pip", "--python", venv / "bin" / "python", "install",
                 "--no-index", "--disable-pip-version-check", "-q", wheel]))
    work = tmp / "work"
    work.mkdir()
    for name in ("fire_alarm.rtl", "events.jsonl"):
        shutil.copy(FIRE / name, work / name)
    return {"venv": venv, "wheel": wheel, "work": work, "site": site_packages,
            "env": _clean_env(venv)}


@pytest.fixture(scope="module")
def in_repo_run():
    """`retalisc run` on the fire alarm from the source tree."""
    return _check(_run([sys.executable, "-m", "retalisc", "run", FIRE / "fire_alarm.rtl", "--events",
                        FIRE / "events.jsonl"], cwd=ROOT))


def test_wheel_holds_every_module_and_the_runtime_but_not_its_tests(installed):
    with zipfile.ZipFile(installed["wheel"]) as archive:
        names = set(archive.namelist())
    sources = {str(p.relative_to(ROOT)) for p in (ROOT / "retalisc").rglob("*")
               if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}
    runtime = {f"retalisc/prolog_runtime/{p.name}" for p in (ROOT / "prolog_runtime").glob("*.pl")}
    assert sources - names == set()
    assert runtime - names == set()
    assert "retalisc/prolog_runtime/retalis.pl" in runtime
    assert not [n for n in names if n.startswith("retalisc/prolog_runtime/tests")]


def test_installed_package_does_not_use_the_repository(installed):
    where = _check(_run([installed["venv"] / "bin" / "python", "-c",
                         "import retalisc, retalisc.runtime_location as r; "
                         "print(retalisc.__file__); print(r.runtime_dir())"],
                        cwd=installed["work"], env=installed["env"])).stdout.splitlines()
    package = Path(where[0]).parent
    assert package == installed["site"] / "retalisc"
    assert Path(where[1]) == package / "prolog_runtime"
    assert (package / "prolog_runtime" / "retalis.pl").is_file()
    printed = _check(_run([installed["venv"] / "bin" / "python", "-m", "retalisc.runtime_location"],
                          cwd=installed["work"], env=installed["env"]))
    assert printed.stdout == f"{package / 'prolog_runtime'}\n"


def test_python_m_retalisc_run_from_elsewhere_matches_the_in_repo_run(installed, in_repo_run):
    run = _check(_run([installed["venv"] / "bin" / "python", "-m", "retalisc", "run", "fire_alarm.rtl",
                       "--events", "events.jsonl"], cwd=installed["work"], env=installed["env"]))
    assert run.stdout == in_repo_run.stdout
    assert run.stdout.splitlines() == (FIRE / "expected.jsonl").read_text().splitlines()
    usage = _check(_run([installed["venv"] / "bin" / "python", "-m", "retalisc", "--help"],
                        cwd=installed["work"], env=installed["env"]))
    assert "python -m retalisc" in usage.stdout and "compile" in usage.stdout


def test_compile_then_standalone_swipl_from_elsewhere(installed, in_repo_run, swipl):
    work, env = installed["work"], installed["env"]
    _check(_run(["retalisc", "compile", "fire_alarm.rtl", "-o", "fire_alarm.pl"], cwd=work, env=env))
    text = (work / "fire_alarm.pl").read_text()
    assert str(ROOT) not in text
    assert f"'{installed['site'] / 'retalisc' / 'prolog_runtime'}'" in text
    run = _check(_run([swipl, "fire_alarm.pl", "events.jsonl"], cwd=work, env=env))
    assert run.stdout == in_repo_run.stdout
    # ins_event_rule/1 compiles the rule with the Python of the installation.
    rule = "rtl_prog_fire_alarm:ins_event_rule('late: smoky(X) <- smoke(X).')"
    run = _check(_run([swipl, "-g", rule, "fire_alarm.pl", "events.jsonl"], cwd=work, env=env))
    assert '{"event": "smoky(smoke_2)", "start": 10, "end": 10}' in run.stdout.splitlines()
    assert [ln for ln in run.stdout.splitlines() if "smoky" not in ln] == in_repo_run.stdout.splitlines()


def test_program_compiled_elsewhere_finds_the_installed_runtime(installed, in_repo_run, swipl):
    """The recorded runtime directory does not exist here: python3 (the new environment's, first
    on PATH) says where the installed runtime is."""
    work, env = installed["work"], installed["env"]
    compile_env = dict(env, RETALIS_RUNTIME="/nonexistent/build-machine/prolog_runtime")
    _check(_run(["retalisc", "compile", "fire_alarm.rtl", "-o", "moved.pl"], cwd=work, env=compile_env))
    assert "'/nonexistent/build-machine/prolog_runtime'" in (work / "moved.pl").read_text()
    run = _check(_run([swipl, "moved.pl", "events.jsonl"], cwd=work, env=env))
    assert run.stdout == in_repo_run.stdout
