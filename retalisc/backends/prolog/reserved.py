"""The predicates a generated module sees without defining them (`target_predicates()`), for
the `loadable` pass: a program may not define them, and its directives may call them.

- SWI-Prolog's builtins and autoloaded library (`swi_predicates.py`);
- the predicates the module imports from the runtime, read from the export lists of
  `prolog_runtime/retalis.pl` and of the modules it re-exports (in turn), in the runtime directory the
  generated program will load;
- the predicates every generated module defines (`templates/program.pl.j2`).
"""
from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path
from typing import Dict, Tuple

from ...frontend.errors import RetalisError
from ...frontend.parser import read_program
from ...frontend.terms import Atom, Compound, Number, list_items
from ...passes.unit import TargetPredicates
from .swi_predicates import LIBRARY_PREDICATES, SYSTEM_PREDICATES
from ...runtime_location import runtime_dir

Indicator = Tuple[str, int]

#: Predicates every generated module defines (templates/program.pl.j2).
TEMPLATE_PREDICATES = {("ele_trigger", 3), ("ele_untrigger", 3), ("ele_store", 3), ("ele_partial_store", 2),
                       ("ele_printed", 1), ("ele_declaration", 1)}

_MODULE_HEADER = re.compile(r"^:- module\(.*?\]\)\.", re.S | re.M)
_REEXPORT = re.compile(r"^:- reexport\((\w+)\)\.", re.M)


@lru_cache(maxsize=4)
def _runtime_exports(directory: str) -> Dict[Indicator, str]:
    """Exported predicate -> module, for retalis.pl and the modules it re-exports (and those
    re-export)."""
    found: Dict[Indicator, str] = {}
    root = Path(directory)
    try:
        main = (root / "retalis.pl").read_text(encoding="utf-8")
    except OSError:
        return found
    modules, seen = ["retalis"], set()
    while modules:                  # retalis.pl, the modules it re-exports, theirs in turn
        module = modules.pop(0)
        if module in seen:
            continue
        seen.add(module)
        try:
            text = main if module == "retalis" else (root / f"{module}.pl").read_text(encoding="utf-8")
        except OSError:
            continue
        modules += _REEXPORT.findall(text)
        header = _MODULE_HEADER.search(text)
        if header is None:
            continue
        try:
            clause = read_program(header.group(0), str(root / f"{module}.pl"))[0].term
        except RetalisError:
            continue
        exports = clause.args[0].args[1] if isinstance(clause, Compound) and clause.args else None
        for item in list_items(exports) or []:
            if (isinstance(item, Compound) and item.name == "/" and item.arity == 2
                    and isinstance(item.args[0], Atom) and isinstance(item.args[1], Number)):
                found.setdefault((item.args[0].name, int(item.args[1].value)), module)
    return found


def runtime_predicates() -> Dict[Indicator, str]:
    """The predicates a compiled program imports from the runtime, each with its module."""
    return _runtime_exports(str(runtime_dir()))


def target_predicates() -> TargetPredicates:
    """What a generated module sees without defining it, for the passes (`Unit.target`)."""
    return TargetPredicates(SYSTEM_PREDICATES, LIBRARY_PREDICATES, runtime_predicates(),
                            frozenset(TEMPLATE_PREDICATES))
