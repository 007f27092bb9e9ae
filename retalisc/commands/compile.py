"""`retalisc compile`, `retalisc check` and `retalisc run`."""
from __future__ import annotations

import sys
from pathlib import Path

import click

from .options import (LazyChoice, Seconds, check_snapshot_options, output_directory, output_file, run_options,
                      state_options)
from ..run_options import cli_options, engine_flags, keeps_python
from ..robot_io.options import BAG_DEFAULTS, bag_options
from .. import commands


def report_program_error(error) -> None:
    """Print `file:line:col: message` with the offending line and exit with status 2."""
    click.echo(error.render(), err=True)
    sys.exit(2)


def compile_or_exit(program: str, werror: bool = False, **kwargs):
    """Compile `program` or exit with status 2 on errors; print the warnings on standard error.
    With `werror`, the warnings are errors: printed as such, and exit status 2."""
    from ..compiler import compile_file
    from ..frontend.errors import RetalisError

    try:
        result = compile_file(program, **kwargs)
    except RetalisError as error:
        report_program_error(error)
    except UnicodeDecodeError as error:
        click.echo(f"{program}: error: not a UTF-8 text file ({error.reason})", err=True)
        sys.exit(2)
    if werror and result.warnings:
        for warning in result.warnings:
            click.echo(_as_error(warning), err=True)
        count = len(result.warnings)
        click.echo(f"{program}: {count} warning{'s' if count != 1 else ''} treated as error{'s' if count != 1 else ''} "
                   "(--werror)", err=True)
        sys.exit(2)
    for warning in result.warnings:
        click.echo(warning, err=True)
    return result


def _as_error(warning: str) -> str:
    """A warning's text with its `warning:` tag made `error:` (--werror)."""
    head, sep, rest = warning.partition(": warning: ")
    return f"{head}: error: {rest}" if sep else warning


def _pipeline():
    """The compiler's pass lists (imported when a command needs them, not for every command)."""
    from ..passes import pipeline

    return pipeline


WERROR = click.option("--werror", is_flag=True,
                      help="Treat warnings (traps such as a window on the last operand only, an undefined "
                           "predicate in a condition) as errors: exit status 2.")


@click.command("compile", epilog="""\b
Examples:
  retalisc compile examples/fire_alarm/fire_alarm.rtl -o fire_alarm.pl
  swipl fire_alarm.pl examples/fire_alarm/events.jsonl
  swipl fire_alarm.pl - < examples/fire_alarm/events.jsonl      # '-': standard input
  retalisc compile examples/fire_alarm/fire_alarm.rtl --dump-after binarize
  retalisc compile tests/golden/program1/program.pl --active-queries tabled -o aq.pl""")
@click.argument("program", type=click.Path(exists=True, dir_okay=False))
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="Write the Prolog program here "
              "(default, or -: standard output).")
@click.option("--dump-after", type=LazyChoice(lambda: _pipeline().PASS_NAMES),
              help="Print the program after this pass and stop (with --active-queries: aq_program or the pass of the transformation).")
@click.option("--active-queries", "active_queries", type=LazyChoice(lambda: _pipeline().AQ_MODES),
              help="Compile PROGRAM as a definite program for active queries with this transformation "
                   "(aq_register/2, aq_assert/1, ...; see docs/active_queries.md).")
@click.option("--subsumption", is_flag=True, help="With --active-queries tabled: reuse tables by subsumption.")
@WERROR
def compile_command(program: str, output: str, dump_after: str, active_queries: str, subsumption: bool,
                    werror: bool) -> None:
    """Compile PROGRAM (.rtl) to a SWI-Prolog module.

    Run the result with `swipl OUT.pl EVENTS.jsonl`: it prints the derived events as JSON Lines.
    With --active-queries, PROGRAM is a definite program (rules and facts) compiled for
    active queries instead.
    """
    from ..compiler import AqOptions, pass_names

    options = AqOptions(active_queries, subsumption) if active_queries else None
    if dump_after:
        if dump_after not in pass_names(options):
            raise click.UsageError(f"--dump-after {dump_after}: this compilation runs the passes "
                                   f"{', '.join(pass_names(options))}")
        compile_or_exit(program, dump_after=dump_after, dump=click.echo, active_queries=options)
        return
    to_file = output not in (None, "-")
    result = compile_or_exit(program, werror, output_name=Path(output).name if to_file else "PROGRAM.pl",
                             active_queries=options)
    if to_file:
        try:
            Path(output).write_text(result.prolog, encoding="utf-8")
        except OSError as error:
            raise click.BadParameter(f"cannot write {output}: {error.strerror}", param_hint="-o") from None
    else:
        click.echo(result.prolog, nl=False)


@click.command("check", epilog="""\b
Example:
  retalisc check examples/fire_alarm/fire_alarm.rtl    # examples/fire_alarm/fire_alarm.rtl: ok (1 event rule)""")
@click.argument("program", type=click.Path(exists=True, dir_okay=False))
@WERROR
def check_command(program: str, werror: bool) -> None:
    """Check PROGRAM for errors without writing anything (exit status 2 on errors).

    It runs the whole compilation, as `retalisc compile` does, and discards the result: a
    program `check` accepts compiles, and its Prolog loads. Programs that compile but cannot
    mean what they say get warnings (`file:line:col: warning: ...` with a hint)."""
    if program.endswith(".apl"):            # a RobAPL agent file (docs/robapl.md)
        from .robapl import check_agent
        check_agent(program)
        return
    from ..load_check import load_error

    result = compile_or_exit(program, werror)
    error = load_error(result, program)
    if error is not None:
        report_program_error(error)
    rules = len(result.unit.rules)
    warnings = len(result.warnings)
    noted = f", {warnings} warning{'s' if warnings != 1 else ''}" if warnings else ""
    click.echo(f"{program}: ok ({rules} event rule{'s' if rules != 1 else ''}{noted})", err=True)


@click.command("run", epilog="""\b
Examples:
  retalisc run examples/fire_alarm/fire_alarm.rtl --events examples/fire_alarm/events.jsonl
  cat examples/fire_alarm/events.jsonl | retalisc run examples/fire_alarm/fire_alarm.rtl --events - --echo-input
  retalisc run examples/state_knowledge/state_knowledge.rtl --events examples/state_knowledge/events.jsonl \\
      --max-delay 0.5 --query 14 'location(box, L)^14'""")
@click.argument("program", type=click.Path(exists=True, dir_okay=False))
@click.option("--events", "events", type=click.Path(exists=True, allow_dash=True, dir_okay=False),
              help="Event JSON Lines file ('-' for standard input). Or --bag.")
@click.option("--out", type=click.Path(dir_okay=False, allow_dash=True), default="-",
              help="Write the output JSON Lines here (default: standard output).")
@run_options
@click.option("--batch-size", type=click.IntRange(1), default=2000, show_default=True,
              help="Events handed to Prolog per call.")
@click.option("--subscribe", "subscriptions", multiple=True, metavar="'CONSUMER=QUERY[=>TEMPLATE]'",
              help="Subscribe CONSUMER to the events matching QUERY (Event or Event-[Goals]), delivered "
                   "as TEMPLATE (default: the event). Repeatable.")
@click.option("--memory", "memories", multiple=True, metavar="'c_mem(Id, Event-Conds, N, L)'",
              help="Create a memory instance before the events (c_mem/4, c_mem/5, memorize/5; d_mem/1 deletes one). "
                   "Repeatable.")
@click.option("--query", "queries", multiple=True, nargs=2, type=(float, str), metavar="Z GOAL",
              help="Post the synchronized query <GOAL, Z> before the events; its answers are written as "
                   "a line {\"query\": N, \"status\": ..., \"answers\": [...]} when it becomes achievable "
                   "(N counts the --query options from 1). Repeatable.")
@click.option("--query-timeout", type=Seconds(), default=None,
              help="A synchronized query still waiting when the clock reaches Z + SECONDS ends with status "
                   "\"timeout\" (default: it waits until the end of the input).")
@click.option("--heartbeat", type=click.FloatRange(min=0.001), default=None, metavar="SECONDS",
              help="A live source (e.g. --events - fed by a robot): process lines as they arrive, and while "
                   "none arrives advance the clock with the wall clock every SECONDS, so that absences and "
                   "alarms fire on time.")
@click.option("--progress/--no-progress", default=None,
              help="Show a progress line on standard error (default: on a terminal, for inputs over 5 MB).")
@click.option("--trace", "traces", multiple=True, metavar="RULE",
              help="Write to standard error every partial match of rule RULE (a label, r1 for the first "
                   "rule; 'all' for every rule) created, consumed, expired, dropped, replaced or retracted, "
                   "and at the end its detections and counts. Repeatable.")
@click.option("--late", "late_file", type=click.Path(dir_okay=False), default=None, metavar="FILE",
              help="Write every input event that arrives more than --max-delay behind the latest one to FILE "
                   "(JSON Lines: its lateness and the rules whose partners it may have missed).")
@click.option("--no-cache", "no_cache", is_flag=True,
              help="Compile PROGRAM even when the compile cache holds it, and do not store it there "
                   "(also: RETALISC_NO_CACHE=1; docs/reference.md).")
@state_options(
    "Survive a crash: keep snapshots of the state in DIR; started again with the same DIR, "
    "the run goes on from the newest complete snapshot and the --out file ends byte-identical "
    "to that of a run that never stopped (docs/recovery.md). Needs --events FILE and --out FILE.",
    "With --state: a snapshot every N input lines (default 200000).",
    "With --state: a snapshot every S seconds of processing at the latest (default 60; inf: "
    "only by --snapshot-every).")
@bag_options
def run_command(program: str, events: str, out: str, batch_size: int, subscriptions, memories, queries,
                query_timeout, heartbeat, progress, traces, late_file, no_cache, state, snapshot_every,
                snapshot_seconds, **options) -> None:
    """Run PROGRAM over an event file or a recording (--bag), printing derived events as JSON Lines.

    \b
    Example:
      retalisc run fire_alarm.rtl --events events.jsonl --strict --action-output actions.log
    """
    from ..compile_cache import CompiledProgram, cached_compile
    from ..compiler import unique_module_name

    runtime = {option.name: options.pop(option.name) for option in cli_options()}   # run_options.py
    bag = options
    consumer_dir, action_output = runtime["consumer_dir"], runtime["action_output"]
    drop_pending, allow_control, strict = runtime["drop_pending"], runtime["allow_control"], runtime["strict"]
    if (events is None) == (bag["bag"] is None):
        raise click.UsageError("give the input: --events FILE or --bag RECORDING (one of them)")
    if bag["bag"] is None and any(bag[name] != default for name, default in BAG_DEFAULTS.items()):
        raise click.UsageError("--topics, --rate, --start, --duration, --wrap-topic, --plain-strings, "
                               "--stamp, --typestore, --out-bag and --foxglove go with --bag")
    check_snapshot_options(state, snapshot_every, snapshot_seconds)
    if state is not None:
        if heartbeat is not None:
            raise click.UsageError("--state does not go with --heartbeat (a replay would not see the same clock)")
        if bag["bag"] is not None and (bag["rate"] is not None or bag["out_bag"] is not None
                                       or bag["foxglove"] is not None):
            raise click.UsageError("--state replays a recording as fast as it can: not with --rate, --out-bag "
                                   "or --foxglove")
        if out in (None, "-"):
            raise click.UsageError("--state needs --out FILE (standard output cannot be cut back after a crash)")
        if consumer_dir is not None:
            raise click.UsageError("--state does not go with --consumer-dir (the deliveries go to --out)")
        output_directory(state, "--state")
    module = unique_module_name(program)        # a second run in one process loads anew
    handover = (bag["bag"] is None and state is None and not (subscriptions or memories or queries or traces)
                and late_file is None and not keeps_python(runtime) and _runs_in_runtime_loop(events, out, consumer_dir,
                                                                                           progress, heartbeat))
    if traces or late_file:                     # these need the compiled unit itself
        result = compile_or_exit(program, module=module)
        compiled = CompiledProgram.of(result)
    else:
        compiled = cached_compile(program, module, lambda: compile_or_exit(program, module=module),
                                  use_cache=not no_cache, found=_print_warnings, as_file=handover)
    output_file(out, "--out")
    output_directory(consumer_dir, "--consumer-dir")
    if handover and compiled.file is not None:
        _hand_over_to_swipl(compiled, events, runtime)
    from ..driver.bridge import PrologError
    from ..driver.engine import Engine
    from ..driver.run import run_event_file, set_action_output

    in_this_thread = _calls_in_this_thread()
    engine = Engine.from_prolog(compiled.prolog, compiled.module, compiled.rules)
    for flag, value in engine_flags(runtime):
        engine.set_flag(flag, value)
    if action_output is not None:
        try:
            set_action_output(engine, action_output)
        except PrologError as error:
            click.echo(f"error: --action-output {action_output}: cannot open the action output file ({error})",
                       err=True)
            sys.exit(2)
    report = _start_tracing(engine, result.unit, traces, late_file) if traces or late_file else None
    for spec in subscriptions:
        add_cli_subscription(engine, spec)
    for request in memories:
        add_cli_memory(engine, request)
    posted = [post_cli_query(engine, number, at, goal, query_timeout)
              for number, (at, goal) in enumerate(queries, start=1)]
    if bag["bag"] is not None and state is not None:
        from ..driver import recovery
        from ..robot_io.replay import BagOptions
        try:
            status = recovery.run_bag_recoverable(
                engine, bag["bag"], out, state, BagOptions.from_cli(bag, engine), batch_size=batch_size,
                snapshot_events=snapshot_every or recovery.DEFAULT_SNAPSHOT_EVENTS,
                snapshot_seconds=recovery.DEFAULT_SNAPSHOT_SECONDS if snapshot_seconds is None else snapshot_seconds,
                drop_pending=drop_pending, first_output=posted)
        except recovery.RecoveryError as error:
            click.echo(f"error: --state {state}: {error}", err=True)
            sys.exit(2)
        sys.exit(status)
    if bag["bag"] is not None:
        from ..robot_io.replay import replay_from_cli
        sys.exit(replay_from_cli(engine, out, bag, batch_size=batch_size, consumer_dir=consumer_dir,
                                 drop_pending=drop_pending, first_output=posted, trace_report=report))
    if state is not None:
        from ..driver import recovery
        try:
            status = recovery.run_recoverable(
                engine, events, out, state, batch_size=batch_size,
                snapshot_events=snapshot_every or recovery.DEFAULT_SNAPSHOT_EVENTS,
                snapshot_seconds=recovery.DEFAULT_SNAPSHOT_SECONDS if snapshot_seconds is None else snapshot_seconds,
                drop_pending=drop_pending, first_output=posted, allow_control=allow_control, strict=strict,
                progress=progress)
        except recovery.RecoveryError as error:
            click.echo(f"error: --state {state}: {error}", err=True)
            sys.exit(2)
        sys.exit(status)
    status = run_event_file(engine, events, out, batch_size=batch_size, consumer_dir=consumer_dir,
                            drop_pending=drop_pending, first_output=posted, allow_control=allow_control,
                            strict=strict, progress=progress, heartbeat=heartbeat, report=report,
                            stdin_in_prolog=in_this_thread)
    sys.exit(status)


def _print_warnings(compiled) -> None:
    """The warnings of a program taken from the compile cache, printed as its compilation does."""
    for warning in compiled.warnings:
        click.echo(warning, err=True)


def _runs_in_runtime_loop(events, out, consumer_dir, progress, heartbeat) -> bool:
    """Whether, in the `retalisc` program itself, the events go through the runtime's own
    loop (`in_prolog_loop`), which `swipl` runs as well, writing to this process's own
    standard output and error (not to streams another program put in their place)."""
    from ..driver.run import in_prolog_loop

    return (commands.COMMAND_LINE_PROCESS and events is not None and _process_streams()
            and in_prolog_loop(events, out, consumer_dir, progress, heartbeat))


def _process_streams() -> bool:
    try:
        return sys.stdout.fileno() == 1 and sys.stderr.fileno() == 2
    except (AttributeError, OSError, ValueError):
        return False


def _hand_over_to_swipl(compiled, events: str, options) -> None:
    """Replace this process by `swipl` on the cached program file, when its command line can
    say the run (retalisc/driver/swipl_handover.py); returns when it cannot."""
    from ..driver.swipl_handover import hand_over, swipl_arguments, swipl_command

    arguments = swipl_arguments(events, compiled.rules, **options)      # the run options given
    command = swipl_command(str(compiled.file), arguments) if arguments is not None else None
    if command is not None:
        hand_over(command)


def _calls_in_this_thread() -> bool:
    """In the `retalisc` program, run Prolog in this (the only calling) thread: each call then
    runs at once instead of being handed to the bridge's own thread, which takes two thread
    wake-ups per call (what spreads a live stream's latency on a busy machine). Not when the
    command runs inside another program (click's test runner), whose other threads may call."""
    from ..driver.bridge import Bridge

    return commands.COMMAND_LINE_PROCESS and Bridge().run_in_calling_thread()


def _start_tracing(engine, unit, traces, late_file):
    """`--trace RULE` and `--late FILE`: start the runtime's tracing (prolog_runtime/rtl_trace.pl);
    returns what gives the report printed before the summary."""
    from ..driver.explain import late_rules, trace_specs

    labels = list(dict.fromkeys(traces))
    if "all" in labels:
        labels = [b.rule_id for b in unit.rules]
    try:
        specs = trace_specs(unit, labels) if labels else []
    except KeyError as error:
        known = ", ".join(b.rule_id for b in unit.rules)
        raise click.BadParameter(f"no rule {error.args[0]!r} in the program (its rules: {known})",
                                 param_hint="--trace") from None
    if late_file is not None:
        output_file(late_file, "--late")
        engine.trace("late", late_file, late_rules(unit))
    if specs:
        engine.trace("rules", specs)

    def report() -> str:
        text = engine.trace("report") if specs else ""
        engine.trace("end")
        return text
    return report


def post_cli_query(engine, number: int, at: float, goal: str, timeout):
    """`--query Z GOAL`: exit 2 when GOAL does not parse or is refused. Returns the output lines
    of queries answered at once."""
    from ..driver.engine import QueryError

    if at != at or at in (float("inf"), float("-inf")):
        raise click.BadParameter(f"{at}: the time of a query must be a finite number", param_hint="--query")
    try:
        return engine.post_synchronized(goal, at, timeout, query_id=str(number))
    except QueryError as error:
        click.echo(f"--query {goal!r}: {error.kind} error: {error.message}", err=True)
        sys.exit(2)


def add_cli_memory(engine, request: str) -> None:
    """`--memory 'c_mem(...)'`: exit 2 when it does not parse or is refused, 1 when it fails."""
    from ..driver.engine import QueryError

    try:
        engine.memory(request)
    except QueryError as error:
        click.echo(f"--memory {request!r}: {error.kind} error: {error.message}", err=True)
        sys.exit(2 if error.kind in ("syntax", "unsafe") else 1)


def add_cli_subscription(engine, spec: str) -> None:
    """`--subscribe 'CONSUMER=QUERY[=>TEMPLATE]'`: a usage error (exit 2) when it is malformed."""
    from ..driver.bridge import PrologError

    consumer, sep, rest = spec.partition("=")
    query, _, template = rest.partition("=>")
    if not sep or not consumer.strip() or not query.strip():
        raise click.UsageError(f"--subscribe {spec!r}: expected 'CONSUMER=QUERY' or 'CONSUMER=QUERY=>TEMPLATE'")
    try:
        engine.subscribe_query(consumer.strip(), query, template or None)
    except PrologError as error:
        raise click.UsageError(f"--subscribe {spec!r}: {error}")


COMMANDS = [compile_command, check_command, run_command]
