"""CLI subcommands, one module per command family; `retalisc.cli` registers them."""
from __future__ import annotations

import importlib

# Modules that define click commands in a module-level list `COMMANDS`.
_COMMAND_MODULES = ["retalisc.commands.compile", "retalisc.commands.aq", "retalisc.commands.rules",
                    "retalisc.commands.query", "retalisc.commands.plot", "retalisc.commands.explain",
                    "retalisc.commands.live"]


def registered_commands():
    for name in _COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:
                continue
            raise
        yield from module.COMMANDS
