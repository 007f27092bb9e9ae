"""The one feed loop of the Python roads: a source of batches, the loop that feeds them to the
Engine, the sinks that take what it produces (docs/architecture.md, "The event road").

- A **source** (`LineSource` over an event file, a pipe or standard input, with or without a
  heartbeat; `robot_io/replay.py`'s recording source; the journal of a recoverable standard
  input, `recovery.py`) yields `Batch`es and feeds one to the Engine, returning the problems it
  met (`Problem`: a rejected line or message, an error, a warning) and whether the run must stop
  (a halt called by program code, `--strict`).
- The **loop** (`FeedLoop.run`) is the only place that reports: the problems as
  `NAME:WHERE: KIND: TEXT` (`problem_text`), the progress display, strict and halt, the stop
  signals, the end of the input (the postponed matches), a full output, and the closing lines
  (the source's own line, the sinks', `report`, the detections and the summary,
  `summary_line`, timed from the start of the loop on every road).
- A **sink** (`TextSink`: standard output or `--out`, consumer files; `BinarySink`: a recoverable
  output file that can be cut back; `robot_io/replay.py`'s MCAP and Foxglove sinks) takes the
  Engine's output objects (`OutputEvent`) as they are produced, through `Sinks.write`.
- Crash recovery (`recovery.Recovery`) wraps any source and sink: `FeedLoop.run(checkpoint=...)`
  calls it when the run starts and after every batch; its checkpoint is the source's position,
  the sink's position and the Engine's snapshot.

On the roads that only Python has (a recording's replay, `retalisc run --bag`, with or without
`--state`) a delivery to a subscription (an `OutputEvent` with `consumer`) of an event the program
also writes as derived is printed once in JSON Lines and written once to MCAP and Foxglove: as
the delivery, the line with `consumer` (`once_per_delivery`). The Engine's API (`feed_*`,
`on_output`) and the runtime's own output (`swipl OUT.pl`, the hand-over, the event-file roads
that must print what it prints) keep both lines, as the 2015 release did (docs/runtime.md,
"Output"); so does a live node's `--out` (its outputs come one at a time through `on_output`),
whose topics carry only the deliveries anyway.
"""
from __future__ import annotations

import errno
import gc
import io
import itertools
import math
import os
import queue
import select
import sys
import threading
import time
from typing import IO, Callable, Iterable, Iterator, List, NamedTuple, Optional, Sequence, Tuple

from .bridge import PrologError
from .event_lines import batch_payload, read_lines, split_lines, too_long_line
from .outputs import ConsumerFiles, detections_line
from .signals import SignalStop, SignalStops

PROGRESS_THRESHOLD = 5_000_000     # bytes of input before a progress display is worth it


# ---- the text of a run: made here only ------------------------------------------------------

def problem_text(name: str, where, kind: str, text: str) -> str:
    """`NAME:WHERE: KIND: TEXT`: a line not processed (`rejected`: malformed; `error`: a refused
    control line, an event whose processing raised) or a `warning`, WHERE its line number or
    `TOPIC#N` (the N-th message replayed)."""
    return f"{name}:{where}: {kind}: {text}"


def where_text(where, kind: str, text: str) -> str:
    """`WHERE: KIND: TEXT`, a problem of a live node (whose input has no name): `TOPIC#N`."""
    return f"{where}: {kind}: {text}"


def rejection_kind(kind: str) -> str:
    """The word of a runtime rejection kind (`rejected`, `error`, `halt`) in its message."""
    return "rejected" if kind == "rejected" else "error"


def summary_line(stats: dict, seconds: float) -> str:
    """`retalis: N events in, M derived, K rejected, T s` (as rtl_summary/2 in
    prolog_runtime/rtl_feed.pl), with failed, retracted, too-late deletions and late events
    before the time when there are any."""
    labels = (("failed", "failed"), ("retracted", "retracted"), ("too_late", "too late to retract"),
              ("late", "late"), ("timers_refused", "timers not set (max_timers)"))
    extra = "".join(f", {stats[name]:,} {label}" for name, label in labels if stats.get(name))
    return (f"retalis: {stats.get('events', 0):,} events in, {stats.get('derived', 0):,} derived, "
            f"{stats.get('rejected', 0):,} rejected{extra}, {seconds:.2f} s")


def print_summary(engine, seconds: float, summary: Optional[str] = None, log: Optional[IO[str]] = None) -> None:
    """The end of a run on standard error: the detections per rule (`detections_line`), then
    the one-line summary (`summary`, or `summary_line` of the engine's counters)."""
    log = log or sys.stderr
    line = detections_line(engine.detections())
    if line:
        print(line, file=log)
    print(summary if summary is not None else summary_line(engine.stats(), seconds), file=log)


def cannot_write_text(out_name: str, error: OSError) -> str:
    return f"retalis: cannot write {out_name}: {error.strerror}"


def engine_error_text(name: str, error) -> str:
    """`NAME: error: ERROR`: the Engine failed outside any one line or message."""
    return f"{name}: error: {error}"


class Problem(NamedTuple):
    """What a source met feeding a batch: `where` (line number or `TOPIC#N`), `kind`
    (`rejected`, `error`, `warning`) and the text."""
    where: object
    kind: str
    text: str
    order: float = 0          # problems are reported in this order (the line number)
    item: object = None       # what the source keeps of the message (feed_resilient)
    detail: str = ""          # an error's whole text


def rejection_problems(rejected, warnings=()) -> List[Problem]:
    """The Problems of `Engine.feed_lines`' rejections and `Engine.take_warnings`' warnings, in
    line order."""
    found = [Problem(r.line, rejection_kind(r.kind), r.reason, r.line) for r in rejected]
    found += [Problem(w.line, "warning", w.text, w.line) for w in warnings]
    return sorted(found, key=lambda p: p.order)


class RunStopped(Exception):
    """The run ended early: `--strict` met a bad line, or program code called halt. The
    message, if any, goes to standard error; `status` is the exit status (1)."""

    def __init__(self, message: str = "", status: int = 1):
        super().__init__(message)
        self.message = message
        self.status = status


def beat(engine, target: float, write) -> bool:
    """A heartbeat: move the program's clock to `target` if that is later and `write` what its
    timers then raise; whether the clock moved (a live source with nothing arrived, the live
    nodes' --heartbeat)."""
    if target <= engine.clock():
        return False
    write(engine.advance_clock(target))
    return True


def end_the_input(engine, write, drop_pending: bool, strict: bool) -> None:
    """Run (or, with `drop_pending`, drop) the matches postponed to the end of the input and
    `write` what they produce. RunStopped when program code called halt in one of them, or,
    with `strict`, when one of them failed."""
    failed = engine.stats().get("failed", 0)
    write(engine.end_of_input(drop_pending))
    if engine.end_stopped():
        raise RunStopped()
    if strict and engine.stats().get("failed", 0) > failed:
        raise RunStopped()


def halted_at_load(engine) -> str:
    """The message of a halt program code called while the program loaded ("" if none): the
    run then ends at once, status 1."""
    return engine.take_halted()


#: The errors of writing to a file system that is full (or a file grown to its limit): the
#: run ends with `retalis: cannot write OUT: REASON`, the summary and status 1.
OUTPUT_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def output_full(error: OSError) -> OSError:
    """`error`, when it says that the output is full; raised again otherwise."""
    if error.errno not in OUTPUT_FULL:
        raise error
    return error


def settle_output(step, full: Optional[OSError]) -> Optional[OSError]:
    """Run `step` (a flush or close of the output); once the output is full, its error
    (then that of the run) is kept instead of raised."""
    try:
        step()
    except OSError as error:
        return full or output_full(error)
    return full


# ---- sources ---------------------------------------------------------------------------------

class Batch(NamedTuple):
    """A batch of a source: the number of its first line (0: a heartbeat, nothing arrived),
    its items (lines as bytes without their newlines, or a recording's messages), the bytes
    read for it, and the source's position after it (for a checkpoint)."""
    first: int
    lines: list
    size: int
    position: int = 0
    extra: object = None      # what a source keeps with a batch (a recording's due times)


def file_batches(stream: IO[bytes], batch_size: int, limit: Optional[int] = None, offset: int = 0,
                 first_line: int = 1) -> Iterator[Batch]:
    """The batches of a file read as bytes from `offset` (its line `first_line`): the lines
    without their newlines (`event_lines.batch_payload` makes them the runtime's text), each
    at most `limit` bytes long (`event_lines.read_lines`), the position the byte offset after
    the batch."""
    first, position = first_line, offset
    if limit is None and offset == 0:
        while True:
            batch = list(itertools.islice(stream, batch_size))
            if not batch:
                return
            data = b"".join(batch)
            position += len(data)
            yield Batch(first, split_lines(data), len(data), position)
            first += len(batch)
    if offset:
        stream.seek(offset)
    lines = read_lines(stream, limit)
    while True:
        read = list(itertools.islice(lines, batch_size))
        if not read:
            return
        size = sum(taken for _, taken in read)
        position += size
        yield Batch(first, [line for line, _ in read], size, position)
        first += len(read)


def live_batches(fd: int, batch_size: int, limit: Optional[int] = None, first_line: int = 1) -> Iterator[Batch]:
    """The batches of a live input: the complete lines that have arrived, as soon as they are
    there. A blocking read returns everything that is waiting, so a batch holds more than one
    line only while input was already waiting (at most `batch_size` lines). No `select` per
    line: only lines left over from a batch that was full wait for a look at what has arrived
    since. A line longer than `limit` bytes is `too_long_line(limit)`: of its bytes, those
    after the first `limit` + 1 are dropped as they arrive."""
    chunk_size = 1 << 16
    pending = b""
    skipping = False                        # in a line too long, dropping it to its newline
    lines: List[bytes] = []
    first = first_line
    at_end = unterminated = False
    while True:
        while not at_end and len(lines) < batch_size:
            if lines and not select.select([fd], [], [], 0)[0]:
                break
            chunk = os.read(fd, chunk_size)
            if skipping and chunk:
                newline = chunk.find(b"\n")
                if newline < 0:
                    continue
                lines.append(too_long_line(limit))
                chunk, skipping = chunk[newline + 1:], False
                if not chunk:
                    continue
            if not chunk:
                at_end = True
                if skipping:
                    lines.append(too_long_line(limit))
                    skipping, unterminated = False, True
                elif pending:               # a last line without a newline
                    lines.append(pending)
                    pending, unterminated = b"", True
            elif b"\n" in chunk:
                *complete, pending = (pending + chunk).split(b"\n")
                if limit is not None:
                    complete = [line if len(line) <= limit else too_long_line(limit) for line in complete]
                lines += complete
                if limit is not None and len(pending) > limit:
                    pending, skipping = b"", True
                if len(chunk) < chunk_size:
                    break                   # the read took all that was waiting
            else:
                pending += chunk
                if limit is not None and len(pending) > limit:
                    pending, skipping = b"", True
        if not lines:
            return
        part, lines = lines[:batch_size], lines[batch_size:]
        size = sum(len(line) for line in part) + len(part) - (1 if unterminated and not lines else 0)
        yield Batch(first, part, size)
        first += len(part)


def heartbeat_batches(stream: IO[bytes], batch_size: int, heartbeat: float, limit: Optional[int] = None
                      ) -> Iterator[Batch]:
    """As `file_batches`, for a live source: a batch is what has arrived when the reader
    catches up (not `batch_size` lines), and a batch with no lines (first line number 0)
    comes every `heartbeat` seconds while nothing arrives. A thread reads the lines."""
    lines: "queue.Queue[Optional[Tuple[bytes, int]]]" = queue.Queue()

    def read():
        try:
            for line in read_lines(stream, limit):
                lines.put(line)
        finally:
            lines.put(None)

    threading.Thread(target=read, name="retalisc-live-reader", daemon=True).start()
    number, ended = 1, False
    while not ended:
        try:
            item = lines.get(timeout=heartbeat)
        except queue.Empty:
            yield Batch(0, [], 0)
            continue
        batch: List[bytes] = []
        size = 0
        while True:
            if item is None:
                ended = True
                break
            batch.append(item[0])
            size += item[1]
            if len(batch) >= batch_size:
                break
            try:
                item = lines.get_nowait()
            except queue.Empty:
                break
        if batch:
            yield Batch(number, batch, size)
            number += len(batch)


class WallClock:
    """The event time a live source has reached while no event arrives: the clock at the
    latest event that moved it, plus the wall-clock time since (the stamps are taken to
    follow the wall clock; an event lagging more than the delay bound behind is late)."""

    def __init__(self, now=time.monotonic):
        self.now = now
        self.anchor: Optional[Tuple[float, float]] = None

    def saw(self, clock: float) -> None:
        if math.isfinite(clock) and (self.anchor is None or clock > self.anchor[0]):
            self.anchor = (clock, self.now())

    def estimate(self) -> Optional[float]:
        if self.anchor is None:
            return None
        clock, wall = self.anchor
        return clock + (self.now() - wall)


class EngineSource:
    """What the loop does with the Engine around a source's batches (every source of an Engine
    inherits this; a source of another kind, `ScriptSource`'s update script of active queries,
    has its own)."""

    name = ""
    live = False

    def at_start(self, engine) -> str:
        """The message that ends the run before its first batch ("": none): a halt called by
        program code while the program loaded."""
        return halted_at_load(engine)

    def at_end(self, engine, write, drop_pending: bool, strict: bool) -> None:
        end_the_input(engine, write, drop_pending, strict)

    def release(self, engine) -> None:
        engine.close_action_output()

    def closing_lines(self) -> List[str]:
        """The source's own lines before the summary."""
        return []

    def problem_line(self, problem: Problem) -> Optional[str]:
        """The line the loop writes for `problem` (None: counted only, not written)."""
        return problem_text(self.name, problem.where, problem.kind, problem.text)

    def summary(self, engine, seconds: float, log) -> None:
        print_summary(engine, seconds, log=log)

    def close(self) -> None:
        pass


class LineSource(EngineSource):
    """Event lines (an event file, a pipe, standard input, the journal of a recoverable run)
    fed with `Engine.feed_lines`: `batches` yields `Batch`es of lines; with `heartbeat`, a
    batch without lines moves the clock with the wall clock (`WallClock`), so absences and
    alarms fire on time. `live`: the output of each batch leaves at once. `owned`: a stream
    the run opened for the batches, closed with the source."""

    def __init__(self, name: str, batches: Iterable[Batch], allow_control: bool = False, strict: bool = False,
                 heartbeat: bool = False, live: bool = False, total: Optional[int] = None,
                 owned: Optional[IO] = None):
        self.name = name
        self.batches = batches
        self.owned = owned                  # a stream the run opened: closed with the source
        self.allow_control = allow_control
        self.strict = strict
        self.heartbeat = heartbeat
        self.live = live or heartbeat
        self.total = total
        self.wall = WallClock()

    def close(self) -> None:
        if self.owned is not None:
            self.owned.close()

    def feed(self, engine, batch: Batch, write) -> Tuple[List[Problem], bool]:
        """Feed `batch`, `write` what it produces; (the problems, whether the run stops)."""
        if not batch.lines:                     # a heartbeat: nothing arrived
            target = self.wall.estimate()
            if target is not None:
                beat(engine, target, write)
            return [], False
        produced, rejected = engine.feed_lines(batch_payload(batch.lines), batch.first,
                                               allow_control=self.allow_control, strict=self.strict)
        write(produced)
        if self.heartbeat:
            self.wall.saw(engine.clock())
        stop = bool(rejected) and (self.strict or rejected[-1].kind == "halt")
        return rejection_problems(rejected, engine.take_warnings()), stop


SCRIPT_BATCH = 100        # update-script commands run per call into the runtime


class ScriptSource:
    """An update script of active queries (`retalisc aq --script`, with or without `--state`)
    as a source of the feed loop: a batch is at most `batch_size` commands run by
    `ActiveQueries.run_script_batch` from the script line reached (`line`); its output is the
    notifications' JSON Lines as `retalisc aq` prints them, written as text. A bad line or a
    failed command ends the run with its message, the script named `display_name` in it
    (status 2 or 1); there is no Engine around it (no halt at load, no end of input, no
    summary)."""

    live = False

    def __init__(self, path: str, display_name: str, line: int = 1, batch_size: int = SCRIPT_BATCH):
        self.name = display_name
        self.path = path
        self.line = line
        self.batch_size = batch_size
        self.done = False

    @property
    def batches(self):
        while not self.done:
            yield Batch(self.line, [None] * self.batch_size, 0)

    def feed(self, aq, batch: Batch, write) -> Tuple[List[Problem], bool]:
        ran = aq.run_script_batch(self.path, self.line, self.batch_size)
        write(ran.output)
        if ran.status == "error":
            raise RunStopped(ran.message.replace(self.path, self.name), ran.exit_status)
        self.line = ran.next_line
        self.done = ran.status == "done"
        return [], False

    def at_start(self, aq) -> str:
        return ""

    def at_end(self, aq, write, drop_pending: bool, strict: bool) -> None:
        pass

    def release(self, aq) -> None:
        pass

    def closing_lines(self) -> List[str]:
        return []

    def problem_line(self, problem: Problem) -> Optional[str]:
        return problem_text(self.name, problem.where, problem.kind, problem.text)

    def summary(self, aq, seconds: float, log) -> None:
        pass

    def close(self) -> None:
        pass


def feed_resilient(engine, items: list, write, retext, where, dues: Optional[List[float]] = None,
                   tick: float = 0.01, delivered=None, flush=None, index_of=None) -> Tuple[List[Problem], int]:
    """Feed `items`, (event, seconds, item) each, with `Engine.feed_batch` (or, with `dues`, the
    wall-clock time each falls due, `Engine.feed_paced`, `delivered` getting each output as it
    is produced) and `write` what they produce; an event the runtime fails on does not stop the
    rest (a recording's source, the live nodes). Of a `PrologError` at the batch's N-th event
    (`batch_index`, or `refused_index` for a bad item; `index_of(error)` when it has neither, else it is raised): the output before
    it is written; an event whose bytes the runtime refused (`undecodable`) goes again as the
    text `retext(item)` gives, or is a `rejected` problem when that raises (`ValueError` or
    any error of the conversion: its text is the reason); another error is an `error` problem.
    `where(item)` places a problem (`TOPIC#N`). Returns (the problems, the events processed:
    the rejected ones not counted)."""
    problems: List[Problem] = []
    fed = 0
    while items:
        try:
            if dues is None:
                write(engine.feed_batch([(event, seconds) for event, seconds, _ in items]))
            else:
                write(engine.feed_paced([(event, seconds) for event, seconds, _ in items], dues, tick, delivered))
                if flush is not None:
                    flush()
            return problems, fed + len(items)
        except PrologError as error:
            index = getattr(error, "batch_index", None)
            if index is None:
                index = getattr(error, "refused_index", None)   # a bad item: none processed
            if index is None:
                if index_of is None:
                    raise
                index = index_of(error, len(items))
            write(getattr(error, "delivered", None) or [])
            _, seconds, item = items[index]
            rest = items[index + 1:]
            if dues is not None:
                dues = dues[index:]             # the event's own due time, then the rest's
            fed += index
            if getattr(error, "undecodable", False):      # the runtime refused the bytes
                try:
                    text = retext(item)
                except Exception as refusal:     # noqa: BLE001  (a message is data: any failure is its reason)
                    problems.append(Problem(where(item), "rejected", str(refusal), item=item))
                    items = rest
                    dues = dues[1:] if dues is not None else None
                else:
                    items = [(text, seconds, item)] + rest      # the time the run's clock gave it
                continue
            problems.append(Problem(where(item), "error", str(error).split(": ", 1)[-1], item=item, detail=str(error)))
            fed += 1
            items = rest
            dues = dues[1:] if dues is not None else None
    return problems, fed


# ---- sinks -----------------------------------------------------------------------------------

def once_per_delivery(produced: Sequence) -> list:
    """`produced` without the derived events that a subscription delivery right after them
    repeats (the same event, times and operation, with `consumer`): a delivery is one line,
    the one with `consumer` (docs/runtime.md, "Output"). The derived event is still counted
    and the API's callbacks still get both."""
    kept = []
    for index, event in enumerate(produced):
        if event.consumer is None and _delivered_next(produced, index):
            continue
        kept.append(event)
    return kept


def _delivered_next(produced: Sequence, index: int) -> bool:
    event = produced[index]
    for later in itertools.islice(produced, index + 1, None):
        if later.consumer is None:
            return False
        if (later.event, later.start, later.end, later.op) == (event.event, event.start, event.end, event.op):
            return True
    return False


class Sink:
    """What the loop asks of a sink; a sink overrides what it does. `write(produced)` takes a
    batch's output events; `write_text` text the loop itself writes (JSON Lines sinks only);
    `once`: a delivery repeating its derived event is written once (`once_per_delivery`)."""

    once = False
    out_name = "the output"

    def write(self, produced) -> None:
        raise NotImplementedError

    def write_text(self, text: str) -> None:
        pass

    def go_live(self) -> None:
        """From now on each batch's output leaves at once."""

    def flush(self) -> None:
        pass

    def close(self) -> None:
        pass

    def closing_lines(self) -> List[str]:
        """The sink's own lines before the summary."""
        return []


class NullSink(Sink):
    """A sink that takes nothing: the outputs leave elsewhere (a live node's, one at a time
    through `Engine.on_output`)."""

    def write(self, produced) -> None:
        pass


class TextSink(Sink):
    """JSON Lines to a text stream (standard output or `--out`); with `consumers`, the
    subscription deliveries go to one file per consumer instead (`ConsumerFiles`). A batch's
    lines are written in one call, or, with `by_line`, one call each (a recording's replay:
    its reader going away is then seen at the next buffer's worth)."""

    def __init__(self, stream: IO[str], out_name: str, owned: bool, consumers: Optional[ConsumerFiles] = None,
                 by_line: bool = False):
        self.by_line = by_line
        self.stream = stream
        self.out_name = out_name
        self.owned = owned
        self.consumers = consumers
        self.once = consumers is None         # with consumer files, the deliveries are elsewhere
        self.emit = stream.write

    def write_text(self, text: str) -> None:
        self.emit(text)

    def write(self, produced) -> None:
        lines = []
        for event in produced:
            if self.consumers is not None and event.consumer is not None:
                self.consumers.write(event)
            elif self.by_line:
                self.emit(event.line + "\n")
            else:
                lines.append(event.line)
        if lines:
            lines.append("")
            self.emit("\n".join(lines))

    def go_live(self) -> None:
        """From now on each batch's output leaves in one write, with no buffer to flush."""
        self.stream.flush()
        self.emit = _unbuffered(self.stream)

    def flush(self) -> None:
        self.stream.flush()

    def close(self) -> None:
        if self.owned:
            self.stream.close()
        if self.consumers is not None:
            self.consumers.close()


class BinarySink(Sink):
    """JSON Lines to a file opened for binary writing whose position (`tell`) a checkpoint
    records and a restart cuts the file back to (recovery.py)."""

    once = True

    def __init__(self, stream: IO[bytes], out_name: str):
        self.stream = stream
        self.out_name = out_name

    def write(self, produced) -> None:
        for event in produced:
            self.stream.write(event.line.encode("utf-8") + b"\n")

    def write_text(self, text: str) -> None:
        self.stream.write(text.encode("utf-8"))

    def tell(self) -> int:
        return self.stream.tell()

    def sync(self) -> None:
        self.stream.flush()
        os.fsync(self.stream.fileno())

    def flush(self) -> None:
        self.stream.flush()

    def close(self) -> None:
        self.stream.close()


class Sinks:
    """The sinks of one run; the first is the JSON Lines output (its position is the one a
    checkpoint keeps). Each batch's output goes to every sink; with `once`, once per delivery
    (`once_per_delivery`: the roads with no runtime-side twin, a recording's replay); without, as the runtime writes it (the event-file roads, whose output is that of
    `swipl OUT.pl` and the hand-over)."""

    def __init__(self, sinks: Sequence, once: bool = False):
        self.sinks = list(sinks)
        self.main = self.sinks[0]
        self.once = once

    def write(self, produced) -> None:
        """Write a batch's OutputEvents (or, from a source that makes its own lines, text)."""
        if not produced:
            return
        if isinstance(produced, str):
            for sink in self.sinks:
                sink.write_text(produced)
            return
        once = once_per_delivery(produced) if self.once else produced
        for sink in self.sinks:
            sink.write(once if sink.once else produced)

    def flush(self) -> None:
        for sink in self.sinks:
            sink.flush()


def _unbuffered(sink: IO[str]):
    """A function writing text to `sink` at once: straight to its file descriptor (one system
    call, no buffer to flush) when it has one, else written and flushed."""
    fd = fileno(sink)
    if fd is None:
        def write_and_flush(text: str) -> None:
            sink.write(text)
            sink.flush()
        return write_and_flush

    def write_fd(text: str) -> None:
        data = text.encode("utf-8")
        while data:
            data = data[os.write(fd, data):]
    return write_fd


def fileno(source) -> Optional[int]:
    """The file descriptor under a text stream (standard input's buffer, or an open file), or
    None when there is none (a stream in memory)."""
    try:
        return source.buffer.fileno() if hasattr(source, "buffer") else source.fileno()
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return None


def quiet_collector():
    """Keep Python's cyclic garbage collector from pausing a live run to walk the objects that
    exist when it starts (the compiler's, click's, the loaded program's: gc.freeze moves them
    out of its reach), so that a full collection during the run takes microseconds, not tens
    of milliseconds. Each event's own objects are freed by reference counting. Returns what
    undoes this."""
    gc.collect()
    gc.freeze()
    return gc.unfreeze


# ---- the loop --------------------------------------------------------------------------------

class FeedLoop:
    """Feeds one source's batches to `engine`, each batch's output to `sinks`, and reports
    (module docstring), its lines on `log` (standard error) or through `say`. `display`: the progress display (`Progress`, or a source's own: update,
    clear, close). `signals`: the stop signals end the run between batches (SignalStops);
    without, a KeyboardInterrupt goes to the caller. `engine_errors`: an Engine error outside
    any line (PrologError) ends the run with `NAME: error: ERROR` and status 1 instead of
    propagating."""

    def __init__(self, engine, source, sinks: Sinks, display=None, drop_pending: bool = False,
                 strict: bool = False, signals: bool = True, engine_errors: Tuple[type, ...] = (),
                 log: Optional[IO[str]] = None, say: Optional[Callable[[str], None]] = None):
        self.engine = engine
        self.source = source
        self.sinks = sinks
        self.display = display
        self.drop_pending = drop_pending
        self.strict = strict
        self.signals = signals
        self.engine_errors = engine_errors
        self.log = log
        self.say = say

    def _say(self, text: str) -> None:
        if self.say is not None:
            self.say(text)
        else:
            print(text, file=self.log or sys.stderr)

    def run(self, first_output: Sequence = (), checkpoint=None, report: Optional[Callable[[], str]] = None,
            runtime_loop: Optional[Callable[[SignalStops], None]] = None) -> int:
        """Run to the end of the source (or a stop); returns the exit status. `first_output`:
        outputs (lists of OutputEvents) produced before the events, written first.
        `checkpoint` (recovery.Recovery): `begin(first)` when the loop starts (`first`: whether
        this is the run's first start, not a restart), `after(batch)` after each batch is
        written. `report()` gives text printed before the detections and the summary (the
        counts of `--trace`). `runtime_loop(stops)`: the runtime reads and writes the input
        itself (run.py, the runtime's own loop): called instead of the batches; it raises
        RunStopped, SignalStop or OSError as the loop would."""
        started = time.perf_counter()
        engine, source, sinks = self.engine, self.source, self.sinks
        display = self.display
        derived = [0]                   # of the batch: the derived events written (not the deliveries)

        def write(produced) -> None:
            if not isinstance(produced, str):
                derived[0] += sum(1 for event in produced if event.consumer is None)
            sinks.write(produced)

        stops = SignalStops()
        status, full, frozen = 0, None, None
        try:
            if self.signals:
                stops.install()
            first = checkpoint is None or checkpoint.restored is None
            if first:
                halted = source.at_start(engine)
                if halted:
                    raise RunStopped(halted)
            if first:
                for produced in first_output:
                    write(produced)
            if checkpoint is not None:
                checkpoint.begin(first)
            if getattr(source, "live", False) and runtime_loop is None:
                for sink in sinks.sinks:
                    sink.go_live()
                frozen = quiet_collector()          # no collection pause of the objects made so far
            if runtime_loop is not None:
                sinks.flush()
                runtime_loop(stops)
                batches: Iterable[Batch] = ()
            else:
                batches = source.batches
            for batch in batches:
                derived[0] = 0
                stops.batch_starts()                # a stop signal ends the run after the batch
                problems, stop = source.feed(engine, batch, write)
                if problems:
                    sinks.flush()
                    if display is not None:
                        display.clear()
                for problem in problems:
                    line = source.problem_line(problem)
                    if line is not None:
                        self._say(line)
                if display is not None:
                    display.batch(batch, derived[0])
                if getattr(source, "live", False):
                    sinks.flush()
                if stop:
                    raise RunStopped()
                if checkpoint is not None:
                    checkpoint.after(batch)
                stops.batch_ends()
            stops.batch_starts()
            source.at_end(engine, write, self.drop_pending, self.strict)
        except RunStopped as stopped:
            if stopped.message:
                sinks.flush()
                self._say(stopped.message)
            status = stopped.status
        except SignalStop:
            pass
        except OSError as error:
            full, status = output_full(error), 1
        except self.engine_errors as error:
            full = settle_output(sinks.flush, full)
            self._say(engine_error_text(source.name, error))
            status = 1
        finally:
            stops.finishing()
            if frozen is not None:
                frozen()
            if display is not None:
                display.close()
            for sink in sinks.sinks:
                full = settle_output(sink.flush, full)
            source.close()
            for sink in sinks.sinks:
                full = settle_output(sink.close, full)
            if checkpoint is not None:
                checkpoint.close()
            source.release(engine)
        for line in source.closing_lines():
            self._say(line)
        for sink in sinks.sinks:
            for line in sink.closing_lines():
                self._say(line)
        text = report() if report is not None else ""
        if text:
            self._say(text)
        if full is not None:
            self._say(cannot_write_text(sinks.main.out_name, full))
        source.summary(engine, time.perf_counter() - started, self.log)
        stops.restore()
        return stops.status(status)


class Progress:
    """A one-line progress display on a terminal: bytes read (with a bar and percentage when
    the size is known), events, events per second, derived events. `enabled` None: shown
    when `stream` is a terminal and the input is (or, from a pipe, has grown) over
    `threshold` bytes; True: always; False: never. Redrawn at most every `interval` s."""

    def __init__(self, stream: IO[str], total: Optional[int], enabled: Optional[bool] = None,
                 threshold: int = PROGRESS_THRESHOLD, interval: float = 0.2):
        self.stream = stream
        self.total = total
        self.enabled = enabled
        self.threshold = threshold
        self.interval = interval
        self.read = self.events = self.derived = 0
        self.started = time.perf_counter()
        self.drawn_at = -1.0
        self.shown = False
        self.width = 0
        isatty = getattr(stream, "isatty", None)
        self.terminal = bool(isatty and isatty())

    def _active(self) -> bool:
        if self.enabled is not None:
            return self.enabled
        if not self.terminal:
            return False
        size = self.total if self.total is not None else self.read
        return size > self.threshold

    def batch(self, batch: Batch, derived: int) -> None:
        """Count a batch fed and the derived events it produced."""
        self.update(batch.size, len(batch.lines), derived)

    def update(self, read: int, events: int, derived: int) -> None:
        self.read += read
        self.events += events
        self.derived += derived
        now = time.perf_counter()
        if self._active() and now - self.drawn_at >= self.interval:
            self._draw(now)

    def _draw(self, now: float) -> None:
        elapsed = max(now - self.started, 1e-9)
        parts = []
        if self.total:
            fraction = min(self.read / self.total, 1.0)
            filled = int(fraction * 20)
            parts.append(f"[{'#' * filled}{'.' * (20 - filled)}] {fraction:4.0%}")
            parts.append(f"{self.read / 1e6:.1f}/{self.total / 1e6:.1f} MB")
        else:
            parts.append(f"{self.read / 1e6:.1f} MB")
        parts.append(f"{self.events:,} events")
        parts.append(f"{self.events / elapsed:,.0f} events/s")
        parts.append(f"{self.derived:,} derived")
        text = "  ".join(parts)
        self.stream.write("\r" + text.ljust(self.width))
        self.stream.flush()
        self.width = len(text)
        self.drawn_at = now
        self.shown = True

    def clear(self) -> None:
        """Take the display line away (before other messages are written)."""
        if self.shown:
            self.stream.write("\r" + " " * self.width + "\r")
            self.stream.flush()
            self.drawn_at = -1.0

    def close(self) -> None:
        """Draw the final state and end the line."""
        if self._active() and (self.shown or self.enabled):
            self._draw(time.perf_counter())
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
