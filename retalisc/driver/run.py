"""Running a program over an event JSON Lines file through the Python driver: the same
output and the same rejection messages as `swipl PROGRAM.pl FILE`."""
from __future__ import annotations

import os
import sys
from typing import IO, Dict, Iterator, List, Optional, Sequence, Tuple

import click

from .engine import Engine


def _batches(stream: IO[str], batch_size: int) -> Iterator[Tuple[int, List[str]]]:
    first, batch = 1, []
    for number, line in enumerate(stream, start=1):
        batch.append(line.rstrip("\n"))
        if len(batch) >= batch_size:
            yield first, batch
            first, batch = number + 1, []
    if batch:
        yield first, batch


def run_event_file(engine: Engine, events: str, out: Optional[str] = "-", batch_size: int = 2000,
                   consumer_dir: Optional[str] = None, drop_pending: bool = False,
                   first_output: Sequence = ()) -> int:
    """Feed every line of `events` ('-' for stdin) to `engine`; write the output JSON Lines to
    `out` ('-' for stdout, None to drop it). Rejected lines go to stderr as `FILE:LINE: rejected: REASON`,
    warnings (deletions outside the retraction horizon) as `FILE:LINE: warning: TEXT`;
    a summary closes the run. At the end of the input the postponed synchronized matches run
    (or are dropped with `drop_pending`). `first_output` holds outputs (lists of OutputEvents)
    produced before the events, written first. With `consumer_dir`, subscription deliveries go to
    `consumer_dir/<consumer>.jsonl` instead of `out`. Returns the exit status."""
    name = "<stdin>" if events == "-" else events
    source = sys.stdin if events == "-" else open(events, encoding="utf-8")
    sink = sys.stdout if out == "-" else open(os.devnull if out is None else out, "w", encoding="utf-8")
    total = os.path.getsize(events) if events != "-" else 0
    consumers = ConsumerFiles(consumer_dir) if consumer_dir else None
    show_progress = total > 5_000_000 and sys.stderr.isatty()
    try:
        with click.progressbar(length=total, label="events", file=sys.stderr) if show_progress else _NoBar() as bar:
            def write(produced):
                for event in produced:
                    if consumers is not None and event.consumer is not None:
                        consumers.write(event)
                    else:
                        sink.write(event.line + "\n")

            for produced in first_output:
                write(produced)
            for first, lines in _batches(source, batch_size):
                text = "\n".join(lines)
                produced, rejected = engine.feed_lines(text, first)
                messages = [(r.line, f"rejected: {r.reason}") for r in rejected]
                messages += [(w.line, f"warning: {w.text}") for w in engine.take_warnings()]
                for line, message in sorted(messages, key=lambda m: m[0]):
                    print(f"{name}:{line}: {message}", file=sys.stderr)
                write(produced)
                bar.update(len(text.encode("utf-8")) + len(lines))
            write(engine.end_of_input(drop_pending))
        sink.flush()
    finally:
        if source is not sys.stdin:
            source.close()
        if sink is not sys.stdout:
            sink.close()
        if consumers is not None:
            consumers.close()
    print(engine.summary(), file=sys.stderr)
    return 0


def consumer_file_name(consumer: str) -> str:
    """The file of a consumer's deliveries: leading slashes dropped, every character other
    than letters, digits, `_`, `-`, `.` written `_` (the runtime's rtl_consumer_dir/1 rule)."""
    base = "".join(c if (c.isalnum() or c in "_-.") else "_" for c in consumer.lstrip("/"))
    return (base or "_") + ".jsonl"


class ConsumerFiles:
    """One JSON Lines file per consumer in a directory, opened at its first delivery."""

    def __init__(self, directory: str):
        self.directory = directory
        os.makedirs(directory, exist_ok=True)
        self.files: Dict[str, IO[str]] = {}

    def write(self, event) -> None:
        stream = self.files.get(event.consumer)
        if stream is None:
            path = os.path.join(self.directory, consumer_file_name(event.consumer))
            stream = self.files[event.consumer] = open(path, "w", encoding="utf-8")
        stream.write(event.line + "\n")

    def close(self) -> None:
        for stream in self.files.values():
            stream.close()
        self.files.clear()


class _NoBar:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n: int) -> None:
        pass
