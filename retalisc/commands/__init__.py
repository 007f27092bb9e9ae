"""CLI subcommands, one module per command family; `retalisc.cli` registers them.

A module is imported when one of its commands runs (or when the command list is shown), so
that a command does not pay for the imports of the others: `COMMAND_MODULES` names each
module's commands, the names of its module-level list `COMMANDS`."""
from __future__ import annotations

import importlib
from typing import Optional

COMMAND_MODULES = {
    "retalisc.commands.compile": ("compile", "check", "run"),
    "retalisc.commands.aq": ("aq",),
    "retalisc.commands.rules": ("compile-rules",),
    "retalisc.commands.query": ("query",),
    "retalisc.commands.plot": ("plot",),
    "retalisc.commands.explain": ("explain",),
    "retalisc.commands.live": ("ros", "ros2", "zenoh"),
    "retalisc.commands.robapl": ("robapl",),
}
_COMMAND_MODULES = list(COMMAND_MODULES)

#: True in the `retalisc` program itself (`cli.entry`), where one thread makes every Prolog
#: call; False when the commands run inside another program (click's test runner, an embedding).
COMMAND_LINE_PROCESS = False


def _import(name: str):
    """The module `name`, or None when it is not installed (an optional part)."""
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name == name:
            return None
        raise


def registered_commands():
    for name in _COMMAND_MODULES:
        module = _import(name)
        if module is not None:
            yield from module.COMMANDS


def commands_of(command: str) -> list:
    """The commands of the module that defines `command` (imported now), or [] when no
    module defines it."""
    module_name: Optional[str] = next((m for m, names in COMMAND_MODULES.items() if command in names), None)
    module = _import(module_name) if module_name is not None else None
    return list(module.COMMANDS) if module is not None else []
