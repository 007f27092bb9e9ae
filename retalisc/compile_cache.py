"""Compiled programs kept between runs, so that `retalisc run` compiles a program once.

Compiling a program takes the compiler itself to be imported (lark, jinja2, every pass),
which costs more than the compilation. `retalisc run` therefore keeps what a compilation
gives it (the Prolog text, the module name, the rule labels and the warnings) in a cache
directory, one file per entry, and uses it again when nothing that decides the result has
changed. The key of an entry is a SHA-256 hash of:

- the bytes of the program file and the name it was given (messages and the generated code
  name it), the module name and the name of the output file (the files the program
  includes, `compile_event_file(F)` and the like, are checked apart: an entry records the
  hash of the text read from each, and is used only while each file still reads the same);
- the compiler: every source file of `retalisc/frontend`, `passes` and `backends` (grammar and
  templates included), `compiler.py` and `runtime_location.py`;
- the runtime the program will load: its directory (recorded in the generated program) and
  its `.pl` files (the compiler reads their export lists);
- the Python version and the entry format.

Where: `$RETALISC_CACHE_DIR` if set, else `$XDG_CACHE_HOME/retalisc/compiled`, else
`~/.cache/retalisc/compiled`. Off: `RETALISC_NO_CACHE=1` (or `retalisc run --no-cache`).

Nothing is trusted that was not checked: the directory is made readable and writable by
its owner only, and an entry is used only when the directory and the file belong to the
user running `retalisc`, no one else may write them, the file's checksum matches its
content (a file cut short or damaged is not used), and the key written in it is the key
asked for. Anything else is a miss: the program is compiled and the entry written anew
(atomically: a temporary file renamed over the old one). When the cache cannot be used
(no home, a read-only disk), the program is compiled as if there were no cache; the cache
never changes what a run prints. The directory keeps at most `MAX_ENTRIES` entries (the
least recently written go first).
"""
from __future__ import annotations

import hashlib
import json
import os
import stat
import sys
import tempfile
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import List, Optional

from . import runtime_location

FORMAT = 1
MAGIC = "retalisc-compiled"
MAX_ENTRIES = 256
ENV_DIR = "RETALISC_CACHE_DIR"
ENV_OFF = "RETALISC_NO_CACHE"

_PACKAGE = Path(__file__).resolve().parent
_COMPILER_PARTS = ("frontend", "passes", "backends")
_COMPILER_FILES = ("compiler.py", "runtime_location.py")
_SOURCE_SUFFIXES = {".py", ".j2", ".lark"}


@dataclass
class CompiledProgram:
    """What `retalisc run` needs of a compilation: the Prolog text of the module `module`,
    the labels of its event rules in program order, the warnings to print, and the files
    its includes read, each with the hash of the text read (`text_hash`)."""

    prolog: str
    module: str
    rules: List[str]
    warnings: List[str]
    included: List[List[str]] = field(default_factory=list)
    #: The Prolog text as a file of the cache (`cached_compile(..., as_file=True)`), or None.
    file: Optional[Path] = field(default=None, compare=False)

    @classmethod
    def of(cls, result) -> "CompiledProgram":
        """From a `CompileResult` of an event program."""
        included = [[path, text_hash(text)] for path, text in getattr(result.unit.program, "included", [])]
        return cls(result.prolog, result.unit.module, [rule.rule_id for rule in result.unit.rules],
                   list(result.warnings), included)

    def includes_unchanged(self) -> bool:
        """Whether every included file still reads as it did (as the compiler reads it)."""
        for path, digest in self.included:
            try:
                if text_hash(Path(path).read_text(encoding="utf-8-sig")) != digest:
                    return False
            except (OSError, UnicodeDecodeError):
                return False
        return True


def text_hash(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()


def enabled() -> bool:
    """False when `$RETALISC_NO_CACHE` is set to anything but empty or `0`."""
    return os.environ.get(ENV_OFF, "") in ("", "0")


def cache_dir() -> Optional[Path]:
    """The cache directory (not created here), or None when there is no place for it."""
    explicit = os.environ.get(ENV_DIR)
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME")
    if base and os.path.isabs(base):
        return Path(base) / "retalisc" / "compiled"
    home = os.path.expanduser("~")
    if not home or home == "~" or not os.path.isabs(home):
        return None
    return Path(home) / ".cache" / "retalisc" / "compiled"


@lru_cache(maxsize=1)
def compiler_fingerprint() -> str:
    """A hash of everything but the program that decides what a compilation gives."""
    digest = hashlib.sha256()

    def add(label: str, data: bytes) -> None:
        digest.update(f"{label}\0{len(data)}\0".encode())
        digest.update(data)

    add("format", str(FORMAT).encode())
    add("python", sys.version.encode())
    files = [_PACKAGE / name for name in _COMPILER_FILES]
    for part in _COMPILER_PARTS:
        files += [p for p in (_PACKAGE / part).rglob("*") if p.suffix in _SOURCE_SUFFIXES and p.is_file()]
    for path in sorted(files):
        add(str(path.relative_to(_PACKAGE)), path.read_bytes())
    runtime = runtime_location.runtime_dir()
    add("runtime", str(runtime).encode())
    for path in sorted(runtime.glob("*.pl")):
        add(f"runtime/{path.name}", path.read_bytes())
    return digest.hexdigest()


def entry_key(source: bytes, file: str, module: str, output_name: str) -> str:
    """The key of the entry of program `source` (bytes of the file named `file`)."""
    header = json.dumps([FORMAT, compiler_fingerprint(), file, module, output_name])
    return hashlib.sha256(header.encode() + b"\0" + source).hexdigest()


class CompileCache:
    """The entries in `directory`."""

    def __init__(self, directory: Path):
        self.directory = Path(directory)

    def _path(self, key: str) -> Path:
        return self.directory / f"{key}.json"

    def load(self, key: str) -> Optional[CompiledProgram]:
        """The entry `key`, or None when there is none or it fails a check."""
        path = self._path(key)
        try:
            if not (_private(self.directory, directory=True) and _private(path)):
                return None
            with open(path, "rb") as stream:
                data = stream.read()
        except OSError:
            return None
        head, newline, body = data.partition(b"\n")
        if not newline or head != f"{MAGIC} {FORMAT} {hashlib.sha256(body).hexdigest()}".encode():
            return None
        try:
            entry = json.loads(body.decode("utf-8"))
        except (UnicodeDecodeError, ValueError):
            return None
        if not isinstance(entry, dict) or entry.get("key") != key:
            return None
        prolog, module, rules, warnings, included = (
            entry.get(k) for k in ("prolog", "module", "rules", "warnings", "included"))
        if not (isinstance(prolog, str) and isinstance(module, str) and _strings(rules) and _strings(warnings)
                and isinstance(included, list) and all(_strings(item) and len(item) == 2 for item in included)):
            return None
        program = CompiledProgram(prolog, module, rules, warnings, included)
        return program if program.includes_unchanged() else None

    def store(self, key: str, program: CompiledProgram) -> bool:
        """Write the entry `key` (replacing any); False when it could not be written."""
        body = json.dumps({"key": key, "prolog": program.prolog, "module": program.module,
                           "rules": program.rules, "warnings": program.warnings,
                           "included": program.included}).encode("utf-8")
        data = f"{MAGIC} {FORMAT} {hashlib.sha256(body).hexdigest()}\n".encode() + body
        try:
            self.directory.mkdir(mode=0o700, parents=True, exist_ok=True)
            if not _private(self.directory, directory=True):
                return False
            handle, temporary = tempfile.mkstemp(prefix=".entry-", dir=self.directory)
            try:
                with os.fdopen(handle, "wb") as stream:
                    stream.write(data)
                os.replace(temporary, self._path(key))
            except BaseException:
                os.unlink(temporary)
                raise
            self._prune()
        except OSError:
            return False
        return True

    def program_file(self, key: str, program: CompiledProgram) -> Optional[Path]:
        """The Prolog text of the entry `key` as a file next to it, `KEY.pl`, for `swipl` to
        load (retalisc/driver/swipl_handover.py): used when it is private (as an entry) and
        holds exactly that text, else written anew (atomically). None when it cannot be."""
        path = self.directory / f"{key}.pl"
        data = program.prolog.encode("utf-8")
        try:
            if _private(path):
                with open(path, "rb") as stream:
                    if stream.read() == data:
                        return path
        except OSError:
            pass
        try:
            if not _private(self.directory, directory=True):
                return None
            handle, temporary = tempfile.mkstemp(prefix=".program-", suffix=".pl", dir=self.directory)
            try:
                with os.fdopen(handle, "wb") as stream:
                    stream.write(data)
                os.replace(temporary, path)
            except BaseException:
                os.unlink(temporary)
                raise
        except OSError:
            return None
        return path

    def _prune(self) -> None:
        entries = []
        for path in self.directory.glob("*.json"):
            try:
                entries.append((path.stat().st_mtime, path))
            except OSError:
                continue
        if len(entries) > MAX_ENTRIES:
            for _, path in sorted(entries)[:len(entries) - MAX_ENTRIES]:
                for old in (path, path.with_suffix(".pl")):
                    try:
                        old.unlink()
                    except OSError:
                        pass


def _private(path: Path, directory: bool = False) -> bool:
    """Whether `path` belongs to this user and no one else may write it; a file must not be
    a symbolic link, a directory may be one (to a directory of this user)."""
    info = os.stat(path) if directory else os.lstat(path)
    if not (stat.S_ISDIR(info.st_mode) if directory else stat.S_ISREG(info.st_mode)):
        return False
    owner = getattr(os, "getuid", None)
    if owner is not None and info.st_uid != owner():
        return False
    return not info.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def _strings(value) -> bool:
    return isinstance(value, list) and all(isinstance(item, str) for item in value)


def cached_compile(program: str, module: str, compile, output_name: str = "PROGRAM.pl",
                   use_cache: bool = True, found=None, as_file: bool = False) -> CompiledProgram:
    """The compiled program of the file `program`: from the cache when it holds it (`found`
    is called with it first: the warnings are printed there), else `compile()` (a
    `CompileResult`), stored for the next time when the file did not change meanwhile. Only
    regular files are cached. With `as_file`, the entry's Prolog text is also kept as a file
    of the cache, named by the result's `file` (None when the entry is not in the cache)."""
    directory = cache_dir() if use_cache and enabled() else None
    source = key = None
    if directory is not None:
        try:
            if stat.S_ISREG(os.stat(program).st_mode):     # not a pipe (`<(...)`): read once only
                source = Path(program).read_bytes()
                key = entry_key(source, str(program), module, output_name)
        except OSError:
            key = None
    cache = CompileCache(directory) if key is not None else None
    if cache is not None:
        hit = cache.load(key)
        if hit is not None:
            if found is not None:
                found(hit)
            if as_file:
                hit.file = cache.program_file(key, hit)
            return hit
    compiled = CompiledProgram.of(compile())
    if cache is not None:
        try:
            unchanged = Path(program).read_bytes() == source
        except OSError:
            unchanged = False
        if unchanged and cache.store(key, compiled) and as_file:
            compiled.file = cache.program_file(key, compiled)
    return compiled
