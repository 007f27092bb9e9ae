"""`retalisc robapl check|run`: RobAPL agent files (retalisc/robapl/, docs/robapl.md)."""
from __future__ import annotations

import sys

import click


@click.group("robapl")
def robapl_group() -> None:
    """RobAPL agents (thesis chapter 7): plans as node trees run by the deliberation cycle.

    \b
    retalisc robapl check AGENT.apl
    retalisc robapl run AGENT.apl --events EVENTS.jsonl [--actions ACTIONS.py] [--iec IEC.rtl]\n                      [--trace-out T.jsonl] [--plot P.png]
    """


def _load(path: str):
    from ..frontend.errors import RetalisError
    from ..robapl.syntax import load_agent

    try:
        return load_agent(path)
    except RetalisError as error:
        click.echo(error.render(), err=True)
        sys.exit(2)


@robapl_group.command("check")
@click.argument("agent_file", type=click.Path(exists=True, dir_okay=False))
def check_command(agent_file: str) -> None:
    """Report the errors of AGENT_FILE (file:line:col: message, exit 2), or a summary."""
    check_agent(agent_file)


def check_agent(agent_file: str) -> None:
    """`retalisc robapl check` (and `retalisc check` of a `.apl` file)."""
    from ..frontend.errors import RetalisError
    from ..robapl.patterns import check_patterns

    agent = _load(agent_file)
    try:
        patterns = check_patterns(agent)
    except RetalisError as error:
        click.echo(error.render(), err=True)
        sys.exit(2)
    nodes = 0
    for rule in agent.rules:
        stack = [rule.plan]
        while stack:
            node = stack.pop()
            nodes += 1
            stack.extend(node.children)
    click.echo(f"{agent_file}: agent {agent.name}: {len(agent.beliefs)} beliefs, {len(agent.goals)} goals, "
               f"{len(agent.pool)} resources, {len(agent.rules)} rules, {nodes} plan nodes, "
               f"{patterns} pattern conditions", err=True)


@robapl_group.command("run")
@click.argument("agent_file", type=click.Path(exists=True, dir_okay=False))
@click.option("--events", "events_file", required=True, type=click.Path(exists=True, dir_okay=False),
              help='Event JSON Lines: {"t": SECONDS, "event": "TERM"}.')
@click.option("--actions", "actions_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="A Python file defining register(actions): the external actions by name.")
@click.option("--iec", "iec_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="A Retalis program (.rtl) run in step with the agent on its events and node status changes: its derived events join the event base.")
@click.option("--trace-out", type=click.Path(dir_okay=False), default=None,
              help="Write the trace here instead of standard output.")
@click.option("--plot", "plot_file", type=click.Path(dir_okay=False), default=None,
              help="Draw the plan nodes over time, coloured by state (PNG, SVG or PDF).")
def run_command(agent_file: str, events_file: str, actions_file, iec_file, trace_out, plot_file) -> None:
    """Run AGENT_FILE on the events of EVENTS: the trace (events, plans, transitions, actions)
    as JSON Lines."""
    from pathlib import Path

    from ..robapl.executor import ExecutionError
    from ..robapl.runner import read_event_lines, run_agent, trace_lines

    agent = _load(agent_file)
    read = read_event_lines(Path(events_file).read_text(encoding="utf-8"), events_file)
    for message in read.bad:
        click.echo(message, err=True)
    events = list(read.events)
    actions = _load_actions(actions_file)
    from ..robapl.patterns import agent_iec
    iec = agent_iec(agent, Path(iec_file).read_text(encoding="utf-8") if iec_file else None,
                    iec_file or "iec.rtl")
    try:
        trace = run_agent(agent, events, actions, iec=iec)
    except ExecutionError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(1)
    finally:
        if iec is not None:
            for message in iec.problems:
                click.echo(message, err=True)
            iec.close()
    text = trace_lines(trace)
    if trace_out:
        Path(trace_out).write_text(text)
    else:
        click.echo(text, nl=False)
    if plot_file:
        from ..robapl.plot import plot_run
        rows = plot_run(trace, plot_file, title=Path(agent_file).name)
        click.echo(f"{plot_file}: {rows} nodes", err=True)
    if read.bad:
        click.echo(f"{len(read.bad)} bad event lines skipped", err=True)



def _load_actions(actions_file):
    """The actions file's actions. One with ROS 2 actions (robapl/ros2_actions.py) in a Python
    without rclpy: the same command in .venv-ros2's Python, as `retalisc ros2` does."""
    from ..robapl.ros2_actions import MissingRclpy
    from ..robapl.runner import load_actions

    try:
        return load_actions(actions_file)
    except MissingRclpy as error:
        from .ros2_venv import hand_over_to_ros2_venv
        hand_over_to_ros2_venv()
        click.echo(f"error: {error}", err=True)
        sys.exit(1)


COMMANDS = [robapl_group]
