"""The `retalisc` command line."""
from __future__ import annotations

import errno
import gc
import os
import sys

import click

from . import commands
from .commands import commands_of, registered_commands


_NO_ARGS_IS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())

class _Group(click.Group):
    """A click group whose usage errors (a missing file, a bad option value, an unknown option)
    are one line on standard error, `retalisc CMD: error: MESSAGE (see retalisc CMD --help)`,
    with exit status 2, instead of click's usage block."""

    def get_command(self, ctx, cmd_name):
        """The command `cmd_name`, its module imported at the first use (`retalisc.commands`)."""
        if cmd_name not in self.commands:
            for command in commands_of(cmd_name):
                self.commands.setdefault(command.name, command)
        return self.commands.get(cmd_name)

    def list_commands(self, ctx):
        for command in registered_commands():
            self.commands.setdefault(command.name, command)
        return sorted(self.commands)

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            result = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except _NO_ARGS_IS_HELP as error:      # `retalisc` alone: the help text
            error.show()
            sys.exit(error.exit_code)
        except click.UsageError as error:
            click.echo(_one_line(error), err=True)
            sys.exit(error.exit_code)
        except click.ClickException as error:
            error.show()
            sys.exit(error.exit_code)
        except click.Abort:
            click.echo("Aborted!", err=True)
            sys.exit(1)
        except OSError as error:
            if error.errno != errno.EPIPE:
                raise
            # the reader of standard output went away (`retalisc run ... | head`)
            sys.stdout = open(os.devnull, "w")
            sys.exit(1)
        sys.exit(result if isinstance(result, int) else 0)


def _one_line(error: click.UsageError) -> str:
    ctx = error.ctx
    path = ctx.command_path if ctx is not None else "retalisc"
    message = " ".join(error.format_message().split())
    hint = f" (see {path} --help)" if ctx is not None else ""
    return f"{path}: error: {message}{hint}"


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="retalisc")
def main() -> None:
    """Compile and run Retalis programs: event patterns (ELE), event memories (SLR) and
    active queries, on SWI-Prolog.

    \b
    retalisc check PROGRAM.rtl                       report errors (file:line:col:), exit 2
    retalisc compile PROGRAM.rtl -o OUT.pl           then: swipl OUT.pl EVENTS.jsonl (or - for stdin)
    retalisc run PROGRAM.rtl --events EVENTS.jsonl   derived events as JSON Lines
    retalisc query PROGRAM.rtl --events EVENTS.jsonl GOAL
    retalisc aq PROGRAM.pl --script UPDATES.txt      active queries
    retalisc compile-rules --module MODULE < RULES   rules for a running program
    """


def entry() -> None:
    """The `retalisc` program (its console script and `python -m retalisc`)."""
    commands.COMMAND_LINE_PROCESS = True
    try:
        main()
    finally:
        # the interpreter's last collection at exit walks every object of the run (the
        # compiler's, the program's, lark's): frozen, it has nothing to walk (a run's CPU)
        gc.freeze()
