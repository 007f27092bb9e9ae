"""The compile cache of `retalisc run` (retalisc/compile_cache.py): a program compiled once is
taken from the cache while nothing that decides its compilation changed; anything stale,
damaged or writable by others is compiled again; the cache can be turned off."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from retalisc import compile_cache
from retalisc.compile_cache import CompileCache, CompiledProgram, cached_compile
from retalisc.compiler import compile_file

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = "alarm(X) <- smoke(X) seq heat(X).\nfire(X) <- alarm(X) and smoke(X).\n"
# `a(X) seq b(X).10`: a window on the last operand only, a warning every compilation prints.
WARNED = "late(X) <- a(X) seq b(X).10.\n"
EVENTS = "".join(f'{{"event": "{e}", "t": {t}}}\n' for t, e in enumerate(["smoke(k)", "heat(k)", "a(1)", "b(1)"], 1))


class Compiler:
    """Compiles `path` as `retalisc run` would, counting the compilations."""

    def __init__(self, path: Path, module: str = "rtl_prog_test_1"):
        self.path, self.module, self.calls = path, module, 0

    def __call__(self):
        self.calls += 1
        return compile_file(str(self.path), module=self.module)

    def compiled(self, **options) -> CompiledProgram:
        return cached_compile(str(self.path), self.module, self, **options)


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    directory = tmp_path / "cache"
    monkeypatch.setenv("RETALISC_CACHE_DIR", str(directory))
    monkeypatch.delenv("RETALISC_NO_CACHE", raising=False)
    return directory


@pytest.fixture
def program(tmp_path):
    path = tmp_path / "fire.rtl"
    path.write_text(PROGRAM)
    return path


def entries(directory: Path):
    return sorted(directory.glob("*.json"))


def test_a_second_compilation_is_a_hit(cache_dir, program):
    compiler = Compiler(program)
    first = compiler.compiled()
    assert compiler.calls == 1 and len(entries(cache_dir)) == 1
    seen = []
    second = compiler.compiled(found=seen.append)
    assert compiler.calls == 1
    assert second == first == CompiledProgram.of(compile_file(str(program), module="rtl_prog_test_1"))
    assert seen == [second] and len(second.rules) == 2


def test_a_changed_program_module_or_compiler_is_stale(cache_dir, program, monkeypatch):
    compiler = Compiler(program)
    compiler.compiled()
    program.write_text(PROGRAM.replace("heat", "warm"))
    changed = compiler.compiled()
    assert compiler.calls == 2 and "warm" in changed.prolog
    compiler.module = "rtl_prog_test_2"                 # another module name: another program
    assert compiler.compiled().module == "rtl_prog_test_2" and compiler.calls == 3
    compiler.compiled()
    assert compiler.calls == 3
    monkeypatch.setattr(compile_cache, "compiler_fingerprint", lambda: "another compiler")
    compiler.compiled()
    assert compiler.calls == 4


def test_the_fingerprint_covers_the_compiler_and_the_runtime(monkeypatch, tmp_path):
    compile_cache.compiler_fingerprint.cache_clear()
    try:
        ours = compile_cache.compiler_fingerprint()
        runtime = tmp_path / "runtime"
        runtime.mkdir()
        for path in (ROOT / "prolog_runtime").glob("*.pl"):
            (runtime / path.name).write_bytes(path.read_bytes())
        monkeypatch.setenv("RETALIS_RUNTIME", str(runtime))
        compile_cache.compiler_fingerprint.cache_clear()
        elsewhere = compile_cache.compiler_fingerprint()
        (runtime / "rtl_io.pl").write_text((runtime / "rtl_io.pl").read_text() + "\n% changed\n")
        compile_cache.compiler_fingerprint.cache_clear()
        changed = compile_cache.compiler_fingerprint()
        assert len({ours, elsewhere, changed}) == 3
    finally:
        compile_cache.compiler_fingerprint.cache_clear()


@pytest.mark.parametrize("damage", ["truncated", "flipped", "other key", "not json", "empty", "wrong types"])
def test_a_damaged_entry_is_compiled_again_and_rewritten(cache_dir, program, damage):
    compiler = Compiler(program)
    good = compiler.compiled()
    [entry] = entries(cache_dir)
    data = entry.read_bytes()
    head, _, body = data.partition(b"\n")
    if damage == "truncated":
        data = data[:len(data) // 2]
    elif damage == "flipped":
        at = data.index(b"seq") if b"seq" in data else len(data) - 10
        data = data[:at] + bytes([data[at] ^ 1]) + data[at + 1:]
    elif damage == "other key":             # a valid entry of another program, under this name
        body = body.replace(entry.stem.encode(), b"0" * 64)
        data = _with_checksum(body)
    elif damage == "not json":
        data = _with_checksum(b"{not json")
    elif damage == "empty":
        data = b""
    else:
        data = _with_checksum(body.replace(b'"rules": [', b'"rules": [1, '))
    entry.write_bytes(data)
    assert compiler.compiled() == good and compiler.calls == 2
    assert CompileCache(cache_dir).load(entry.stem) == good          # rewritten whole


def _with_checksum(body: bytes) -> bytes:
    import hashlib
    return f"{compile_cache.MAGIC} {compile_cache.FORMAT} {hashlib.sha256(body).hexdigest()}\n".encode() + body


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="file owners")
def test_entries_others_may_write_are_not_used(cache_dir, program, tmp_path):
    compiler = Compiler(program)
    compiler.compiled()
    [entry] = entries(cache_dir)
    assert cache_dir.stat().st_mode & 0o777 == 0o700 and entry.stat().st_mode & 0o777 == 0o600
    entry.chmod(0o666)
    compiler.compiled()
    assert compiler.calls == 2
    assert entry.stat().st_mode & 0o777 == 0o600                     # replaced by a private one
    elsewhere = tmp_path / "elsewhere.json"
    elsewhere.write_bytes(entry.read_bytes())
    entry.unlink()
    entry.symlink_to(elsewhere)                                      # a link is not an entry
    compiler.compiled()
    assert compiler.calls == 3
    cache_dir.chmod(0o777)                                           # a directory others may write
    compiler.compiled()
    compiler.compiled()
    assert compiler.calls == 5


def test_the_cache_can_be_turned_off(cache_dir, program, monkeypatch):
    compiler = Compiler(program)
    compiler.compiled(use_cache=False)
    compiler.compiled(use_cache=False)
    assert compiler.calls == 2 and not cache_dir.exists()
    monkeypatch.setenv("RETALISC_NO_CACHE", "1")
    compiler.compiled()
    assert compiler.calls == 3 and not cache_dir.exists()
    monkeypatch.setenv("RETALISC_NO_CACHE", "0")
    compiler.compiled()
    compiler.compiled()
    assert compiler.calls == 4 and len(entries(cache_dir)) == 1


def test_no_usable_directory_compiles_as_without_cache(tmp_path, program, monkeypatch):
    blocker = tmp_path / "a file"
    blocker.write_text("")
    monkeypatch.setenv("RETALISC_CACHE_DIR", str(blocker / "cache"))
    compiler = Compiler(program)
    assert compiler.compiled() == compiler.compiled()
    assert compiler.calls == 2


def test_a_program_changed_while_compiling_is_not_stored(cache_dir, program):
    compiler = Compiler(program)

    def compile_and_change():
        result = compiler()
        program.write_text(PROGRAM + "% edited\n")
        return result
    cached_compile(str(program), compiler.module, compile_and_change)
    assert entries(cache_dir) == []


def test_old_entries_are_pruned(cache_dir, tmp_path, monkeypatch):
    monkeypatch.setattr(compile_cache, "MAX_ENTRIES", 3)
    for n in range(5):
        path = tmp_path / f"p{n}.rtl"
        path.write_text(PROGRAM)
        Compiler(path, f"rtl_prog_p{n}_1").compiled()
        os.utime(entries(cache_dir)[0], None)
    assert len(entries(cache_dir)) == 3


def _run(tmp_path, program: Path, *options, env=None):
    events = tmp_path / "events.jsonl"
    events.write_text(EVENTS)
    return subprocess.run([sys.executable, "-X", "importtime", "-m", "retalisc", "run", str(program),
                           "--events", str(events), *options],
                          capture_output=True, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})})


def _messages(stderr: str):
    """Standard error without the import times and the run's duration."""
    lines = [line for line in stderr.splitlines() if not line.startswith("import time:")]
    return [line.rsplit(",", 1)[0] if line.startswith("retalis: ") else line for line in lines]


def _imported(stderr: str):
    return {line.split("|")[-1].strip() for line in stderr.splitlines() if line.startswith("import time:")}


def test_run_from_the_cache_says_the_same_without_the_compiler(cache_dir, tmp_path):
    program = tmp_path / "warned.rtl"
    program.write_text(PROGRAM + WARNED)
    first = _run(tmp_path, program)
    second = _run(tmp_path, program)
    assert first.returncode == second.returncode == 0, first.stderr
    assert "warning:" in first.stderr
    assert second.stdout == first.stdout and "fire(k)" in first.stdout and "late(1)" in first.stdout
    assert _messages(second.stderr) == _messages(first.stderr)
    assert {"lark", "jinja2", "retalisc.passes.pipeline"} <= _imported(first.stderr)
    assert not {"lark", "jinja2", "retalisc.passes.pipeline"} & _imported(second.stderr)
    uncached = _run(tmp_path, program, "--no-cache")
    assert uncached.stdout == first.stdout and _messages(uncached.stderr) == _messages(first.stderr)
    assert "lark" in _imported(uncached.stderr)


def test_included_files_are_checked(cache_dir, tmp_path):
    rules = tmp_path / "rules" / "more.event"
    rules.parent.mkdir()
    rules.write_text("warm(X) <- heat(X) seq heat(X).\n")
    program = tmp_path / "main.rtl"
    program.write_text(PROGRAM + ":- compile_event_file('rules/more.event').\n")
    compiler = Compiler(program)
    first = compiler.compiled()
    assert first.included == [[str(rules), compile_cache.text_hash(rules.read_text())]]
    assert compiler.compiled() == first and compiler.calls == 1
    rules.write_text("warm(X) <- heat(X) seq smoke(X).\n")           # same main file, other rules
    changed = compiler.compiled()
    assert compiler.calls == 2 and "smoke" in changed.prolog.split("warm", 1)[1]
    assert compiler.compiled() == changed and compiler.calls == 2
    rules.unlink()
    with pytest.raises(Exception, match="cannot read"):
        compiler.compiled()


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes")
def test_a_program_from_a_pipe_is_read_once_and_not_cached(cache_dir, tmp_path):
    import threading

    fifo = tmp_path / "program.rtl"
    os.mkfifo(fifo)
    writer = threading.Thread(target=lambda: fifo.write_text(PROGRAM))
    writer.start()
    compiler = Compiler(fifo)
    compiled = compiler.compiled()
    writer.join(timeout=10)
    assert compiler.calls == 1 and "smoke" in compiled.prolog
    assert not cache_dir.exists()
