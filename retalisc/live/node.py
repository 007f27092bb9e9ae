"""A Retalis program as a live component: messages in, deliveries out, services answered.

`LiveNode` is the part every transport (ROS 1, ROS 2 over DDS, Zenoh) shares. Transports
call `arrived(...)` from their own threads, as many as they use; each arrival goes into one
queue, in the order the calls are made, and one consumer thread takes them out, turns the
messages into events (robot_io/messages.py, the convention of `retalisc run --bag`; ROS 1
messages go to the runtime as their bytes, which it reads in C: robot_io/ros1_terms.py) and
feeds them to the Engine in batches (all that is waiting, up to `BATCH` events, in one
Prolog call; with `linger`, what arrives within that many seconds of the first message of a
batch joins it, which saves Prolog calls at the cost of that latency). The queue has no
bound: a burst is absorbed, never dropped.

With `heartbeat` (seconds), while no message arrives the program's clock follows the node's
clock: every `heartbeat` seconds of it (the transport's timer, `Transport.every`: ROS 2's
runs on rclpy's clock, /clock under use_sim_time; otherwise a thread on the wall clock), once
nothing has arrived for that long (and for `linger`, so that a heartbeat never cuts a batch
short), the consumer moves the clock to the time a message without a stamp would get now
(Engine.advance_clock), so that absences and alarms fire on time, as `retalisc run
--heartbeat` does on a live input. Heartbeats are not journaled: not with `state`.

Service requests (thesis A.1) go through the same queue (`call`): they run in the consumer
thread between two batches, so a subscription added after a message arrived does not see
it, and the caller waits for the reply. Every text a request carries is untrusted data: it
reaches Prolog only through the Engine's API (read with read_term, goals checked by the
sandbox); a refusal is an error reply (`Reply.ok` False), the node goes on.

Subscription deliveries (outputs with a consumer) are published: consumer `marker1` on topic
`/marker1`, as the message type the topic was given (pub_sub.xml `publish_to`, or the
add_output_subscription request), else the type named by the event's functor.

Every published message carries its output number: the position of its output in all the
outputs of the node (the line number of the --out file), counted from 1 and, with --state,
over restarts, so a message published again after a crash has the number it had before
(docs/recovery.md). Over ROS 1, a type whose first field is a std_msgs/Header has it in
`header.seq` (modulo 2^32; rospy itself fills that field with its own count); over Zenoh it is
the sample's attachment (8 bytes, unsigned little-endian); otherwise (ROS 2 over DDS, ROS 1
types without a header) it is published on the companion topic `<topic>/seq` as a
std_msgs/UInt64, right before the message (unless the middleware says that topic has no
subscriber: an extra message costs, over rospy, about as much as the message itself).

Time: one clock rule (robot_io/messages.py EventClock): an event is stamped with the time its
message carries (its `header.stamp`, a TFMessage's first transform's), else with the latest
`/clock` when the node subscribes to it, else with the node's clock at its arrival (the wall
clock, or the transport's, `Transport.now_ns`: ROS 2's /clock under use_sim_time; shifted onto
the messages' clock when they carry another one, sim time); a jump of more than an hour is a
warning on the log, once. A subscription or unsubscription at `now` (or with no time) means the
node clock's now. Events later than the delay bound void
the promise of arrival-order independence (a synchronized rule no longer waits for them), so
the node says so when it happens, not only in its summary: after a batch, at most once every
`LATE_CHECK_SECONDS`, and when it closes, a growing late count is a warning on the log (the
first `REPORTS_PER_TOPIC` times).
"""
from __future__ import annotations

import json
import queue
import re
import struct
import sys
import threading
import time
from collections import Counter
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import IO, Any, Callable, Dict, List, Optional, Tuple

from ..driver.values import read_term, write_term
from ..robot_io.messages import CLOCK_JUMP, CLOCK_TOPIC, ConversionError, Convention, EventClock, MessageConverter
from ..robot_io.ros1_terms import Ros1Terms
from ..robot_io.wire import MessageWriter
from .config import PubSubConfig, resolve_topic, ros1_type, store_type
from .state import STATEFUL_CALLS
from ..robot_io.bags import typestore
from ..driver.bridge import PrologError  # noqa: F401  (the name tests and callers use)
from ..driver.feed import (Batch, EngineSource, FeedLoop, NullSink, Problem, Sinks, beat, feed_resilient,
                           where_text)

BATCH = 2000
REPORTS_PER_TOPIC = 10       # rejected messages reported on stderr per topic; then only counted
CALL_TIMEOUT = 60.0
LATE_CHECK_SECONDS = 1.0     # how often the consumer asks the runtime for its late count
SEQ_SUFFIX = "/seq"          # the companion topic of the output numbers: `/out` -> `/out/seq`
SEQ_TYPE = "std_msgs/UInt64"
_HEADER = ("header", "std_msgs/msg/Header")
_CDR_LE = b"\x00\x01\x00\x00"      # the CDR encapsulation header (little endian)


@dataclass
class Reply:
    """The reply to a service request: `ok` False with `error` saying why, or the value."""

    ok: bool
    error: str = ""
    value: Any = None


@dataclass
class NodeStats:
    received: Counter = field(default_factory=Counter)
    rejected: Counter = field(default_factory=Counter)
    published: Counter = field(default_factory=Counter)
    unpublished: int = 0
    errors: int = 0
    calls: int = 0

    def summary(self, transport: str, services: bool = True) -> str:
        """The node's summary line; the count of service calls (requests a client made, not the
        node's own set-up) only for a transport that offers services."""
        topics = ", ".join(f"{t} {n:,}" for t, n in sorted(self.received.items()))
        out = ", ".join(f"{t} {n:,}" for t, n in sorted(self.published.items()))
        rejected = sum(self.rejected.values())
        return (f"{transport}: {sum(self.received.values()):,} messages in"
                f"{': ' + topics if topics else ''}; {rejected:,} rejected, {self.errors:,} errors; "
                f"{sum(self.published.values()):,} published{': ' + out if out else ''}"
                f"{f', {self.unpublished:,} not publishable' if self.unpublished else ''}"
                f"{f'; {self.calls:,} service calls' if services else ''}")


class Transport:
    """What a LiveNode needs from a middleware. `wire` is "ros1" (ROS 1 serialization) or "cdr"
    (ROS 2's CDR). All methods are called from the node's consumer thread."""

    wire = "cdr"
    name = "transport"
    offers_services = False  # the node's services are reachable over this middleware (ROS 1)
    attaches_seq = False     # publish(..., seq=N) carries the output number with the message itself
    # `flush` makes sure what was published is not lost with the process; when it cannot
    # (Zenoh), a node with --state keeps the outputs of the last moments in its snapshots and
    # publishes them again on restart (state.py, "the tail")
    flush_delivers = True

    def start(self, node: "LiveNode") -> None:
        raise NotImplementedError

    def subscribe(self, topic: str, msgtype: str) -> None:
        raise NotImplementedError

    def unsubscribe(self, topic: str) -> bool:
        raise NotImplementedError

    def advertise(self, topic: str, msgtype: str) -> None:
        """Announce a publisher of `topic` before its first message (so subscribers are
        connected when it comes)."""

    def publish(self, topic: str, msgtype: str, data: bytes) -> None:
        """Publish `data`; a transport with `attaches_seq` also takes `seq=N`, the output
        number, and sends it with the message."""
        raise NotImplementedError

    def recoverable(self) -> None:
        """The node keeps its state (--state): before its first publication. A transport that
        queues what it publishes in the process hands it to the operating system at once
        from now on, or in `flush`."""

    def flush(self, timeout: float) -> None:
        """Before a snapshot: what was published so far is handed over (to the operating
        system, or acknowledged by the subscribers), within `timeout` seconds; a snapshot
        then never counts an output that a crash would lose inside the process."""

    def now_ns(self) -> int:
        """The node's clock (ns since the epoch): what stamps a message with no header and what
        `now` means in a request. The wall clock, unless the middleware has a clock of its own
        (ROS 2's /clock with use_sim_time)."""
        return time.time_ns()

    def subscriber_count(self, topic: str) -> Optional[int]:
        """How many subscribers the publisher of `topic` reaches now (0 if not advertised);
        None: the middleware does not say."""
        return None

    def every(self, seconds: float, callback: Callable[[], None]) -> bool:
        """Call `callback()` every `seconds` of the node's clock (`now_ns`), from a thread of the
        middleware's, until `close`; False: the middleware has no timers of its own (the node
        then calls it from a thread of its own, on the wall clock)."""
        return False

    def close(self) -> None:
        pass


_STOP = object()


class _Arrivals(EngineSource):
    """A live node's queue as a source of the feed loop (feed.FeedLoop): its items are the
    messages, heartbeats, service requests and the stop (`LiveNode._arrivals`); a batch is fed
    by `LiveNode._feed`, its outputs leaving through `Engine.on_output` (published, and
    written to `out`). `batches`: a list of batches instead (a journal's replay). A live node
    runs until it is stopped: no end of the input, no halt at load, its summary the node's
    (commands/live.py)."""

    live = True

    def __init__(self, node: "LiveNode", until: Optional[float] = None, batches=None):
        self.node = node
        self.batches = node._arrivals(until) if batches is None else batches
        self.live = batches is None           # a replay: no collection set-up per journal record

    def feed(self, engine, batch: Batch, write) -> Tuple[List[Problem], bool]:
        return self.node._feed(batch.lines), False

    def problem_line(self, problem: Problem) -> Optional[str]:
        if problem.kind == "rejected":
            return where_text(problem.where, problem.kind, problem.text)
        return f"error: {problem.detail}"

    def at_start(self, engine) -> str:
        return ""

    def at_end(self, engine, write, drop_pending: bool, strict: bool) -> None:
        pass

    def release(self, engine) -> None:
        pass

    def summary(self, engine, seconds: float, log) -> None:
        pass


_NO_SINKS = Sinks([NullSink()])


class LiveNode:
    def __init__(self, engine, transport: Transport, config: Optional[PubSubConfig] = None,
                 convention: Optional[Convention] = None, out: Optional[IO[str]] = None,
                 log: Callable[[str], None] = lambda text: print(text, file=sys.stderr, flush=True),
                 linger: float = 0.0, state=None, heartbeat: Optional[float] = None):
        self.engine = engine
        self.transport = transport
        self.config = config or PubSubConfig()
        self.store = typestore("ros1_noetic" if transport.wire == "ros1" else "ros2_humble")
        convention = convention or Convention.of_program(engine)     # the program's strings
        self.converter = MessageConverter(self.store, convention)
        self.writer = MessageWriter(self.converter, "ros1" if transport.wire == "ros1" else "cdr")
        # messages go to the runtime as bytes, which it reads in C (ros1_terms.py; CDR too)
        self.ros1_terms = Ros1Terms(engine, self.store, convention, cdr=transport.wire == "cdr")
        self.clock = EventClock(log)             # the one clock rule (consumer thread only)
        self.out = out
        self.log = log
        self.stats = NodeStats()
        self.inputs: Dict[str, str] = {}           # topic -> ROS 1 type name
        self.output_types: Dict[str, str] = {}     # topic -> type given at runtime
        self._queue: "queue.SimpleQueue" = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._consume, name="retalis-consumer", daemon=True)
        self._owner: Optional[threading.Thread] = self._thread     # the thread that feeds the Engine
        self._here = False                 # start(here=True): the owner is the thread that started
        self._deliveries: List[Callable] = []      # extra observers of outputs (tests, benchmark)
        self.fed = 0
        self.linger = linger       # seconds to wait for more messages before feeding a batch
        if heartbeat is not None and state is not None:
            raise ValueError("a heartbeat does not go with a state directory (a replay would not see the same clock)")
        self.heartbeat = heartbeat          # seconds (the module's docstring) or None
        self._last_arrival = 0.0            # time.monotonic() of the last arrival
        self._beat_queued = False
        self._closed = threading.Event()
        self.state = state         # live/state.py LiveState (--state DIR) or None
        if state is not None:
            transport.recoverable()
        self.learned: Dict[str, str] = {}          # types learned from definitions -> the definition
        self.outputs = 0           # output lines produced (counted over restarts with --state)
        self._numbering: Dict[str, str] = {}       # type -> how its messages carry their number
        self.advertised: Dict[str, str] = {}       # output topic -> its type (companions included)
        self._replay_now: Optional[float] = None   # the wall clock of a replayed request
        self.late = 0              # the runtime's late count when it was last checked
        self._late_warnings = 0
        self._late_checked: Optional[float] = None    # time.monotonic() of the last check
        self._problems: List[Problem] = []         # to write with the next batch (FeedLoop)
        engine.on_output(self._output)

    # ---- life cycle ------------------------------------------------------------------------

    def start(self, here: bool = False) -> None:
        """Start taking messages. `here`: the calling thread is the consumer (and, with
        `Bridge.run_in_calling_thread`, the Prolog thread: no handoff per call); it then feeds
        what arrives in `run` and `close`. Otherwise a consumer thread of the node's own."""
        self.transport.start(self)
        if here:
            self._here, self._owner = True, threading.current_thread()
        if self.state is not None:     # restore and replay before the live input queued meanwhile
            self.state.recover(self)
        if not here:
            self._thread.start()
        for spec in self.config.subscribe:          # the node's own set-up: not service calls
            reply = self.call(self._add_input, spec.name, spec.msgtype, request=False)
            if not reply.ok:
                raise ValueError(reply.error)
        for spec in self.config.publish:
            self.call(self._advertise, spec.name, spec.msgtype, request=False)
        if self.heartbeat is not None and not self.transport.every(self.heartbeat, self._beat):
            threading.Thread(target=self._beating, name="retalis-heartbeat", daemon=True).start()

    def _beating(self) -> None:
        while not self._closed.wait(self.heartbeat):
            self._beat()

    def _beat(self) -> None:
        """A tick of the heartbeat (any thread): a heartbeat for the consumer, unless something
        arrived within the last `heartbeat` (and `linger`) seconds, or one is still queued."""
        if self._beat_queued or time.monotonic() - self._last_arrival < max(self.heartbeat, self.linger):
            return
        self._beat_queued = True
        self._queue.put((self._heartbeat, (), Future(), False))

    def _heartbeat(self) -> Reply:
        """Move the program's clock to the time the one clock rule (EventClock) gives a message
        without a stamp arriving now, if that is later; what the timers then raise is output."""
        self._beat_queued = False
        clock, now = self.clock, self.transport.now_ns() / 1e9
        if clock.clock_time is not None:           # the node reads /clock: its latest
            target = clock.clock_time
        elif clock.offset is not None and abs(clock.offset) > CLOCK_JUMP:
            target = now + clock.offset            # the messages carry another clock
        else:
            target = now
        if beat(self.engine, target, lambda produced: None):    # the output comes through _output
            if self.out is not None:
                self.out.flush()
        return Reply(True)

    def _advertise(self, topic: str, msgtype: str) -> Reply:
        if store_type(msgtype) not in self.store.fielddefs:
            return Reply(False, f"unknown message type {msgtype}")
        self.transport.advertise(topic, ros1_type(msgtype))
        self.advertised[topic] = ros1_type(msgtype)
        if self._numbered_by(store_type(msgtype)) == "topic":
            self.transport.advertise(topic + SEQ_SUFFIX, SEQ_TYPE)
            self.advertised[topic + SEQ_SUFFIX] = SEQ_TYPE
        return Reply(True)

    def _numbered_by(self, name: str) -> str:
        """How a message of type `name` carries its output number: "header" (ROS 1
        header.seq), "attachment" (the transport's), "topic" (the companion topic)."""
        how = self._numbering.get(name)
        if how is None:
            fields = self.store.fielddefs[name][1]
            if self.transport.wire == "ros1" and fields and (fields[0][0], fields[0][1][1]) == _HEADER:
                how = "header"
            else:
                how = "attachment" if self.transport.attaches_seq else "topic"
            self._numbering[name] = how
        return how

    def run(self, duration: Optional[float] = None) -> None:
        """Feed what arrives, in the thread that called `start(here=True)`, until `stop` (or
        `duration` seconds)."""
        self._consume(None if duration is None else time.monotonic() + duration)

    def stop(self) -> None:
        """End `run` (any thread, a signal handler too: SimpleQueue.put is reentrant)."""
        self._queue.put(_STOP)

    def close(self, timeout: float = 10.0) -> None:
        """Stop taking messages, process what is queued, close the transport."""
        self._closed.set()
        if self._here:
            self._queue.put(_STOP)
            self._consume()                 # what is queued, up to the stop
        elif self._thread.is_alive():
            self._queue.put(_STOP)
            self._thread.join(timeout)
        if self.out is not None:
            self.out.flush()
        done = self._here or not self._thread.is_alive()
        if done:
            self._check_late()
        if self.state is not None:      # no last snapshot while the consumer is still feeding
            self.state.close(self, snapshot=done)     # (with its subscriber counts)
        self.transport.close()

    # ---- recovery: what the state journal (live/state.py) restores and replays --------------
    # Called from LiveNode.start, before live input is taken (the consumer thread is not running).

    def restore_type(self, name: str, definition: str) -> None:
        """A message type learned before the snapshot (its full definition, ROS 1), known again."""
        if name not in self.store.fielddefs:
            self._learn_type(name, definition)
            self.learned[name] = definition

    def advertise(self, topic: str, msgtype: str) -> Reply:
        """Advertise `topic` (its message type) on the transport."""
        return self._advertise(topic, msgtype)

    def publish_again(self, topic: str, msgtype: str, data: bytes, how: str, seq: int) -> None:
        """Publish again a message published before the snapshot, with its output number."""
        self._send(topic, msgtype, data, how, seq)

    def subscribe_input(self, topic: str, msgtype: str) -> Reply:
        """Subscribe to an input topic again (as the add_input_subscription service does)."""
        return self._add_input(topic, msgtype)

    def feed_events(self, events: List[tuple]) -> None:
        """Feed `(event, time, arrival)` items in order (journaled first when the node keeps one),
        their outputs published."""
        self._loop(_Arrivals(self, batches=[Batch(0, events, 0)]))

    def replay_call(self, name: str, args, now: Optional[float]) -> Reply:
        """A stateful service request by name, replayed from the journal (`now`: the wall-clock
        time it first ran at)."""
        return self._replay_call(name, args, now)

    def message_event(self, topic: str, data: bytes, name: str, arrival_ns: int) -> Tuple[object, float]:
        """(event, time) of a message of type `name` that arrived on `topic` at `arrival_ns`: for
        ROS 1 its bytes (engine.Ros1Bytes) when the runtime reads them, else its text."""
        fast = self.ros1_terms.event(data, name, topic, arrival_ns) if self.ros1_terms else None
        if fast is not None:
            return fast[0], fast[1]
        return self._text_event(topic, data, name, arrival_ns)

    # ---- arrivals (any thread) ---------------------------------------------------------------

    def arrived(self, topic: str, data: bytes, msgtype: Optional[str] = None,
                definition: Optional[str] = None) -> None:
        """A message of `topic` arrived: its serialized bytes, the type its publisher gave
        (ROS 1 connection header; None: the subscribed type) and that type's full definition
        (ROS 1), for types the node does not know."""
        self._last_arrival = time.monotonic()
        self._queue.put((topic, data, msgtype, definition, self.transport.now_ns()))

    def call(self, function: Callable[..., Reply], *args, timeout: float = CALL_TIMEOUT,
             request: bool = True) -> Reply:
        """Run `function(*args)` in the consumer thread, after what arrived before; its Reply.
        Called from the consumer thread itself, it runs at once. `request`: a service request
        (counted in `stats.calls`), not the node's own set-up."""
        if threading.current_thread() is self._owner:
            return self._run_call(function, args, request)
        future: Future = Future()
        self._queue.put((function, args, future, request))
        try:
            return future.result(timeout)
        except Exception as error:          # a timeout: the node is overloaded or stopped
            return Reply(False, f"no reply: {type(error).__name__} {error}".strip())

    # ---- the consumer thread ------------------------------------------------------------------

    def _consume(self, until: Optional[float] = None) -> None:
        """Take what arrives and feed it, until a stop (or the time.monotonic() `until`): the
        feed loop (feed.FeedLoop) over the node's queue (`_Arrivals`)."""
        self._loop(_Arrivals(self, until=until))

    def _loop(self, source: "_Arrivals") -> None:
        FeedLoop(self.engine, source, _NO_SINKS, signals=False, say=self.log).run()

    def _arrivals(self, until: Optional[float]):
        """The batches of the queue: all that is waiting (with `linger`, what arrives within
        that many seconds of the first), at most BATCH events; a service request or a heartbeat
        runs between two batches, the batch before it fed first."""
        pending: List[tuple] = []           # (event, time, the arrival: for the text road)
        while True:
            idle = self.state.idle_timeout() if self.state is not None else None
            if until is not None:
                left = until - time.monotonic()
                if left <= 0:
                    return
                idle = left if idle is None else min(idle, left)
            try:
                item = self._queue.get() if idle is None else self._queue.get(timeout=idle)
            except queue.Empty:          # an idle node with --state: the time-based snapshot
                if self.state is not None:
                    self.state.idle(self)
                continue
            deadline = time.monotonic() + self.linger if self.linger else None
            stop = False
            while True:
                if item is _STOP:
                    stop = True
                elif len(item) == 4:
                    yield Batch(0, pending, 0)
                    pending = []
                    function, args, future, request = item
                    future.set_result(self._run_call(function, args, request))
                else:
                    event = self._event(*item)
                    if event is not None:
                        pending.append(event)
                        if len(pending) >= BATCH:
                            yield Batch(0, pending, 0)
                            pending = []
                if stop:
                    break
                try:
                    left = None if deadline is None else deadline - time.monotonic()
                    item = self._queue.get_nowait() if left is None or left <= 0 else self._queue.get(timeout=left)
                except queue.Empty:
                    break
            yield Batch(0, pending, 0)
            pending = []
            if stop:
                return

    def _run_call(self, function, args, request: bool = True) -> Reply:
        if request:
            self.stats.calls += 1
        name = getattr(function, "__name__", "")
        if self.state is not None and name in STATEFUL_CALLS:
            now = self._clock()
            self.state.call(name, args, now)     # journaled before it runs
            try:
                return self._replay_call(name, args, now)
            finally:
                self.state.fed(self, 0)
        try:
            return function(*args)
        except Exception as error:       # a request is data: whatever goes wrong is its reply
            return Reply(False, str(error) or type(error).__name__)

    def _event(self, topic: str, data: bytes, msgtype: Optional[str], definition: Optional[str],
               arrival_ns: int) -> Optional[tuple]:
        """(event, time, arrival) of a message: the event is its text, or, for ROS 1, its
        bytes (engine.Ros1Bytes) when its type has a schema; None when it is rejected."""
        subscribed = self.inputs.get(topic)
        if subscribed is None:           # unsubscribed meanwhile
            return None
        self.stats.received[topic] += 1
        number = self.stats.received[topic]
        try:
            if msgtype is not None and msgtype != "*" and ros1_type(msgtype) != subscribed:
                raise ConversionError(f"published as {msgtype}, subscribed as {subscribed}")
            name = store_type(subscribed)
            if name not in self.store.fielddefs:
                self._learn_type(name, definition)
            where = f"{topic}#{number}"
            if self.ros1_terms is not None and topic != CLOCK_TOPIC:
                fast = self.ros1_terms.event(data, name, topic, 0)
                if fast is not None:
                    return (fast[0], self.clock.time(fast[1], arrival_ns, topic, where),
                            (topic, number, data, name, arrival_ns))
            text, carried = self._text_event(topic, data, name, 0)
            return text, self.clock.time(carried, arrival_ns, topic, where), (topic, number, data, name, arrival_ns)
        except Exception as error:       # bytes from the network are data: report, skip
            self._reject(topic, number, error)
            return None

    def _text_event(self, topic: str, data: bytes, name: str, arrival_ns: int) -> Tuple[str, float]:
        """(text, the time the message carries, else `arrival_ns`); a /clock message sets the
        run's clock (EventClock)."""
        if self.transport.wire == "ros1":
            msg = self.store.deserialize_ros1(data, name)
        else:
            msg = self.store.deserialize_cdr(data, name)
        if topic == CLOCK_TOPIC and hasattr(getattr(msg, "clock", None), "nanosec"):
            self.clock.clock((msg.clock.sec * 1_000_000_000 + msg.clock.nanosec) / 1_000_000_000)
        return self.converter.event(msg, name, topic, arrival_ns)

    def _replay_call(self, name: str, args, now: Optional[float]) -> Reply:
        """A stateful service request by name (also one replayed from the journal, `now`
        meaning the wall-clock time it first ran at; None: the clock)."""
        if name not in STATEFUL_CALLS:
            return Reply(False, f"not a service request: {name}")
        self._replay_now = now
        try:
            return getattr(self, name)(*args)
        except Exception as error:
            return Reply(False, str(error) or type(error).__name__)
        finally:
            self._replay_now = None

    def _clock(self) -> float:
        return self.transport.now_ns() / 1e9

    def _now(self) -> float:
        return self._clock() if self._replay_now is None else self._replay_now

    def _reject(self, topic: str, number: int, error) -> None:
        """Count a rejected message; the first REPORTS_PER_TOPIC of a topic are problems the
        loop writes with the batch."""
        self.stats.rejected[topic] += 1
        if self.stats.rejected[topic] <= REPORTS_PER_TOPIC:
            self._problems.append(Problem(f"{topic}#{number}", "rejected", str(error)))

    def _learn_type(self, name: str, definition: Optional[str]) -> None:
        if not definition:
            raise ConversionError(f"unknown message type {ros1_type(name)} (its definition did not come with it)")
        from rosbags.typesys import get_types_from_msg      # optional: the `ros` extra

        types = {key: value for key, value in get_types_from_msg(definition, name).items()
                 if key not in self.store.fielddefs}
        self.store.register(types)
        self.learned[name] = definition

    def _feed(self, events: List[tuple]) -> List[Problem]:
        """Feed a batch; the problems the loop writes (the messages rejected since the last
        batch, then the batch's)."""
        if self.state is not None:
            self.state.events(events)       # journaled (flushed) before they are fed
        count = len(events)
        if events:          # the output comes through _output (Engine.on_output), in order

            def retext(item) -> str:
                topic, _, data, name, arrival_ns = item
                return self._text_event(topic, data, name, arrival_ns)[0]

            problems, fed = feed_resilient(self.engine, events, lambda produced: None, retext,
                                           lambda item: f"{item[0]}#{item[1]}", index_of=lambda error, size: size - 1)
            self.fed += fed
            for problem in problems:
                if problem.kind == "rejected":
                    self._reject(problem.item[0], problem.item[1], problem.text)
                else:
                    self.stats.errors += 1
                    self._problems.append(problem)
        if self.out is not None:
            self.out.flush()
        if count and (self._late_checked is None or time.monotonic() - self._late_checked >= LATE_CHECK_SECONDS):
            self._check_late()
        if self.state is not None and count:
            self.state.fed(self, count)
        problems, self._problems = self._problems, []
        return problems

    def _check_late(self) -> None:
        """Warn when events came later than the delay bound since the last check."""
        self._late_checked = time.monotonic()
        late = self.engine.stats().get("late", 0)
        if late > self.late:
            self._late_warnings += 1
            if self._late_warnings <= REPORTS_PER_TOPIC:
                self.log(f"warning: {late - self.late:,} events came more than the delay bound (max_delay) behind "
                         f"the clock ({self.engine.clock():.3f}), {late:,} in all: their results may depend on "
                         f"the arrival order; are the stamps on the node's clock? (docs/ros.md)")
            self.late = late

    def _output(self, event) -> None:
        self.outputs += 1
        if self.out is not None:
            self.out.write(event.line + "\n")
        if event.consumer is not None and event.op == "add":
            self._publish(resolve_topic(event.consumer), event)
        for observer in self._deliveries:
            observer(event)

    def _publish(self, topic: str, event) -> None:
        msgtype = self.output_types.get(topic) or self.config.publish_type(topic)
        try:
            term = event.term                   # the runtime's data: nothing is read again
            if msgtype is None:
                found = self.converter.message_type(term)
                if found is None:
                    raise ConversionError(f"{event.event[:80]} is not a message of a known type")
                name = found
            else:
                name = store_type(msgtype)
            data = self.writer.write(term, name)         # the term's data to bytes (robot_io/wire.py)
            self._send(topic, ros1_type(name), data, self._numbered_by(name), self.outputs)
            self.stats.published[topic] += 1
        except Exception as error:
            self.stats.unpublished += 1
            if self.stats.unpublished <= REPORTS_PER_TOPIC:
                self.log(f"{topic}: cannot publish {event.event[:120]}: {error}")

    def _send(self, topic: str, msgtype: str, data: bytes, how: str, seq: int) -> None:
        """Publish a message with its output number `seq` (see the module's docstring)."""
        if self.state is not None and not self.transport.flush_delivers:
            self.state.published(seq, topic, msgtype, data, how)
        if how == "header":          # ROS 1: header.seq is the first 4 bytes of the message
            self.transport.publish(topic, msgtype, struct.pack("<I", seq & 0xFFFFFFFF) + data[4:])
        elif how == "attachment":
            self.transport.publish(topic, msgtype, data, seq=seq)
        else:             # the companion topic; not when the middleware says no one takes it
            if self.transport.subscriber_count(topic + SEQ_SUFFIX) != 0:
                number = struct.pack("<Q", seq)
                self.transport.publish(topic + SEQ_SUFFIX, SEQ_TYPE,
                                       number if self.transport.wire == "ros1" else _CDR_LE + number)
            self.transport.publish(topic, msgtype, data)

    def message_definition(self, msgtype: str) -> Tuple[str, str]:
        """(full definition text, md5) of a type in ROS 1 form (for ROS 1 publishers)."""
        return self.store.generate_msgdef(store_type(msgtype), ros_version=1)

    # ---- the services of thesis A.1 (run in the consumer thread) ---------------------------------

    def add_output_subscription(self, topic: str, msg_type: str, event: str, conditions: str = "",
                                template: str = "", start: str = "", end: str = "") -> Reply:
        return self.call(self._add_output, topic, msg_type, event, conditions, template, start, end)

    def delete_output_subscription(self, subscription_id: str, end: str = "") -> Reply:
        return self.call(self._delete_output, subscription_id, end)

    def add_memory(self, request: str) -> Reply:
        return self.call(self._add_memory, request)

    def delete_memory(self, memory_id: str) -> Reply:
        return self.call(self._delete_memory, memory_id)

    def add_input_subscription(self, topic: str, msg_type: str) -> Reply:
        return self.call(self._add_input, topic, msg_type)

    def delete_input_subscription(self, topic: str) -> Reply:
        return self.call(self._delete_input, topic)

    def query(self, goal: str, at: str = "", all_answers: bool = False) -> Reply:
        return self.call(self._query, goal, at, all_answers)

    def _add_output(self, topic, msg_type, event, conditions, template, start, end) -> Reply:
        if not topic.strip():
            return Reply(False, "a subscription needs a topic")
        resolved = resolve_topic(topic)
        msgtype = ros1_type(msg_type) if msg_type.strip() else None
        if msgtype is not None:
            store_name = store_type(msgtype)
            if store_name not in self.store.fielddefs:
                return Reply(False, f"unknown message type {msgtype}")
        subscription_id = self.engine.subscribe(
            topic.strip(), event,
            template if template.strip() else None, conditions if conditions.strip() else "[]",
            _bound(start, "-inf", self._now), _bound(end, "inf", self._now))
        if msgtype is not None:
            self.output_types[resolved] = msgtype
        known = msgtype or self.config.publish_type(resolved)
        if known is not None:
            self._advertise(resolved, known)
        return Reply(True, value=subscription_id)

    def _delete_output(self, subscription_id: str, end: str) -> Reply:
        self.engine.unsubscribe(subscription_id, _bound(end, "now", self._now))
        return Reply(True)

    def _add_memory(self, request: str) -> Reply:
        if not re.match(r"\s*(c_mem|memorize)\s*\(", request):
            return Reply(False, "add_memory takes c_mem(Id, Event-Conds, N, L) or memorize(Event, Conds, Template, Id, N)")
        self.engine.memory(request)
        return Reply(True)

    def _delete_memory(self, memory_id: str) -> Reply:
        try:
            term = read_term(memory_id.strip())
        except ValueError as error:
            return Reply(False, f"a memory id is a ground term: {error}")
        self.engine.memory(f"d_mem({write_term(term)})")    # re-written from the parsed term
        return Reply(True)

    def _add_input(self, topic: str, msg_type: str) -> Reply:
        if not topic.strip():
            return Reply(False, "an input subscription needs a topic")
        resolved = resolve_topic(topic)
        msgtype = ros1_type(msg_type)
        if self.inputs.get(resolved) == msgtype:
            return Reply(True)
        if resolved in self.inputs:
            return Reply(False, f"already subscribed to {resolved} as {self.inputs[resolved]}")
        self.inputs[resolved] = msgtype
        try:
            self.transport.subscribe(resolved, msgtype)
        except Exception:
            del self.inputs[resolved]
            raise
        return Reply(True)

    def _delete_input(self, topic: str) -> Reply:
        resolved = resolve_topic(topic)
        if self.inputs.pop(resolved, None) is None:
            return Reply(False, f"not subscribed to {resolved}")
        self.transport.unsubscribe(resolved)
        return Reply(True)

    def _query(self, goal: str, at: str, all_answers: bool) -> Reply:
        at_value = _time_value(at, self._now)
        if all_answers:
            return Reply(True, value=self.engine.query_all(goal, at_value))
        answer = self.engine.query(goal, at_value)
        return Reply(True, value=answer)


def _time_value(text: str, now: Callable[[], float] = time.time) -> Optional[float]:
    text = text.strip()
    if text in ("", "inf"):
        return None
    if text == "now":
        return now()
    return float(text)


def _bound(text: str, default: str, now: Callable[[], float] = time.time):
    """A time bound of a request: seconds, `now` (the wall clock), `inf`, `-inf`, or the default."""
    text = (text or "").strip() or default
    if text == "now":
        return now()
    if text in ("inf", "-inf"):
        return text
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"a time is a number of seconds, now, inf or -inf, not {text!r}") from None
    if value != value:
        raise ValueError("a time is not NaN")
    return value


def reply_json(reply: Reply) -> str:
    return json.dumps({"ok": reply.ok, "error": reply.error, "value": reply.value})
