"""Running a program over an event JSON Lines file through the Python driver: the same
output and the same rejection messages as `swipl PROGRAM.pl FILE`."""
from __future__ import annotations

import errno
import gc
import io
import itertools
import math
import os
import queue
import select
import stat
import sys
import threading
import time
from typing import IO, Iterator, List, Optional, Sequence, Tuple

from .engine import Engine
from .event_lines import batch_payload, max_line_bytes, read_lines, split_lines, too_long_line
from .outputs import ConsumerFiles, detections_line
from .signals import SignalStop, SignalStops

PROGRESS_THRESHOLD = 5_000_000     # bytes of input before a progress display is worth it


def _batches(stream: IO[bytes], batch_size: int, limit: Optional[int] = None
             ) -> Iterator[Tuple[int, List[bytes], int]]:
    """(first line number, lines, bytes read) per batch of a file read as bytes; the lines
    without their newlines (`event_lines.batch_payload` makes them the runtime's text), each
    at most `limit` bytes long (`event_lines.read_lines`)."""
    first = 1
    if limit is None:
        while True:
            batch = list(itertools.islice(stream, batch_size))
            if not batch:
                return
            data = b"".join(batch)
            yield first, split_lines(data), len(data)
            first += len(batch)
    lines = read_lines(stream, limit)
    while True:
        read = list(itertools.islice(lines, batch_size))
        if not read:
            return
        yield first, [line for line, _ in read], sum(size for _, size in read)
        first += len(read)


def _is_live(events: str, source: IO[str]) -> bool:
    """Whether `events` is a live input (standard input, a pipe, a socket, a terminal) rather
    than a regular file: its lines are processed as they arrive."""
    if events == "-":
        return True
    try:
        mode = os.stat(events).st_mode
    except OSError:
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode) or stat.S_ISCHR(mode)


def _live_batches(fd: int, batch_size: int, limit: Optional[int] = None) -> Iterator[Tuple[int, List[bytes], int]]:
    """(first line number, lines, bytes read) per batch of a live input: the complete lines
    that have arrived, as soon as they are there. A blocking read returns everything that
    is waiting, so a batch holds more than one line only while input was already waiting (at
    most `batch_size` lines). No `select` per line: only lines left over from a batch that
    was full wait for a look at what has arrived since. A line longer than `limit` bytes is
    `too_long_line(limit)`: of its bytes, those after the first `limit` + 1 are dropped as
    they arrive."""
    chunk_size = 1 << 16
    pending = b""
    skipping = False                        # in a line too long, dropping it to its newline
    lines: List[bytes] = []
    first = 1
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
        yield first, part, size
        first += len(part)


def _heartbeat_batches(stream: IO[bytes], batch_size: int, heartbeat: float, limit: Optional[int] = None
                       ) -> Iterator[Tuple[int, List[bytes], int]]:
    """As `_batches`, for a live source: a batch is what has arrived when the reader catches
    up (not `batch_size` lines), and a batch with no lines (first line number 0) comes every
    `heartbeat` seconds while nothing arrives. A thread reads the lines."""
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
            yield 0, [], 0
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
            yield number, batch, size
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


class RunStopped(Exception):
    """The run ended early: `--strict` met a bad line, or program code called halt."""


def end_the_input(engine: Engine, write, drop_pending: bool, strict: bool) -> None:
    """Run (or, with `drop_pending`, drop) the matches postponed to the end of the input and
    `write` what they produce. RunStopped when program code called halt in one of them, or,
    with `strict`, when one of them failed."""
    failed = engine.stats().get("failed", 0)
    write(engine.end_of_input(drop_pending))
    if engine.end_stopped():
        raise RunStopped()
    if strict and engine.stats().get("failed", 0) > failed:
        raise RunStopped()


def run_event_file(engine: Engine, events: str, out: Optional[str] = "-", batch_size: int = 2000,
                   consumer_dir: Optional[str] = None, drop_pending: bool = False,
                   first_output: Sequence = (), allow_control: bool = False, strict: bool = False,
                   progress: Optional[bool] = None, heartbeat: Optional[float] = None, report=None,
                   stdin_in_prolog: bool = False) -> int:
    """Feed every line of `events` ('-' for stdin) to `engine`; write the output JSON Lines to
    `out` ('-' for stdout, None to drop it). Lines not processed go to stderr as
    `FILE:LINE: rejected: REASON` (malformed) or `FILE:LINE: error: REASON` (a refused control
    line, an event whose processing raised), warnings (deletions outside the retraction
    horizon) as `FILE:LINE: warning: TEXT`; a one-line summary closes the run. At the end
    of the input the postponed synchronized matches run (or are dropped with `drop_pending`).
    `first_output` holds outputs (lists of OutputEvents) produced before the events, written
    first. With `consumer_dir`, subscription deliveries go to `consumer_dir/<consumer>.jsonl`
    instead of `out`. Control lines are obeyed only with `allow_control`. With `strict` the
    first line not processed ends the run (status 1) after everything produced before it
    is written; a halt called by program code does so always. `progress`: True shows a
    progress display on stderr, False never, None (default) on a terminal for inputs over
    a few MB. `heartbeat` (seconds): a live source; batches are what has arrived, and while
    nothing arrives the clock advances with the wall clock every `heartbeat` seconds
    (`WallClock`), so absences and alarms fire on time.
    `report()`, if given, returns text printed on stderr before the summary (the counts of
    `--trace`). `stdin_in_prolog`: Prolog runs in this thread and may read standard input
    itself (the `retalisc` program, `Bridge.run_in_calling_thread`); then standard input or
    a plain text file going to standard output is read, processed and written by the
    runtime's own loop (`in_prolog_loop`), with no call from Python per line. Returns the
    exit status."""
    started = time.perf_counter()
    name = "<stdin>" if events == "-" else events
    source = sys.stdin.buffer if events == "-" else open(events, "rb")
    sink = sys.stdout if out == "-" else open(os.devnull if out is None else out, "w", encoding="utf-8")
    total = os.path.getsize(events) if events != "-" else None
    consumers = ConsumerFiles(consumer_dir) if consumer_dir else None
    display = Progress(stream=sys.stderr, total=total, enabled=progress)
    status = 0
    frozen = None

    emit = sink.write

    def write(produced):
        lines = []
        for event in produced:
            if consumers is not None and event.consumer is not None:
                consumers.write(event)
            else:
                lines.append(event.line)
        if lines:
            lines.append("")
            emit("\n".join(lines))

    stops = SignalStops()
    full: Optional[OSError] = None
    try:
        stops.install()
        halted = engine.take_halted()
        if halted:
            print(halted, file=sys.stderr)
            raise RunStopped()
        for produced in first_output:
            write(produced)
        wall = WallClock()
        fd = _fileno(source)
        live = heartbeat is not None or (fd is not None and _is_live(events, source))
        if live:
            sink.flush()
            emit = _unbuffered(sink)            # each batch's output leaves in one write
            frozen = _quiet_collector()         # no collection pause of the objects made so far
        if stdin_in_prolog and in_prolog_loop(events, out, consumer_dir, progress, heartbeat):
            batches = iter(())
            sink.flush()
            outcome = engine.run_event_file(events, allow_control, strict)
            stops.retake()
            if outcome == "output gone":          # the reader of standard output went away
                raise BrokenPipeError(errno.EPIPE, os.strerror(errno.EPIPE))
            if outcome == "stopped":
                raise RunStopped()
            if outcome.startswith("signal "):       # the runtime's loop took the signal itself
                stops.stopped_by(int(outcome.split()[1]))
            if outcome.startswith("output failed: "):
                raise OSError(errno.ENOSPC, outcome[len("output failed: "):])
        elif heartbeat is not None:
            batches = _heartbeat_batches(source, batch_size, heartbeat, max_line_bytes(engine))
        elif live:
            batches = _live_batches(fd, batch_size, max_line_bytes(engine))
        else:
            batches = _batches(source, batch_size, max_line_bytes(engine))
        for first, lines, size in batches:
            stops.batch_starts()                # a stop signal ends the run after the batch
            if not lines:                       # a heartbeat: nothing arrived
                target = wall.estimate()
                if target is not None and target > engine.clock():
                    write(engine.advance_clock(target))
                    sink.flush()
                stops.batch_ends()
                continue
            produced, rejected = engine.feed_lines(batch_payload(lines), first, allow_control=allow_control,
                                                   strict=strict)
            write(produced)                     # live: written at once, as it is processed
            messages = [(r.line, f"{'rejected' if r.kind == 'rejected' else 'error'}: {r.reason}")
                        for r in rejected]
            messages += [(w.line, f"warning: {w.text}") for w in engine.take_warnings()]
            if messages:
                sink.flush()
                display.clear()
            for line, message in sorted(messages, key=lambda m: m[0]):
                print(f"{name}:{line}: {message}", file=sys.stderr)
            display.update(size, len(lines), sum(1 for e in produced if e.consumer is None))
            if heartbeat is not None:
                wall.saw(engine.clock())
                sink.flush()
            if rejected and (strict or rejected[-1].kind == "halt"):
                raise RunStopped()
            stops.batch_ends()
        stops.batch_starts()
        end_the_input(engine, write, drop_pending, strict)
    except RunStopped:
        status = 1
    except SignalStop:
        pass
    except OSError as error:
        full, status = output_full(error), 1
    finally:
        stops.finishing()
        if frozen is not None:
            frozen()
        display.close()
        full = settle_output(sink.flush, full)
        if events != "-":
            source.close()
        if sink is not sys.stdout:
            full = settle_output(sink.close, full)
        if consumers is not None:
            consumers.close()
        engine.close_action_output()
    if report is not None:
        text = report()
        if text:
            print(text, file=sys.stderr)
    if full is not None:
        print(f"retalis: cannot write {'standard output' if out == '-' else out}: {full.strerror}", file=sys.stderr)
    print_summary(engine, time.perf_counter() - started)
    stops.restore()
    return stops.status(status)


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


def in_prolog_loop(events: str, out: Optional[str], consumer_dir: Optional[str], progress: Optional[bool],
                   heartbeat: Optional[float]) -> bool:
    """Whether a run reads its input in the runtime's loop (that of `swipl PROGRAM.pl FILE`,
    prolog_runtime/rtl_feed.pl, rtl_run_event_file/4): standard input or a regular file, to
    standard output, without --consumer-dir, --heartbeat or a progress line (forced with
    --progress, or possible on a terminal), whose work Python does per batch. Both loops
    read the same lines from any bytes (`event_lines`)."""
    if out != "-" or consumer_dir is not None or heartbeat is not None or progress:
        return False
    if events != "-" and not _regular_file(events):
        return False
    isatty = getattr(sys.stderr, "isatty", None)
    return progress is False or not (isatty and isatty()) or (
        events != "-" and os.path.getsize(events) <= PROGRESS_THRESHOLD)


def _regular_file(path: str) -> bool:
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return False


def _unbuffered(sink: IO[str]):
    """A function writing text to `sink` at once: straight to its file descriptor (one system
    call, no buffer to flush) when it has one, else written and flushed."""
    fd = _fileno(sink)
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


def _quiet_collector():
    """Keep Python's cyclic garbage collector from pausing a live run to walk the objects that
    exist when it starts (the compiler's, click's, the loaded program's: gc.freeze moves them
    out of its reach), so that a full collection during the run takes microseconds, not tens
    of milliseconds. Each event's own objects are freed by reference counting. Returns what
    undoes this."""
    gc.collect()
    gc.freeze()
    return gc.unfreeze


def _fileno(source) -> Optional[int]:
    """The file descriptor under a text stream (standard input's buffer, or an open file), or
    None when there is none (a stream in memory)."""
    try:
        return source.buffer.fileno() if hasattr(source, "buffer") else source.fileno()
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return None


def set_action_output(engine: Engine, path: str) -> None:
    """Send what program code prints (actions, conditions) to the file `path`; raises
    OSError-like PrologError when it cannot be opened."""
    engine.set_action_output(path)


def print_summary(engine: Engine, seconds: float, summary: Optional[str] = None) -> None:
    """The end of a run on standard error: the detections per rule (`detections_line`), then
    the one-line summary (`summary`, or `summary_line` of the engine's counters)."""
    line = detections_line(engine.detections())
    if line:
        print(line, file=sys.stderr)
    print(summary if summary is not None else summary_line(engine.stats(), seconds), file=sys.stderr)


def summary_line(stats: dict, seconds: float) -> str:
    """`retalis: N events in, M derived, K rejected, T s` (as rtl_summary/2), with failed,
    retracted, too-late deletions and late events before the time when there are any."""
    labels = (("failed", "failed"), ("retracted", "retracted"), ("too_late", "too late to retract"),
              ("late", "late"), ("timers_refused", "timers not set (max_timers)"))
    extra = "".join(f", {stats[name]:,} {label}" for name, label in labels if stats.get(name))
    return (f"retalis: {stats.get('events', 0):,} events in, {stats.get('derived', 0):,} derived, "
            f"{stats.get('rejected', 0):,} rejected{extra}, {seconds:.2f} s")


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
