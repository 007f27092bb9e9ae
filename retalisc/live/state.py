"""`--state DIR` for the live nodes (`retalisc ros`, `ros2`, `zenoh`; docs/recovery.md).

The node's input cannot be read again: every event it feeds (its text and time, or for ROS 1
the message's bytes, type, topic and arrival time, from which the event is made again the
same way) and every service request that changes the state (with the wall-clock time it ran
at, which `now` means in it) is appended to the journal segment of the newest snapshot
(recovery.EventJournal, one JSON object a line) and flushed before it is processed.
Snapshots (recovery.StateDir: the engine's state, the node's subscriptions, the types it
learned, the output counts) are taken when the node starts, every N events or S seconds
(checked between two batches, and, when nothing arrives, S seconds after the last snapshot
if anything was journaled since: an idle node does not keep a long journal) and when it
stops. Started again with the same DIR, the node
restores the newest complete snapshot, replays the journal after it and then takes live
input. The --out file is cut back to the snapshot's length, so it ends as that of a run that
never stopped over the same input; what leaves the process (published topics) is
at-least-once: what was produced after the snapshot is published again, with the output
number it had (node.py), so a subscriber drops the repeats. The output topics are advertised
before the replay, so subscribers can connect before it publishes.

A snapshot never counts as published an output that a crash loses inside the process: ROS 1
publishes synchronously and DDS waits for the readers' acknowledgements before it (the
transport's `flush`). Zenoh offers no such wait, so for a transport whose `flush` does not
deliver, the node keeps "the tail": the messages it published during the last TAIL_SECONDS
(at most TAIL_MESSAGES of them; output number, topic, type, bytes, wall-clock time; the
attachment is made again from the number), a snapshot stores it, and a restart publishes it
again, with the same numbers, before it replays the journal. This assumes the middleware
delivers a message within TAIL_SECONDS of its publication.
"""
from __future__ import annotations

import base64
import json
import time
from collections import deque
from pathlib import Path
from typing import Callable, Optional, Union

from ..driver.recovery import (DEFAULT_SNAPSHOT_EVENTS, DEFAULT_SNAPSHOT_SECONDS, EventJournal, StateDir,
                               open_output, restore_newest, take_snapshot)
from ..driver.recovery import RecoveryError
from ..driver.engine import Ros1Bytes
from ..driver.bridge import PrologError

RECONNECT_SECONDS = 2.0     # how long a restart waits for the subscribers of its outputs
FLUSH_SECONDS = 1.0         # how long a snapshot waits for what was published to be handed over
TAIL_SECONDS = 1.0          # without such a wait: the last seconds of publications a snapshot keeps
TAIL_MESSAGES = 4096        # and at most that many of them

# the service requests that change the state: journaled and replayed
STATEFUL_CALLS = ("_add_output", "_delete_output", "_add_memory", "_delete_memory", "_add_input", "_delete_input")


class _TextSink:
    """The node writes text; the recoverable output file is binary (positions are bytes)."""

    def __init__(self, raw):
        self.raw = raw

    def write(self, text: str) -> None:
        self.raw.write(text.encode("utf-8"))

    def flush(self) -> None:
        self.raw.flush()

    def close(self) -> None:
        self.raw.close()


class _NoOutput:
    """The output position of a node without --out: always 0."""

    def flush(self) -> None:
        pass

    def fileno(self) -> int:
        raise OSError("no output file")

    def tell(self) -> int:
        return 0


class LiveState:
    def __init__(self, directory: Union[str, Path], out: Optional[str] = None,
                 snapshot_events: int = DEFAULT_SNAPSHOT_EVENTS,
                 snapshot_seconds: float = DEFAULT_SNAPSHOT_SECONDS,
                 log: Callable[[str], None] = print, reconnect_seconds: float = RECONNECT_SECONDS):
        self.directory = StateDir(directory)
        self.out_path = out
        self.snapshot_events = snapshot_events
        self.snapshot_seconds = snapshot_seconds
        self.reconnect_seconds = reconnect_seconds
        self.log = log
        self.journal = EventJournal(self.directory)
        self.raw = None
        self.replaying = False
        self.since_events, self.since_time = 0, time.monotonic()
        self.journaled = False           # anything journaled since the last snapshot
        self.restored = None
        self.replayed = (0, 0)           # events, service requests
        self.ready = False               # recovered: snapshots may be written
        # (wall time, output number, topic, type, bytes, how numbered) of the last publications
        self.tail: deque = deque(maxlen=TAIL_MESSAGES)
        self.republished = 0             # messages of the restored tail published again

    # ---- start: restore and replay (called by LiveNode.start before live input is taken) -------

    def recover(self, node) -> None:
        self.directory.lock()                   # until close (or the end of the process)
        restored = restore_newest(self.directory, node.engine, "live", node.transport.name, _LogStream(self.log))
        if self.out_path is not None:
            self.raw = open_output(self.out_path, restored)
            node.out = _TextSink(self.raw)
        self.restored = restored
        if restored is None:
            for _, path in self.journal.segments():        # of a run that never took its first snapshot
                path.unlink(missing_ok=True)
            self.ready = True
            self.snapshot(node)
            return
        saved = restored.get("node")
        if not isinstance(saved, dict):
            raise RecoveryError(f"{self.directory.directory}: snapshot {restored['number']} is not one of a live node")
        for name, definition in saved.get("learned", {}).items():
            node.restore_type(name, definition)
        node.output_types.update(saved.get("output_types", {}))
        for topic, msgtype in node.output_types.items():
            node.advertise(topic, msgtype)
        for spec in node.config.publish:         # before the replay publishes on them
            if spec.name not in node.output_types:
                node.advertise(spec.name, spec.msgtype)
        tail = saved.get("tail", [])
        if tail or any(path.stat().st_size for number, path in self.journal.segments()
                       if number >= restored["number"]):
            self._wait_for_subscribers(node, saved.get("subscribers", {}))
        for seq, topic, msgtype, data, how in tail:       # what the middleware may have lost
            node.publish_again(topic, msgtype, base64.b64decode(data), how, seq)
        self.republished = len(tail)
        for topic, msgtype in saved.get("inputs", {}).items():
            reply = node.subscribe_input(topic, msgtype)
            if not reply.ok:
                self.log(f"retalisc: {topic}: cannot subscribe again: {reply.error}")
        node.outputs = saved.get("outputs", 0)
        first_output = node.outputs
        self.replaying = True
        events, calls = 0, 0
        try:
            pending = []
            for line in self.journal.replay(restored["number"]):
                try:
                    record = json.loads(line)
                except ValueError:
                    continue
                if "c" in record:
                    node.feed_events(pending)
                    pending = []
                    node.replay_call(record["c"], record["a"], record["now"])
                    calls += 1
                else:
                    event = self._event(node, record)
                    if event is not None:
                        pending.append(event)
                        events += 1
            node.feed_events(pending)
        finally:
            self.replaying = False
        self.replayed = (events, calls)
        self.ready = True
        self.journal.open(restored["number"])
        tail_note = (f"; published again the {len(tail)} messages of the last {TAIL_SECONDS:g} s before the "
                     f"snapshot (outputs {tail[0][0]} to {tail[-1][0]})" if tail else "")
        again = (f"; outputs {first_output + 1} to {node.outputs} of the run were produced (and published) again, "
                 f"with the same output numbers: "
                 f"live outputs are at-least-once" if node.outputs > first_output else "")
        self.log(f"retalisc: restored snapshot {restored['number']} of {self.directory.directory} and replayed "
                 f"{events} journaled events and {calls} service requests{tail_note}{again}")

    def _wait_for_subscribers(self, node, counts: dict) -> None:
        """Before the replay publishes again: wait (at most `reconnect_seconds`) until every
        output topic reaches as many subscribers as it did at the snapshot, so that those that
        outlived the crash get what the replay publishes."""
        deadline = time.monotonic() + self.reconnect_seconds
        while True:
            missing = [topic for topic, count in counts.items()
                       if (node.transport.subscriber_count(topic) or 0) < count]
            if not missing or time.monotonic() >= deadline:
                break
            time.sleep(0.02)
        if missing:
            self.log(f"retalisc: {', '.join(sorted(missing))}: fewer subscribers than at the snapshot after "
                     f"{self.reconnect_seconds:g} s; the replay publishes without them")

    def _event(self, node, record: dict):
        if "r" in record:                 # a ROS 1 message fed as its bytes: made again as it was
            data = base64.b64decode(record["r"])
            arrival = (record["p"], 0, data, record["n"], record["ns"])
            event, seconds = node.message_event(record["p"], data, record["n"], record["ns"])
            return event, seconds, arrival
        return record["e"], record["t"], None

    # ---- while live (the consumer thread) --------------------------------------------------

    def published(self, seq: int, topic: str, msgtype: str, data: bytes, how: str) -> None:
        """A message was published over a transport whose `flush` does not deliver: kept in
        the tail (the messages of the last TAIL_SECONDS, at most TAIL_MESSAGES)."""
        now = time.time()
        self.tail.append((now, seq, topic, msgtype, data, how))
        while self.tail and self.tail[0][0] < now - TAIL_SECONDS:
            self.tail.popleft()

    def _tail_records(self) -> list:
        since = time.time() - TAIL_SECONDS
        return [[seq, topic, msgtype, base64.b64encode(data).decode("ascii"), how]
                for at, seq, topic, msgtype, data, how in self.tail if at >= since]

    def events(self, events) -> None:
        """Journal events about to be fed: (event, seconds, arrival)."""
        if self.replaying or not events:
            return
        lines = []
        for event, seconds, arrival in events:
            if isinstance(event, Ros1Bytes):
                topic, _, data, name, arrival_ns = arrival
                lines.append(json.dumps({"r": base64.b64encode(data).decode("ascii"), "n": name, "p": topic,
                                         "ns": arrival_ns}))
            else:
                lines.append(json.dumps({"e": event, "t": seconds}))
        self.journal.append([line.encode("ascii") for line in lines])      # (json.dumps writes ASCII)
        self.journaled = True

    def call(self, name: str, args, now: float) -> None:
        if not self.replaying:
            self.journal.append([json.dumps({"c": name, "a": list(args), "now": now}).encode("ascii")])
            self.journaled = True

    def idle_timeout(self) -> Optional[float]:
        """How long the consumer may wait for input before the time-based snapshot is due;
        None: no snapshot is due however long it waits (nothing journaled since the last)."""
        if not self.ready or not self.journaled or self.snapshot_seconds == float("inf"):
            return None
        return max(0.0, self.since_time + self.snapshot_seconds - time.monotonic())

    def idle(self, node) -> None:
        """Nothing arrived for a while: the time-based snapshot, if it is due."""
        if self.ready and not self.replaying and self.journaled and \
                time.monotonic() - self.since_time >= self.snapshot_seconds:
            self.snapshot(node)

    def fed(self, node, count: int) -> None:
        """After a batch: a snapshot when N events or S seconds have passed since the last."""
        if self.replaying or not self.ready:
            return
        self.since_events += count
        if self.since_events >= self.snapshot_events or time.monotonic() - self.since_time >= self.snapshot_seconds:
            self.snapshot(node)

    def snapshot(self, node) -> None:
        node.transport.flush(FLUSH_SECONDS)        # no output counted that a crash loses in the process
        self.journal.sync()
        manifest = {"live": node.transport.name,
                    "node": {"inputs": dict(node.inputs), "output_types": dict(node.output_types),
                             "learned": dict(node.learned), "outputs": node.outputs,
                             "subscribers": _subscribers(node), "tail": self._tail_records()}}
        sink = self.raw if self.raw is not None else _NoOutput()
        if self.raw is None:
            manifest["out_bytes"] = 0
        written = _snapshot(self.directory, node.engine, sink, manifest, _LogStream(self.log))
        if written is not None:
            self.journal.open(written["number"])         # what is fed from now on
            self.journal.prune(self.directory)
        self.since_events, self.since_time = 0, time.monotonic()
        self.journaled = False

    def close(self, node, snapshot: bool = True) -> None:
        """A clean stop: a last snapshot (not when the start failed), files closed."""
        if self.ready and snapshot:
            self.snapshot(node)
        self.journal.close()
        if self.raw is not None:
            self.raw.close()
        self.directory.unlock()


def _subscribers(node) -> dict:
    """topic -> how many subscribers its publisher reaches now (those the middleware counts)."""
    counts = {}
    for topic in node.advertised:
        try:
            count = node.transport.subscriber_count(topic)
        except Exception:           # a middleware that cannot say now: no wait for it on restart
            count = None
        if count:
            counts[topic] = count
    return counts


def _snapshot(directory, engine, sink, manifest, log):
    if isinstance(sink, _NoOutput):
        try:
            return directory.save(engine, manifest)
        except (OSError, PrologError) as error:
            print(f"retalisc: warning: the snapshot could not be written ({error}); the node goes on, "
                  f"the previous snapshot stays the one a restart uses", file=log)
            return None
    return take_snapshot(directory, engine, sink, manifest, log)


class _LogStream:
    """A file-like front of the node's log function (recovery.py prints to a stream)."""

    def __init__(self, log: Callable[[str], None]):
        self.log = log

    def write(self, text: str) -> None:
        if text.strip():
            self.log(text.rstrip("\n"))

    def flush(self) -> None:
        pass
