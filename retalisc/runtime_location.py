"""Where the Prolog runtime is: the directory of `retalis.pl` and the other `rtl_*.pl` modules
that every compiled program loads.

The runtime is kept in the repository as `prolog_runtime/`, next to the package; a wheel (or
`pip install .`) ships it inside the package as `retalisc/prolog_runtime/`. The environment
variable `RETALIS_RUNTIME` overrides both.

The compiler records the directory found here in each generated program, which looks for the
runtime in this order when it is loaded (docs/runtime.md, "Installing and finding the
runtime"): `$RETALIS_RUNTIME`, a directory `prolog_runtime/` next to the generated file, the
recorded directory, and last the directory that `python -m retalisc.runtime_location` prints
(run with `$RETALISC_PYTHON`, else `python3`).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import List, Optional

ENV_VAR = "RETALIS_RUNTIME"
ENTRY_MODULE = "retalis.pl"


def bundled_runtime_dir() -> Path:
    """The runtime that comes with this copy of the package: `retalisc/prolog_runtime/` when
    installed from a wheel, `prolog_runtime/` next to the package in a source checkout (run
    from the tree or installed editable)."""
    package = Path(__file__).resolve().parent
    installed = package / "prolog_runtime"
    if (installed / ENTRY_MODULE).is_file():
        return installed
    return package.parent / "prolog_runtime"


def runtime_dir() -> Path:
    """The runtime compiled programs load: `$RETALIS_RUNTIME` when set, else the bundled one."""
    override = os.environ.get(ENV_VAR)
    if override:
        return Path(override).resolve()
    return bundled_runtime_dir()


def main(argv: Optional[List[str]] = None) -> int:
    """`python -m retalisc.runtime_location`: print the runtime directory (exit 1 when it has
    no `retalis.pl`)."""
    args = sys.argv[1:] if argv is None else argv
    if args:
        print("usage: python -m retalisc.runtime_location", file=sys.stderr)
        return 2
    directory = runtime_dir()
    if not (directory / ENTRY_MODULE).is_file():
        print(f"retalisc: no {ENTRY_MODULE} in {directory}", file=sys.stderr)
        return 1
    print(directory)
    return 0


if __name__ == "__main__":
    sys.exit(main())
