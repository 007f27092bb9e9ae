"""Snapshot mechanics, below the Engine and the run loops (docs/recovery.md): the identity a
snapshot is tagged with and the atomic replacement of a file.

A snapshot file is written by the runtime (prolog_runtime/rtl_state.pl, fast_write terms)
to a temporary file next to its place, flushed to disk (fsync) and renamed over it, so a
reader sees the old file or the new one, never half of one. It is tagged with the
*identity* of the program and runtime: a hash of the compiled program (its module name left
out) and of every runtime source file; the runtime refuses a snapshot with another identity.
"""
from __future__ import annotations

import hashlib
import os
from functools import lru_cache
from pathlib import Path
from typing import Union

from ..runtime_location import runtime_dir

STATE_FORMAT = "retalisc-state-1"     # of the manifest; the state file's is rtl_state.pl's state_version/1


class StateError(Exception):
    """A snapshot or state directory that cannot be used (corrupt, from another program or
    version, unwritable)."""


@lru_cache(maxsize=None)
def runtime_version() -> str:
    """A hash of the runtime's Prolog sources: a snapshot is only read by the runtime that wrote it."""
    digest = hashlib.sha256(STATE_FORMAT.encode())
    for path in sorted(Path(runtime_dir()).glob("*.pl")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def program_identity(prolog_text: str, module: str) -> str:
    """The identity of a compiled program under this runtime: the same program compiled under
    another module name has the same identity."""
    digest = hashlib.sha256(runtime_version().encode())
    digest.update((prolog_text.replace(module, "\0M\0") if module else prolog_text).encode("utf-8"))
    return digest.hexdigest()[:32]


def fsync_directory(directory: Union[str, Path]) -> None:
    """Make a rename in `directory` durable (where the platform allows it)."""
    try:
        fd = os.open(str(directory), os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def fsync_file(path: Union[str, Path]) -> None:
    fd = os.open(str(path), os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def replace_atomically(path: Union[str, Path], write) -> None:
    """Make `path` what `write(temporary)` writes, or leave it as it was: the temporary file
    is flushed to disk, renamed over `path`, and the rename flushed (the directory); on any
    error the temporary file is removed."""
    path = Path(path)
    temporary = path.with_name(path.name + ".tmp")
    try:
        write(temporary)
        fsync_file(temporary)
        os.replace(temporary, path)
    except BaseException:
        try:
            temporary.unlink()
        except OSError:
            pass
        raise
    fsync_directory(path.parent)
