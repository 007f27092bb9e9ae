"""Running a program over an event JSON Lines file through the Python driver: the same
output and the same rejection messages as `swipl PROGRAM.pl FILE`. The loop, its sources and
sinks and the text of a run are feed.py's; this module picks the source (a file, a pipe or
standard input, a heartbeat, or the runtime's own loop) and the sink of `retalisc run`."""
from __future__ import annotations

import errno
import os
import select  # noqa: F401  (tests watch the live reader's select calls through this module)
import stat
import sys
from typing import IO, Iterator, List, Optional, Sequence, Tuple

from .engine import Engine
from .event_lines import max_line_bytes
from .feed import (OUTPUT_FULL, PROGRESS_THRESHOLD, FeedLoop, LineSource, Progress, RunStopped, Sinks, TextSink,
                   WallClock, end_the_input, file_batches, fileno, heartbeat_batches, live_batches, output_full,
                   print_summary, settle_output, summary_line)
from .feed import _unbuffered, quiet_collector as _quiet_collector  # noqa: F401  (the names tests use)
from .outputs import ConsumerFiles, detections_line  # noqa: F401  (detections_line: the name tests use)
from .signals import SignalStops

__all__ = ["OUTPUT_FULL", "PROGRESS_THRESHOLD", "Progress", "RunStopped", "WallClock", "end_the_input",
           "in_prolog_loop", "output_full", "print_summary", "run_event_file", "set_action_output",
           "settle_output", "summary_line"]


def _batches(stream: IO[bytes], batch_size: int, limit: Optional[int] = None
             ) -> Iterator[Tuple[int, List[bytes], int]]:
    """(first line number, lines, bytes read) per batch of a file read as bytes (feed.file_batches)."""
    for batch in file_batches(stream, batch_size, limit):
        yield batch.first, batch.lines, batch.size


def _live_batches(fd: int, batch_size: int, limit: Optional[int] = None) -> Iterator[Tuple[int, List[bytes], int]]:
    """(first line number, lines, bytes read) per batch of a live input (feed.live_batches)."""
    for batch in live_batches(fd, batch_size, limit):
        yield batch.first, batch.lines, batch.size


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
    runtime's own loop (`in_prolog_loop`), with no call from Python per line. The loop is
    feed.FeedLoop. Returns the exit status."""
    name = "<stdin>" if events == "-" else events
    stream = sys.stdin.buffer if events == "-" else open(events, "rb")
    try:
        text = sys.stdout if out == "-" else open(os.devnull if out is None else out, "w", encoding="utf-8")
    except BaseException:
        if events != "-":
            stream.close()
        raise
    total = os.path.getsize(events) if events != "-" else None
    sink = TextSink(text, "standard output" if out == "-" else str(out), owned=text is not sys.stdout,
                    consumers=ConsumerFiles(consumer_dir) if consumer_dir else None)
    fd = fileno(stream)
    live = heartbeat is not None or (fd is not None and _is_live(events, stream))
    runtime_loop = None
    if stdin_in_prolog and in_prolog_loop(events, out, consumer_dir, progress, heartbeat):
        batches: object = ()

        def runtime_loop(stops: SignalStops) -> None:
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
        batches = heartbeat_batches(stream, batch_size, heartbeat, max_line_bytes(engine))
    elif live:
        batches = live_batches(fd, batch_size, max_line_bytes(engine))
    else:
        batches = file_batches(stream, batch_size, max_line_bytes(engine))
    source = LineSource(name, batches, owned=stream if events != "-" else None, allow_control=allow_control,
                        strict=strict, heartbeat=heartbeat is not None, live=live)
    loop = FeedLoop(engine, source, Sinks([sink]), display=Progress(stream=sys.stderr, total=total, enabled=progress),
                    drop_pending=drop_pending, strict=strict)
    return loop.run(first_output, report=report, runtime_loop=runtime_loop)


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


def set_action_output(engine: Engine, path: str) -> None:
    """Send what program code prints (actions, conditions) to the file `path`; raises
    OSError-like PrologError when it cannot be opened."""
    engine.set_action_output(path)
