"""`retalisc ros`, `retalisc ros2`, `retalisc zenoh`: a program as a live component
(docs/ros.md). Each subscribes to the topics of its pub_sub.xml, feeds their messages to the
program, publishes the subscription deliveries and runs until SIGINT or SIGTERM (or
--duration), then prints a summary on standard error."""
from __future__ import annotations

import os
import signal
import sys
import threading
import time
from typing import Callable, Optional

import click

from ..driver.feed import summary_line
from .compile import compile_or_exit
from .ros2_venv import hand_over_to_ros2_venv as _hand_over_to_ros2_venv
from .options import Seconds, check_snapshot_options, output_file, run_option, state_options
from ..run_options import engine_flags


def _common(command):
    options = [
        click.argument("program", type=click.Path(exists=True, dir_okay=False)),
        click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False), default=None,
                     metavar="PUB_SUB.xml",
                     help="The topics to subscribe to and the types of the topics to publish on (thesis "
                          "Listing 2.2)."),
        click.option("--out", default=None, metavar="FILE|-",
                     help="Write every output line (derived events, deliveries) as JSON Lines here."),
        click.option("--wrap-topic", is_flag=True, help="Wrap each message in its topic name, topic(Msg)."),
        click.option("--plain-strings", is_flag=True,
                     help="Strings are atoms holding the text ('/odom', the default) even for a program "
                          "that asks for the release's '\"/odom\"' (ros_strings(quoted), compile_event_file)."),
        run_option("max_delay", help="As for `retalisc run`."),
        click.option("--duration", type=Seconds(allow_inf=False), default=None, metavar="SECONDS",
                     help="Stop after SECONDS (default: run until SIGINT or SIGTERM)."),
        click.option("--linger", type=Seconds(allow_inf=False), default=0.0, metavar="SECONDS",
                     help="Feed messages arriving within SECONDS of each other in one batch (fewer Prolog "
                          "calls, less CPU, that much more latency; default 0: feed what is waiting at once)."),
        click.option("--heartbeat", type=click.FloatRange(min=0.001), default=None, metavar="SECONDS",
                     help="While no message arrives, move the program's clock to the node's clock every "
                          "SECONDS of it (ROS 2: /clock under use_sim_time), so that absences and alarms fire "
                          "on time. Not with --state."),
    ]
    for option in reversed(options):
        command = option(command)
    return state_options(
        "Survive a crash: journal every event and service request in DIR before it is fed, "
        "keep snapshots there; started again with the same DIR, the node restores the newest "
        "snapshot and replays the journal (docs/recovery.md). --out must then be a file.",
        "With --state: a snapshot every N events (default 200000).",
        "With --state: a snapshot every S seconds at the latest, also when no event comes "
        "(default 60; inf: only by --snapshot-every).")(command)


def serve(program: str, config_path: Optional[str], make_transport: Callable, out: Optional[str],
          wrap_topic: bool, plain_strings: bool, max_delay, duration, describe: Callable, linger: float = 0.0,
          recovery: Optional[dict] = None, heartbeat: Optional[float] = None) -> int:
    from ..driver.engine import Engine
    from ..driver.recovery import RecoveryError
    from ..live.config import ConfigError, PubSubConfig, load_config
    from ..live.node import LiveNode
    from ..robot_io import MissingDependency
    from ..robot_io.messages import Convention

    output_file(out, "--out")
    recovery = recovery or {}
    check_snapshot_options(recovery.get("state"), recovery.get("snapshot_every"), recovery.get("snapshot_seconds"))
    if recovery.get("state") is not None and heartbeat is not None:
        raise click.UsageError("--state does not go with --heartbeat (a replay would not see the same clock)")
    if recovery.get("state") is not None and out == "-":
        raise click.UsageError("--state needs --out FILE (or no --out): standard output cannot be cut back")
    try:
        config = load_config(config_path) if config_path else PubSubConfig()
    except ConfigError as error:
        click.echo(f"error: {error}", err=True)
        return 2
    try:
        transport = make_transport()
    except MissingDependency as error:
        click.echo(f"error: {error}", err=True)
        return 2
    from ..compile_cache import cached_compile
    from ..compiler import unique_module_name
    from .compile import _calls_in_this_thread, _print_warnings

    module = unique_module_name(program)
    compiled = cached_compile(program, module, lambda: compile_or_exit(program, module=module),
                              found=_print_warnings)              # as `retalisc run` takes it
    here = _calls_in_this_thread()       # this thread feeds the Engine: no handoff per call
    engine = Engine.from_prolog(compiled.prolog, compiled.module, compiled.rules)
    for flag, value in engine_flags({"max_delay": max_delay}):      # retalisc/run_options.py
        engine.set_flag(flag, value)
    state = None
    if recovery.get("state") is not None:
        from ..driver.recovery import DEFAULT_SNAPSHOT_EVENTS, DEFAULT_SNAPSHOT_SECONDS
        from ..live.state import LiveState

        every, seconds = recovery.get("snapshot_every"), recovery.get("snapshot_seconds")
        state = LiveState(recovery["state"], out, DEFAULT_SNAPSHOT_EVENTS if every is None else every,
                          DEFAULT_SNAPSHOT_SECONDS if seconds is None else seconds,
                          log=lambda text: click.echo(text, err=True))
        sink = None                      # the state opens the output file (cut back to its snapshot)
    else:
        sink = None if out is None else (sys.stdout if out == "-" else open(out, "w", encoding="utf-8"))
    node = LiveNode(engine, transport, config, Convention.of_program(engine, plain_strings, wrap_topic),
                    out=sink, linger=linger, state=state, heartbeat=heartbeat)
    stop = threading.Event()

    def stopped(*_) -> None:
        stop.set()
        node.stop()

    previous = {sig: signal.signal(sig, stopped) for sig in (signal.SIGINT, signal.SIGTERM)}
    status = 0
    started = time.perf_counter()
    try:
        try:
            node.start(here=here)
        except RecoveryError as error:
            click.echo(f"error: --state {recovery['state']}: {error}", err=True)
            status = 2
        except Exception as error:
            click.echo(f"error: {error}", err=True)
            status = 2
        else:
            click.echo(describe(node), err=True)
            deadline = None if duration is None else time.monotonic() + duration
            if here and not stop.is_set():
                node.run(duration)          # until a stop signal (or the duration)
            while not here and not stop.is_set():
                left = 0.5 if deadline is None else min(0.5, deadline - time.monotonic())
                if left <= 0:
                    break
                stop.wait(left)
    finally:
        node.close()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if sink is not None and sink is not sys.stdout:
            sink.close()
    click.echo(node.stats.summary(transport.name, transport.offers_services), err=True)
    click.echo(summary_line(engine.stats(), time.perf_counter() - started), err=True)   # feed.py's text, from the start
    return status


def _inputs(node) -> str:
    topics = ", ".join(f"{topic} ({msgtype})" for topic, msgtype in sorted(node.inputs.items()))
    return topics or "nothing yet"


@click.command("ros", epilog="""\b
Example (after `bash setup.sh`, with a ROS master running):
  .venv-ros/bin/retalisc ros examples/nao_markers/nao_markers.rtl --config examples/nao_markers/pub_sub.xml""")
@_common
@click.option("--name", "node_name", default="retalis", show_default=True,
              help="The node's name; its services are /NAME/add_output_subscription, ... (docs/ros.md).")
def ros_command(program, config_path, out, wrap_topic, plain_strings, max_delay, duration, linger, heartbeat, state,
                snapshot_every, snapshot_seconds, node_name) -> None:
    """Run PROGRAM as a live ROS 1 node: subscribe to the topics of PUB_SUB.xml, publish
    subscription deliveries, and offer the services of the 2015 release (thesis A.1):
    add/delete_output_subscription, add/delete_memory, add/delete_input_subscription,
    query_one, query_all. Needs Debian's rospy: run it with .venv-ros/bin/retalisc."""

    def make():
        from ..robot_io import MissingDependency
        try:
            from ..live.ros1 import Ros1Transport
            return Ros1Transport(node_name)
        except ModuleNotFoundError as error:
            if error.name in ("rospy", "genpy", "genmsg", "rosgraph"):
                raise MissingDependency(
                    "retalisc ros needs ROS 1's rospy (Debian: python3-rospy): run `bash setup.sh`, "
                    "then .venv-ros/bin/retalisc ros ...") from None
            raise

    def describe(node):
        return (f"ros: node /{node_name} on {_master()}: subscribed to {_inputs(node)}; "
                f"services /{node_name}/{{add,delete}}_{{output_subscription,memory,input_subscription}}, "
                f"/{node_name}/query_one, /{node_name}/query_all")

    sys.exit(serve(program, config_path, make, out, wrap_topic, plain_strings, max_delay, duration, describe, linger,
                   dict(state=state, snapshot_every=snapshot_every, snapshot_seconds=snapshot_seconds), heartbeat))


@click.command("ros2", context_settings={"ignore_unknown_options": True}, epilog="""\b
Example (after `bash setup.sh`): a node /retalis, its services /retalis/query_all, ...
  retalisc ros2 examples/nao_markers/nao_markers.rtl --config examples/nao_markers/pub_sub.xml
With sim time and a name given the ROS 2 way (as a launch file does):
  retalisc ros2 PROGRAM.rtl --config pub_sub.xml --ros-args -r __node:=iec1 -p use_sim_time:=true""")
@_common
@click.option("--name", "node_name", default="retalis", show_default=True,
              help="The node's name; its services are /NAME/add_output_subscription, ... (docs/ros.md).")
@click.option("--namespace", default="", metavar="NS", help="The node's namespace (default: the root).")
@click.option("--domain", type=click.IntRange(0, 232), default=None,
              help="The ROS 2 domain (default: $ROS_DOMAIN_ID, else 0).")
@click.argument("ros_args", nargs=-1, type=click.UNPROCESSED, metavar="[--ros-args ...]")
def ros2_command(program, config_path, out, wrap_topic, plain_strings, max_delay, duration, linger, heartbeat, state,
                 snapshot_every, snapshot_seconds, node_name, namespace, domain, ros_args) -> None:
    """Run PROGRAM as a live ROS 2 node (rclpy): subscribe to the topics of PUB_SUB.xml (with
    their QoS), publish subscription deliveries, offer the services of the 2015 release
    (thesis A.1) with the types of ros/retalis_interfaces, and the parameters program, config,
    name, max_delay, state_dir (read-only) and use_sim_time. Arguments after --ros-args are
    ROS 2's (remappings, -p use_sim_time:=true, --params-file). Needs rclpy: run with
    .venv-ros2/bin/retalisc, or from .venv, which hands over to .venv-ros2 (setup.sh)."""
    if ros_args and ros_args[0] != "--ros-args":
        raise click.UsageError(f"unexpected argument {ros_args[0]!r} (ROS 2 arguments come after --ros-args)")

    def make():
        from ..robot_io import MissingDependency
        from ..live.ros2 import Ros2Transport

        parameters = {"program": program, "config": config_path or "", "name": node_name,
                      "max_delay": "" if max_delay is None else repr(max_delay), "state_dir": state or ""}
        try:
            return Ros2Transport(node_name, namespace, list(ros_args), parameters, domain)
        except ModuleNotFoundError as error:
            if error.name != "rclpy":
                raise
            _hand_over_to_ros2_venv()
            raise MissingDependency(
                "retalisc ros2 needs ROS 2's rclpy: run `bash setup.sh` (it makes .venv-ros2), or run "
                "retalisc in the Python of your sourced ROS 2 installation (docs/ros.md)") from None

    def describe(node):
        name = node.transport.fully_qualified_name
        return (f"ros2: node {name} in domain {node.transport.domain}: subscribed to {_inputs(node)}; services "
                f"{name}/{{add,delete}}_{{output_subscription,memory,input_subscription}}, {name}/query_one, "
                f"{name}/query_all")

    sys.exit(serve(program, config_path, make, out, wrap_topic, plain_strings, max_delay, duration, describe, linger,
                   dict(state=state, snapshot_every=snapshot_every, snapshot_seconds=snapshot_seconds), heartbeat))


@click.command("zenoh", epilog="""\b
Example: two components, the second consuming what the first delivers:
  retalisc zenoh first.rtl --config first.xml --listen tcp/127.0.0.1:7447 --connect tcp/127.0.0.1:7448 &
  retalisc zenoh second.rtl --config second.xml --listen tcp/127.0.0.1:7448 --connect tcp/127.0.0.1:7447""")
@_common
@click.option("--listen", multiple=True, metavar="ENDPOINT",
              help="Listen for other components here (tcp/127.0.0.1:PORT); repeatable.")
@click.option("--connect", multiple=True, metavar="ENDPOINT",
              help="Connect to a component listening here; repeatable; retried until it is up.")
def zenoh_command(program, config_path, out, wrap_topic, plain_strings, max_delay, duration, linger, heartbeat, state,
                  snapshot_every, snapshot_seconds, listen, connect) -> None:
    """Run PROGRAM as a live component over Zenoh, without a ROS master: a Zenoh peer with
    multicast scouting off and explicit endpoints; topic /name is key `name`, messages are
    ROS 2 CDR (docs/ros.md)."""
    if not listen and not connect:
        raise click.UsageError("give at least one --listen or --connect endpoint (tcp/127.0.0.1:PORT)")

    def make():
        from ..live.zenoh_transport import ZenohTransport
        return ZenohTransport(listen, connect)

    def describe(node):
        return (f"zenoh: peer listening on {', '.join(listen) or 'nothing'}, connecting to "
                f"{', '.join(connect) or 'nothing'}: subscribed to {_inputs(node)}")

    sys.exit(serve(program, config_path, make, out, wrap_topic, plain_strings, max_delay, duration, describe, linger,
                   dict(state=state, snapshot_every=snapshot_every, snapshot_seconds=snapshot_seconds), heartbeat))


def _master() -> str:
    return os.environ.get("ROS_MASTER_URI", "http://localhost:11311")


COMMANDS = [ros_command, ros2_command, zenoh_command]
