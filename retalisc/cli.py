"""The `retalisc` command line."""
from __future__ import annotations

import click

from .commands import registered_commands


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="retalisc")
def main() -> None:
    """Compile and run Retalis programs: event patterns (ELE), event memories (SLR) and
    active queries, on SWI-Prolog."""


for _command in registered_commands():
    main.add_command(_command)
