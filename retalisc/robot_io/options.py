"""The `--bag` family of options of `retalisc run` (click only: importing this module does
not import rosbags, so the command line starts as fast without the `ros` extra)."""
from __future__ import annotations

import click

STAMPS = ("header", "record")

_OPTIONS = [
    click.option("--bag", type=click.Path(exists=True), default=None, metavar="RECORDING",
                 help="Replay this recording instead of --events: a ROS 1 .bag file, a ROS 2 bag folder "
                      "(sqlite3 or MCAP storage) or an .mcap file; messages become events "
                      "(docs/robot_io.md)."),
    click.option("--topics", default=None, metavar="T1,T2",
                 help="With --bag: replay only these topics (default: all)."),
    click.option("--rate", type=click.FloatRange(min=0, min_open=True), default=None, metavar="RATE",
                 help="With --bag: replay in real time times RATE (1 = as recorded; default: as fast as possible)."),
    click.option("--tick", "bag_tick", type=click.FloatRange(min=0.001, max=10.0), default=0.01, metavar="SECONDS",
                 show_default=True,
                 help="With --bag and --rate: feed each message at most SECONDS after it falls due, with "
                      "the others due by then (longer ticks mean fewer, larger calls into the program: less CPU)."),
    click.option("--start", "bag_start", type=click.FloatRange(min=0), default=0.0, metavar="SECONDS",
                 help="With --bag: skip the first SECONDS of the recording (record time)."),
    click.option("--duration", "bag_duration", type=click.FloatRange(min=0), default=None, metavar="SECONDS",
                 help="With --bag: replay SECONDS of the recording from --start."),
    click.option("--wrap-topic", is_flag=True,
                 help="With --bag: wrap each message in its topic name, topic(Msg) (/tf -> tf(...))."),
    click.option("--plain-strings", is_flag=True,
                 help="With --bag: strings are atoms holding the text ('/odom', the default) even for a "
                      "program that asks for the release's quoted form '\"/odom\"' (ros_strings(quoted), "
                      "compile_event_file)."),
    click.option("--stamp", type=click.Choice(STAMPS), default="header", show_default=True,
                 help="With --bag: the time of an event: its message's header.stamp (the record time "
                      "when it has none), or always the record time."),
    click.option("--typestore", "bag_typestore", default="ros2_humble", show_default=True, metavar="NAME",
                 help="With --bag: the rosbags type store for ROS 2 bags that do not embed their "
                      "message definitions."),
    click.option("--out-bag", type=click.Path(dir_okay=False), default=None, metavar="FILE.mcap",
                 help="With --bag: write the input messages and what the program derived to this MCAP file "
                      "(message events as ROS messages, others as JSON on /retalis/events)."),
    click.option("--foxglove", type=click.IntRange(0, 65535), is_flag=False, flag_value=8765, default=None,
                 metavar="[PORT]",
                 help="With --bag: serve the same live over Foxglove's WebSocket protocol (port 8765 by "
                      "default); waits for a client, then replays in real time unless --rate says otherwise."),
]

# The options that only mean something with --bag, and their defaults.
BAG_DEFAULTS = {"topics": None, "rate": None, "bag_tick": 0.01, "bag_start": 0.0, "bag_duration": None, "wrap_topic": False,
                "plain_strings": False, "stamp": "header", "bag_typestore": "ros2_humble", "out_bag": None,
                "foxglove": None}


def bag_options(command):
    """Add the --bag options to a click command; they arrive as keyword arguments
    (`bag`, `topics`, `rate`, `bag_tick`, `bag_start`, `bag_duration`, `wrap_topic`, `plain_strings`,
    `stamp`, `bag_typestore`)."""
    for option in reversed(_OPTIONS):
        command = option(command)
    return command


# The --bag options that say what becomes an event (for `retalisc query` and `retalisc explain`,
# which read a recording as their input and publish nothing).
INPUT_OPTIONS = ("bag", "topics", "bag_start", "bag_duration", "wrap_topic", "plain_strings", "stamp",
                 "bag_typestore")


def bag_input_options(command):
    """Add the --bag options of INPUT_OPTIONS to a click command (as keyword arguments)."""
    for option in reversed(_OPTIONS):
        decorated = option(lambda: None)
        if decorated.__click_params__[0].name in INPUT_OPTIONS:
            command = option(command)
    return command


def check_bag_input(events, values: dict) -> None:
    """Fail with a usage error unless the input is given once (--events or --bag), and the
    --bag options come with --bag."""
    if events is not None and values["bag"] is not None:
        raise click.UsageError("give the input: --events FILE or --bag RECORDING (one of them)")
    if values["bag"] is None and any(values[name] != BAG_DEFAULTS[name] for name in INPUT_OPTIONS if name != "bag"):
        raise click.UsageError("--topics, --start, --duration, --wrap-topic, --plain-strings, --stamp and "
                               "--typestore go with --bag")
