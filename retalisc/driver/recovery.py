"""Snapshots of a running program's state on disk, and the state directory of a run that
survives a crash (docs/recovery.md).

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

STATE_FORMAT = "retalisc-state-1"


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


def file_sha256(path: Union[str, Path]) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
