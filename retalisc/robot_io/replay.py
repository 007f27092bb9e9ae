"""`retalisc run PROGRAM --bag FILE`: a recording replayed into a running program.

Each message of the selected topics becomes an event (messages.py), in record order, and
goes to the Engine in batches (`feed_batch`, one Prolog call per batch). The messages of a
ROS 1 recording go as their bytes, which the runtime reads in C (ros1_terms.py), unless the
input is also published (--out-bag, --foxglove); a message it refuses is converted here. With a rate, the
replay follows the recording's clock (times the rate), feeding each message when it is due.
The output is written as by `retalisc run --events`; with a rate, a message is fed at most
--tick (10 ms) after it falls due, with the others due by then (on the wall clock, with
nothing published, the runtime paces them itself: PACED_AHEAD). Rejected messages (that cannot be
decoded or converted) are reported on standard error as `BAG:TOPIC#N: rejected: REASON` (N
counts the replayed messages from 1) and skipped; a summary closes the run.
"""
from __future__ import annotations

import os
import sys
import time
from collections import Counter
from dataclasses import dataclass, field, replace
from typing import Callable, Iterator, List, Optional, Sequence, Tuple

import click

from .bags import DEFAULT_ROS2_STORE, BagError, Record, Recording, topic_list
from .messages import CLOCK_TOPIC, ConversionError, Convention, EventClock, MessageConverter
from .ros1_terms import Ros1Terms
from ..driver.bridge import PrologError
from ..driver.feed import Batch, EngineSource, FeedLoop, Problem, Sink, Sinks, TextSink, feed_resilient
from ..driver.outputs import ConsumerFiles
from . import MissingDependency
from .bags import typestore
from .publish import EVENTS_TOPIC, FoxgloveSink, McapSink, Publisher


@dataclass
class BagOptions:
    """What to replay and how messages become events (the --bag options of `retalisc run`)."""

    topics: Optional[List[str]] = None
    rate: Optional[float] = None          # None: as fast as possible
    tick: float = 0.01                    # with a rate: the latency budget (RATE_TICK)
    start: float = 0.0                    # seconds skipped from the start of the recording
    duration: Optional[float] = None      # seconds replayed from `start`
    convention: Convention = field(default_factory=Convention)
    stamp: str = "header"                 # or "record": every event at its record time
    typestore: str = DEFAULT_ROS2_STORE   # for ROS 2 bags without definitions

    @classmethod
    def from_cli(cls, values: dict, engine=None) -> "BagOptions":
        """The options of the command line, for `engine`'s program (its string convention)."""
        return cls(topics=topic_list(values.get("topics")), rate=values.get("rate"),
                   tick=values.get("bag_tick") or RATE_TICK,
                   start=values.get("bag_start") or 0.0, duration=values.get("bag_duration"),
                   convention=Convention.of_program(engine, bool(values.get("plain_strings")),
                                                    bool(values.get("wrap_topic"))),
                   stamp=values.get("stamp") or "header",
                   typestore=values.get("bag_typestore") or DEFAULT_ROS2_STORE)


@dataclass
class ReplayStats:
    """What a replay read: messages per topic, and the messages rejected."""

    per_topic: Counter = field(default_factory=Counter)
    rejected: int = 0
    failed: int = 0
    seconds: float = 0.0

    @property
    def messages(self) -> int:
        return sum(self.per_topic.values())

    def summary(self, name: str) -> str:
        topics = ", ".join(f"{topic} {count:,}" for topic, count in sorted(self.per_topic.items()))
        rejected = f", {self.rejected:,} rejected" if self.rejected else ""
        rejected += f", {self.failed:,} failed" if self.failed else ""
        return (f"bag: {name}: {self.messages:,} messages in {self.seconds:.2f} s"
                f"{rejected}{': ' + topics if topics else ''}")


Event = Tuple[str, float]

class ReplayClock:
    """The clock that paces a replay with a rate: the wall clock (tests give their own)."""

    def now(self) -> float:
        return time.perf_counter()

    def sleep(self, seconds: float) -> None:
        time.sleep(seconds)


RATE_TICK = 0.01
"""With --rate, a message is fed at most this many seconds after it falls due (the default
of --tick). The replay sleeps until the first message not fed is this late and then feeds
every message due by then in one batch: the fewest wake-ups that keep every message within
this latency. Each wake-up costs CPU (the sleep itself, then the batch's work with caches
gone cold on a busy machine): a longer tick saves CPU at the cost of that latency."""


PACED_AHEAD = 0.25
"""With --rate on the wall clock, the replay reads this many seconds ahead of the clock and
hands what it read to the runtime in one call, which sleeps and feeds each message at most
--tick after it falls due (Engine.feed_paced); the call returns early when output is produced, so the
output is written as soon as it is produced. The latency is that of --tick. A longer pause
in the recording is waited out here, so that the runtime never sleeps much longer than
this (an interrupt is seen when the call returns)."""


def bag_events(bag: Recording, options: BagOptions, stats: ReplayStats,
               report: Callable[[str, int, str], None],
               converter: Optional[MessageConverter] = None,
               ros1_terms: Optional[Ros1Terms] = None, skip: int = 0,
               warn: Optional[Callable[[str], None]] = None) -> Iterator[Tuple[object, float, Record]]:
    """(event, time in seconds, record) for each message replayed, in record order: the
    event is its text, or, with `ros1_terms` on a ROS 1 recording, a `Ros1Bytes` the runtime
    reads itself (the record is then undecoded: `raw` holds its bytes; `message_event`
    converts it when the runtime refuses the bytes). Messages that cannot be decoded or
    converted go to `report(topic, number, reason)` and are counted in `stats.rejected`.
    The time is the run's one clock (EventClock: the time the message carries, else the
    recording's `/clock`, read even when not selected, else its arrival); a jump of that
    clock goes to `warn` (standard error). The first `skip` messages are counted, not
    converted (a replay going on from a snapshot, docs/recovery.md)."""
    converter = converter or MessageConverter(bag.typestore, options.convention)
    start_ns, stop_ns = window(bag, options)
    record_stamp = options.stamp == "record"
    clock = EventClock(warn or (lambda text: click.echo(text, err=True)), record=record_stamp)
    clock_topic = CLOCK_TOPIC if not record_stamp and CLOCK_TOPIC in bag.topics() else None
    selected = options.topics
    read = selected
    if selected is not None and clock_topic is not None and clock_topic not in selected:
        read = list(selected) + [clock_topic]
    number = 0
    raw = ros1_terms is not None and bag.format == "ros1"
    records = (bag.raw_records if raw else bag.records)(read, start_ns, stop_ns)
    for record in records:
        if record.topic == clock_topic:
            clock.clock(_clock_seconds(bag, record))
            if read is not selected:
                continue
        number += 1
        stats.per_topic[record.topic] += 1
        if number <= skip:
            continue
        where = f"{bag.path}:{record.topic}#{number}"
        if raw:
            fast = ros1_terms.event(record.raw, record.msgtype, record.topic, 0, record_stamp)
            if fast is not None:
                yield fast[0], clock.time(fast[1], record.time_ns, record.topic, where), record
                continue
        try:
            text, carried = message_event(bag, converter, record, record_stamp, arrival=False)
        except _Rejected as rejected:
            stats.rejected += 1
            report(record.topic, number, str(rejected))
            continue
        yield text, clock.time(carried, record.time_ns, record.topic, where), record


def _clock_seconds(bag: Recording, record: Record) -> float:
    """The time of a `/clock` message (0.0 when it cannot be read: not a Clock)."""
    if record.msg is None and record.raw is not None:
        record = bag.decode(record)
    stamp = getattr(record.msg, "clock", None)
    try:
        return (stamp.sec * 1_000_000_000 + stamp.nanosec) / 1_000_000_000
    except (AttributeError, TypeError):
        return 0.0


class _Rejected(Exception):
    """A message that cannot be decoded or converted; the text says why."""


def message_event(bag: Recording, converter: MessageConverter, record: Record,
                  record_stamp: bool = False, arrival: bool = True) -> Tuple[str, float]:
    """(event text, time in seconds) of a record (decoded first when it is raw): the time it
    carries, else (with `arrival`) its record time; `record_stamp`: its record time. Raises
    _Rejected saying why it cannot be decoded or converted."""
    if record.msg is None and record.raw is not None and record.error is None:
        record = bag.decode(record)
    if record.msg is None:
        raise _Rejected(record.error or "cannot decode")
    try:
        text, seconds = converter.event(record.msg, record.msgtype, record.topic,
                                        record.time_ns if arrival or record_stamp else 0)
    except (ConversionError, AttributeError, TypeError, ValueError) as error:
        raise _Rejected(f"cannot convert {record.msgtype}: {error}") from None
    if record_stamp:
        seconds = record.time_ns / 1_000_000_000
    return text, seconds


def feed_messages(engine, bag: Recording, converter: MessageConverter, record_stamp: bool, batch: list,
                  write: Callable, flush: Callable[[], None], stats: ReplayStats, dues: Optional[List[float]] = None,
                  tick: float = RATE_TICK) -> List[Problem]:
    """Feeds `batch`, a list of (event, seconds, (topic, number, record)), writing what it
    produces with `write` (feed.feed_resilient); returns the problems met (reported by the feed
    loop). With `dues` (the wall-clock time each message falls due), each message is fed at
    most `tick` after it is due (`Engine.feed_paced`) and the output is written and flushed as
    it is produced. A message whose processing fails is an `error` problem (`TOPIC#N`),
    counted in `stats.failed`, and the batch goes on after it; a message whose bytes the
    runtime refuses is converted as text instead (`message_event`), or is a `rejected` problem
    counted in `stats.rejected` when that fails too."""
    def retext(item) -> str:
        try:
            return message_event(bag, converter, item[2], record_stamp)[0]
        except _Rejected as refusal:
            raise ValueError(str(refusal)) from None

    def delivered(produced) -> None:
        write(produced)
        flush()

    problems, _ = feed_resilient(engine, batch, write, retext, lambda item: f"{item[0]}#{item[1]}", dues, tick,
                                 delivered, flush)
    stats.rejected += sum(1 for problem in problems if problem.kind == "rejected")
    stats.failed += sum(1 for problem in problems if problem.kind == "error")
    return problems


def window(bag: Recording, options: BagOptions) -> Tuple[Optional[int], Optional[int]]:
    """The record-time window [start, stop) in ns of --start and --duration."""
    start_ns = bag.start_ns + round(options.start * 1e9) if options.start else None
    stop_ns = None
    if options.duration is not None:
        stop_ns = (start_ns if start_ns is not None else bag.start_ns) + round(options.duration * 1e9)
    return start_ns, stop_ns


def open_recording(path: str, options: BagOptions) -> Optional[Recording]:
    """The recording at `path`, open (the caller closes it); None, with the reason on
    standard error, when it cannot be read."""
    try:
        return Recording(path, options.typestore).__enter__()
    except BagError as error:
        click.echo(f"error: {error}", err=True)
        return None


def replay_bag(engine, path: str, out: Optional[str] = "-", options: Optional[BagOptions] = None,
               batch_size: int = 2000, consumer_dir: Optional[str] = None, drop_pending: bool = False,
               first_output: Sequence = (), progress: Optional[bool] = None, out_bag: Optional[str] = None,
               foxglove: Optional[int] = None, foxglove_wait: Optional[float] = None,
               clock: Optional["ReplayClock"] = None, trace_report=None, recoverable=None) -> int:
    """Replay the recording at `path` into `engine`; write the output JSON Lines to `out`
    ('-' for stdout, None to drop it), as `run_event_file` does. A progress bar shows on a
    terminal (`progress` forces it on or off). `out_bag` writes the input messages and what
    the program derived to an MCAP file; `foxglove` serves them live on that port (0: any
    free port) after waiting up to `foxglove_wait` seconds (None: as long as it takes) for a
    client, replaying in real time unless the options give a rate (publish.py). Returns the
    exit status: 0; 1 when the engine fails outside a message; 2 when the recording cannot be
    read. A message whose processing raises an error is reported with its topic and number,
    counted as failed, and the replay goes on. `clock` paces a replay with a rate (default:
    the wall clock). `trace_report()`, if given, returns text printed on standard error before
    the detections per rule and the summary (the counts of `--trace`). Without `options`,
    strings are as the program says (Engine.ros_strings). A delivery to a subscription of a
    derived event is written once (feed.once_per_delivery). `recoverable` (recovery.py):
    (the output sink, a function of it giving the checkpoint, the messages already replayed).
    The loop is feed.FeedLoop with a `BagSource`."""

    options = options or BagOptions(convention=Convention.of_program(engine))    # the program's strings
    name = str(path)
    bag = open_recording(path, options)
    if bag is None:
        return 2
    text, consumers, targets = None, None, []
    try:
        publisher, targets = _open_sinks(bag, options, out_bag, foxglove, foxglove_wait)
        if recoverable is not None:
            main = recoverable[0]()
        else:
            text = sys.stdout if out == "-" else open(os.devnull if out is None else out, "w", encoding="utf-8")
            consumers = ConsumerFiles(consumer_dir) if consumer_dir else None
            main = TextSink(text, "standard output" if out == "-" else str(out), owned=text is not sys.stdout,
                            consumers=consumers, by_line=True)
    except BaseException:
        bag.__exit__(None, None, None)
        for target in targets:
            target.close()
        if text is not None and text is not sys.stdout:
            text.close()
        raise
    if foxglove is not None and options.rate is None:
        options = replace(options, rate=1.0)
    if options.topics:
        unknown = [t for t in options.topics if t not in bag.topics()]
        if unknown:
            click.echo(f"{name}: warning: no topic {', '.join(unknown)} in this recording "
                       f"(it has {', '.join(bag.topics())})", err=True)
    sinks = Sinks([main] + [_PublishedSink(publisher, target) for target in targets], once=True)
    source = BagSource(engine, bag, options, name, sinks, publisher, targets, batch_size,
                       clock=clock, skip=recoverable[2] if recoverable is not None else 0)
    show = progress if progress is not None else sys.stderr.isatty()
    display = _Bar(source, name) if show else None
    checkpoint = recoverable[1](main) if recoverable is not None else None
    loop = FeedLoop(engine, source, sinks, display=display, drop_pending=drop_pending, signals=False,
                    engine_errors=(PrologError,))
    return loop.run(first_output, checkpoint=checkpoint, report=trace_report)


class BagSource(EngineSource):
    """A recording's messages as a source of the feed loop: in record order, in batches of
    `batch_size` messages; with a rate, a batch is what falls due by a tick after its first
    message (the batches wait on `clock`), or, on the wall clock with nothing published, what
    falls due in the next PACED_AHEAD seconds, handed to the runtime to pace
    (`Engine.feed_paced`). The input messages go to the MCAP and Foxglove sinks as they are fed.
    A batch's position is the number of messages replayed after it (a checkpoint's input
    position); the first `skip` are passed over (a restart, recovery.py)."""

    def __init__(self, engine, bag: Recording, options: BagOptions, name: str, sinks: Sinks, publisher, targets,
                 batch_size: int, clock: Optional["ReplayClock"] = None, skip: int = 0):
        self.engine = engine
        self.bag = bag
        self.options = options
        self.name = name
        self.sinks = sinks
        self.publisher = publisher
        self.targets = targets
        self.batch_size = batch_size
        self.skip = skip
        self.stats = ReplayStats()
        self.problems: List[Problem] = []
        self.converter = MessageConverter(bag.typestore, options.convention)
        # ROS 1 messages go to the runtime as bytes (ros1_terms.py), unless the input
        # messages are also published (--out-bag, --foxglove: they need them decoded)
        self.ros1_terms = (Ros1Terms(engine, bag.typestore, options.convention)
                           if publisher is None and hasattr(engine, "ros1_schema") else None)
        # With a rate on the wall clock, and nothing to publish as each message falls due, the
        # runtime paces the messages itself (Engine.feed_paced): this source hands it what falls
        # due in the next PACED_AHEAD seconds in one batch, instead of sleeping and feeding once
        # per batch.
        self.paced = (options.rate is not None and clock is None and publisher is None
                      and hasattr(engine, "feed_paced"))
        self.clock = clock or ReplayClock()
        start_ns, stop_ns = window(bag, options)
        self.first_ns = start_ns if start_ns is not None else bag.start_ns
        self.last_ns = min(stop_ns, bag.end_ns) if stop_ns is not None else bag.end_ns
        self.done_ms = 0
        self.began = self.clock.now()

    def _report(self, topic: str, number: int, reason: str) -> None:
        self.problems.append(Problem(f"{topic}#{number}", "rejected", reason))

    @property
    def batches(self) -> Iterator[Batch]:
        options, clock, stats = self.options, self.clock, self.stats
        self.began = clock.now()
        began_wall = time.time()
        batch: List[Tuple[object, float, Tuple[str, int, Record]]] = []   # event, time, (topic, number, record)
        dues: List[float] = []
        deadline = 0.0                      # with a rate: when the batch's first message is a tick late

        def wait_for(deadline: float) -> None:
            wait = deadline - clock.now()
            if wait > 0:
                clock.sleep(wait)

        def ready(items, due_times=None) -> Batch:
            return Batch(items[0][2][1] if items else stats.messages, items, 0,
                         items[-1][2][1] if items else stats.messages, due_times)

        for text, seconds, record in bag_events(self.bag, options, stats, self._report, self.converter,
                                                self.ros1_terms, skip=self.skip):
            record_ns = record.time_ns
            if self.paced:
                due = began_wall + (record_ns - self.first_ns) / 1e9 / options.rate
                if batch and (due - time.time() > PACED_AHEAD or len(batch) >= self.batch_size):
                    yield ready(batch, dues)
                    batch, dues = [], []
                gap = due - time.time() - PACED_AHEAD
                if gap > 0:                 # a pause in the recording: waited here (Ctrl-C works)
                    clock.sleep(gap)
                dues.append(due)
            elif options.rate is not None:
                # the batch waits until its first message is a tick late and takes every
                # message due by then (the fewest wake-ups within that latency)
                due = self.began + (record_ns - self.first_ns) / 1e9 / options.rate
                if batch and due > deadline:
                    wait_for(deadline)
                    yield ready(batch)
                    batch = []
                if not batch:
                    deadline = due + options.tick
            batch.append((text, seconds, (record.topic, stats.messages, record)))
            self.done_ms = (record_ns - self.first_ns) // 1_000_000
            if len(batch) >= self.batch_size and not self.paced:
                if options.rate is not None:
                    wait_for(deadline)
                yield ready(batch)
                batch = []
        if batch:
            if options.rate is not None and not self.paced:
                wait_for(deadline)
            yield ready(batch, dues if self.paced else None)
        elif self.problems:
            yield ready([])

    def feed(self, engine, batch: Batch, write) -> Tuple[List[Problem], bool]:
        problems, self.problems = self.problems, []
        if not batch.lines:
            return problems, False
        if self.publisher is not None:               # the input messages as they are fed
            for _, seconds, (topic, _, record) in batch.lines:     # on the clock of the events
                message = self.publisher.input(topic, record.msgtype, round(seconds * 1e9), record.msg)
                for target in self.targets:
                    target.write(message)
            self.publisher.fed([(text, seconds) for text, seconds, _ in batch.lines])
        problems += feed_messages(engine, self.bag, self.converter, self.options.stamp == "record", batch.lines,
                                  write, self.sinks.flush, self.stats, batch.extra, self.options.tick)
        if self.options.rate is not None:
            self.sinks.flush()
        return problems, False

    def at_end(self, engine, write, drop_pending: bool, strict: bool) -> None:
        if self.publisher is not None:
            self.publisher.fed([])
        super().at_end(engine, write, drop_pending, strict)

    def closing_lines(self) -> List[str]:
        self.stats.seconds = self.clock.now() - self.began
        return [self.stats.summary(self.name)]

    def close(self) -> None:
        self.bag.__exit__(None, None, None)


class _PublishedSink(Sink):
    """The MCAP file or Foxglove server of a replay as a sink of the feed loop: each output as
    its message (Publisher.output; the input messages come from BagSource.feed)."""

    once = True

    def __init__(self, publisher, target):
        self.publisher = publisher
        self.target = target
        self.out_name = target.describe()

    def write(self, produced) -> None:
        for event in produced:
            message = self.publisher.output(event)
            if message is not None:
                self.target.write(message)

    def close(self) -> None:
        self.target.close()

    def closing_lines(self) -> List[str]:
        return [f"{self.target.describe()}: {self.target.count:,} messages"]


class _Bar:
    """The progress bar of a replay (the recording's time replayed), a display of the feed loop."""

    def __init__(self, source: BagSource, name: str):
        self.source = source
        self.bar = click.progressbar(length=max(1, (source.last_ns - source.first_ns) // 1_000_000),
                                     label=f"replaying {name}", file=sys.stderr).__enter__()
        self.shown_ms = 0

    def batch(self, batch: Batch, derived: int) -> None:
        done = self.source.done_ms
        if done > self.shown_ms:
            self.bar.update(done - self.shown_ms)
            self.shown_ms = done

    def clear(self) -> None:
        pass

    def close(self) -> None:
        self.bar.__exit__(None, None, None)


def replay_from_cli(engine, out: str, values: dict, **run_options) -> int:
    """`retalisc run PROGRAM --bag FILE ...`: `values` are the --bag options (options.py)."""
    try:
        return replay_bag(engine, values["bag"], out, BagOptions.from_cli(values, engine), out_bag=values.get("out_bag"),
                          foxglove=values.get("foxglove"), **run_options)
    except MissingDependency as error:
        click.echo(f"error: {error}", err=True)
        return 2
    except BrokenPipeError:
        raise                       # the reader of standard output went away: the CLI ends quietly
    except OSError as error:
        click.echo(f"error: {error}", err=True)
        return 2
    except KeyboardInterrupt:
        click.echo("interrupted", err=True)
        return 130


def _open_sinks(bag: Recording, options: BagOptions, out_bag: Optional[str], foxglove: Optional[int],
                foxglove_wait: Optional[float]):
    """The Publisher and the sinks of --out-bag and --foxglove (none: (None, []))."""
    if out_bag is None and foxglove is None:
        return None, []
    fallback = typestore("ros1_noetic" if bag.format == "ros1" else DEFAULT_ROS2_STORE)
    publisher = Publisher(bag.typestore, fallback, options.convention)
    sinks: list = []
    try:
        if out_bag is not None:
            sinks.append(McapSink(out_bag))
        if foxglove is not None:
            server = FoxgloveSink(foxglove)
            sinks.append(server)
            for topic, info in bag.topics().items():
                if options.topics is None or topic in options.topics:
                    server.advertise(publisher.advertisement(topic, info.msgtype))
            server.advertise(publisher.advertisement(EVENTS_TOPIC, None))
            click.echo(f"foxglove: waiting for a client on ws://{server.host}:{server.port} "
                       f"(Foxglove: Open connection, Foxglove WebSocket)", err=True)
            if not server.wait_for_client(foxglove_wait):
                click.echo("foxglove: no client came; replaying anyway", err=True)
    except BaseException:
        for target in sinks:
            target.close()
        raise
    return publisher, sinks
