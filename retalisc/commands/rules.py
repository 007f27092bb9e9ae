"""`retalisc compile-rules`: compile event rules for a running program (ins_event_rule/1)."""
from __future__ import annotations

import sys

import click

from ..runtime_rules import RulesRefused, compile_rules_for_the_runtime


@click.command("compile-rules", epilog="""\b
Example:
  echo 'late : ab(X) <- a(X) seq b(X).' | retalisc compile-rules --module rtl_prog_fire_alarm""")
@click.option("--module", "module", required=True, help="Module of the running program.")
@click.option("--rule-prefix", default="rt", show_default=True,
              help="Unlabelled rules get the ids PREFIX_1, PREFIX_2, ...")
@click.option("--name", default="<rules>", show_default=True, help="File name used in messages.")
def compile_rules_command(module: str, rule_prefix: str, name: str) -> None:
    """Compile the event rules read from standard input for program MODULE and write the
    clauses to add to it, each rule introduced by `'$rtl_rule'(Id, Stores).` (used by the
    runtime's ins_event_rule/1)."""
    text = sys.stdin.read()
    try:
        compiled = compile_rules_for_the_runtime(module, rule_prefix, text, name)
    except RulesRefused as refused:
        click.echo(str(refused), err=True)
        sys.exit(2)
    click.echo(compiled, nl=False)


COMMANDS = [compile_rules_command]
