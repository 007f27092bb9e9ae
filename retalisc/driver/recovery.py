"""The state directory of a run that survives a crash (docs/recovery.md), and `Recovery`, the
wrapper that makes any source and sink of the feed loop (feed.py) recoverable: `retalisc run
--state` over an event file, standard input or a recording, and `retalisc aq --state`. How one
snapshot file is written and tagged (its identity, the atomic replacement) is `snapshot.py`,
below the Engine.
"""
from __future__ import annotations

import fcntl
import hashlib
import inspect
import json
import os
import sys
import time
from functools import wraps
from pathlib import Path
from typing import Optional, Union

from ..robot_io.messages import Convention
from ..robot_io.replay import BagOptions, replay_bag
from .bridge import PrologError
from .event_lines import max_line_bytes
from .feed import (SCRIPT_BATCH, Batch, BinarySink, FeedLoop, LineSource, Progress, ScriptSource, Sinks, file_batches,
                   live_batches)
from .snapshot import STATE_FORMAT, StateError, fsync_directory, replace_atomically


def file_sha256(path: Union[str, Path]) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# ---- the state directory of `retalisc run --state DIR` -------------------------------------

DEFAULT_SNAPSHOT_EVENTS = 200_000   # input lines between two snapshots
DEFAULT_SNAPSHOT_SECONDS = 60.0     # or seconds of processing, whichever comes first
KEEP_SNAPSHOTS = 2                  # the newest complete ones; older ones are deleted
LOCK_FILE = "lock"                  # in DIR: held (fcntl) by the process that uses DIR

# lock file (real path) -> its open file, for the state directories this process holds. A
# POSIX record lock belongs to the process and goes when any descriptor of the file is closed,
# so each lock file is opened once per process.
_HELD_LOCKS: dict = {}


def _atomic_write_text(path: Path, text: str) -> None:
    replace_atomically(path, lambda temporary: temporary.write_text(text, encoding="utf-8"))


class StateDir:
    """The files of a recoverable run in one directory:

    - `snapshot-NNNNNNNN.state`: the runtime state (Engine.save_state);
    - `snapshot-NNNNNNNN.json`: its manifest, written (atomically) after the state file: the
      identity of the program, the SHA-256 of the state file, the input position (lines and
      bytes consumed) and the output position (bytes of the output file). A snapshot without a
      manifest, or whose state file does not match the manifest, is incomplete and never read;
    - `journal.jsonl`: one line per batch consumed since the newest snapshot (input and output
      positions reached), emptied at each snapshot. For a file the journal of what was consumed
      is this position: a restart replays the input file from the snapshot's position, so the
      journal is for inspection (how far the run got), and a line cut by a crash is harmless;
    - `lock`: locked (`lock`) by the process that runs with DIR, so that a second one is refused.
    """

    def __init__(self, directory: Union[str, Path]):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.journal_path = self.directory / "journal.jsonl"
        self.lock_path = self.directory / LOCK_FILE

    def lock(self) -> None:
        """Take the directory for this process until `unlock` (or its end: the operating system
        drops the lock of a killed process, so a stale lock never blocks a restart); the file
        holds the process id, for the message. RecoveryError when another process holds it."""
        key = os.path.realpath(self.lock_path)
        if key in _HELD_LOCKS:
            return
        fd = os.open(key, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.lockf(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.read(fd, 32).decode("ascii", "replace").strip()
            os.close(fd)
            raise RecoveryError(f"{self.directory} is in use by another process"
                                f"{f' (pid {holder})' if holder.isdigit() else ''}: one process per "
                                f"state directory") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        _HELD_LOCKS[key] = fd

    def unlock(self) -> None:
        fd = _HELD_LOCKS.pop(os.path.realpath(self.lock_path), None)
        if fd is not None:
            os.close(fd)

    def _manifests(self):
        return sorted(self.directory.glob("snapshot-*.json"), reverse=True)

    def remove_incomplete(self) -> None:
        """Delete temporary files and state files without a manifest (a crash while writing)."""
        for path in self.directory.glob("*.tmp"):
            path.unlink(missing_ok=True)
        for path in self.directory.glob("snapshot-*.state"):
            if not path.with_suffix(".json").exists():
                path.unlink(missing_ok=True)

    def snapshots(self):
        """(manifest, state file) of the complete snapshots, newest first, and the messages
        about those that are not (corrupt or unreadable)."""
        found, problems = [], []
        for manifest_path in self._manifests():
            state_path = manifest_path.with_suffix(".state")
            try:
                manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
                if manifest.get("format") != STATE_FORMAT:
                    raise ValueError(f"format {manifest.get('format')!r}, not {STATE_FORMAT}")
                if not state_path.exists():
                    raise ValueError("its state file is missing")
                if file_sha256(state_path) != manifest["sha256"]:
                    raise ValueError("its state file does not match its checksum (corrupt)")
            except (OSError, ValueError, KeyError, TypeError) as error:
                problems.append(f"{manifest_path.name}: not used: {error}")
                continue
            found.append((manifest, state_path))
        return found, problems

    def next_number(self) -> int:
        numbers = [int(p.stem.split("-")[1]) for p in self._manifests() if p.stem.split("-")[1].isdigit()]
        return max(numbers, default=-1) + 1

    def save(self, engine, manifest: dict) -> dict:
        """Write a snapshot of `engine` with `manifest` (input and output positions); returns the
        manifest written. Older snapshots beyond the newest KEEP_SNAPSHOTS are deleted."""
        number = self.next_number()
        state_path = self.directory / f"snapshot-{number:08d}.state"
        engine.save_state(state_path)
        manifest = dict(manifest, format=STATE_FORMAT, number=number, identity=engine.identity(),
                        sha256=file_sha256(state_path), state_bytes=state_path.stat().st_size)
        try:
            _atomic_write_text(state_path.with_suffix(".json"), json.dumps(manifest, sort_keys=True) + "\n")
        except BaseException:
            state_path.unlink(missing_ok=True)
            raise
        open(self.journal_path, "w").close()     # the journal holds what came after the newest snapshot
        for old in self._manifests()[KEEP_SNAPSHOTS:]:
            old.unlink(missing_ok=True)
            old.with_suffix(".state").unlink(missing_ok=True)
        return manifest

    def journal(self, record: dict) -> None:
        with open(self.journal_path, "a", encoding="utf-8") as stream:
            stream.write(json.dumps(record, sort_keys=True) + "\n")

    def journal_records(self):
        """The journal's complete lines (a line cut by a crash is skipped)."""
        records = []
        try:
            text = self.journal_path.read_text(encoding="utf-8", errors="replace")
        except OSError:
            return records
        for line in text.splitlines():
            try:
                records.append(json.loads(line))
            except ValueError:
                continue
        return records


class EventJournal:
    """The journal of a live input (standard input), whose events cannot be read again: the
    lines read after snapshot N are appended to `events-N.jsonl` (flushed to the operating
    system before they are processed, fsynced at each snapshot), so a process killed at any
    point loses none of the lines it has read. A restart from snapshot N replays the segments
    from N on; segments older than the oldest snapshot kept are deleted."""

    def __init__(self, directory: StateDir):
        self.directory = directory.directory
        self.stream = None

    def segments(self):
        found = []
        for path in self.directory.glob("events-*.jsonl"):
            number = path.stem.split("-", 1)[1]
            if number.isdigit():
                found.append((int(number), path))
        return sorted(found)

    def replay(self, first: int):
        """The complete lines (bytes) of the segments from snapshot `first` on, in order; a line cut by
        a crash (the end of a segment without a newline) is removed from its file."""
        lines = []
        for number, path in self.segments():
            if number < first:
                continue
            data = path.read_bytes()
            complete = data[:data.rfind(b"\n") + 1]
            if len(complete) != len(data):
                with open(path, "r+b") as stream:
                    stream.truncate(len(complete))
            lines += complete.split(b"\n")[:-1]
        return lines

    def open(self, number: int) -> None:
        """Append from now on to the segment of snapshot `number` (made if missing)."""
        self.close()
        path = self.directory / f"events-{number:08d}.jsonl"
        self.stream = open(path, "ab")
        fsync_directory(self.directory)

    def append(self, lines) -> None:
        """Journal `lines` (bytes, without their newlines)."""
        if self.stream is None:          # no snapshot could be written yet: nothing to replay from
            return
        self.stream.write(b"".join(line + b"\n" for line in lines))
        self.stream.flush()

    def sync(self) -> None:
        if self.stream is not None:
            self.stream.flush()
            os.fsync(self.stream.fileno())

    def prune(self, directory: StateDir) -> None:
        kept = [int(p.stem.split("-")[1]) for p in directory._manifests()]
        if kept:
            for number, path in self.segments():
                if number < min(kept):
                    path.unlink(missing_ok=True)

    def close(self) -> None:
        if self.stream is not None:
            self.stream.close()
            self.stream = None


class RecoveryError(Exception):
    """The state directory cannot be used for this run (another program, another input)."""


def restore_newest(directory: StateDir, engine, input_key: str, input_name: str, log):
    """Restore the newest complete snapshot of `directory` into `engine` (an Engine or an
    ActiveQueries: identity() and restore_state()) and return its manifest, or None for a
    directory without snapshots (a first run). Incomplete snapshots are deleted first, corrupt
    ones (not matching their checksum) reported on `log` and passed over. RecoveryError for a
    snapshot of another program or runtime version, of a run over another input (the
    manifest's `input_key` is not `input_name`), that the runtime refuses (anything in it that
    is not the declared state, prolog_runtime/rtl_state.pl), or when every snapshot is corrupt:
    nothing is restored then, and the run does not start from the beginning."""
    directory.remove_incomplete()
    identity = engine.identity()
    found, problems = directory.snapshots()
    for problem in problems:
        print(f"retalisc: {directory.directory}/{problem}", file=log)
    for manifest, state_path in found:
        if manifest.get("identity") != identity:
            raise RecoveryError(f"{state_path}: the snapshot was made by another program or runtime "
                                f"version; use another --state directory or delete this one")
        if manifest.get(input_key) != input_name:
            raise RecoveryError(f"{state_path}: the snapshot belongs to a run over {manifest.get(input_key)}, "
                                f"not {input_name}")
        try:
            engine.restore_state(state_path)
        except StateError as error:     # it matches its checksum: made so, not damaged
            raise RecoveryError(f"refused: {error}") from None
        return manifest
    if problems:                        # snapshots there, none usable: not a first run
        raise RecoveryError(f"{directory.directory}: none of its snapshots can be used (above); move or delete "
                            f"the directory to start again from the beginning")
    return None


def open_output(out: str, restored):
    """The output file opened for binary writing: new for a first run, else cut back to the
    length it had at the restored snapshot (RecoveryError if it is shorter than that)."""
    if restored is None:
        return open(out, "wb")
    size = os.path.getsize(out) if os.path.exists(out) else -1
    if size < restored["out_bytes"]:
        raise RecoveryError(f"{out} has {max(size, 0)} bytes, fewer than the {restored['out_bytes']} it had at "
                            f"snapshot {restored['number']}: it was changed; cannot go on from this snapshot")
    sink = open(out, "r+b")
    sink.truncate(restored["out_bytes"])
    sink.seek(restored["out_bytes"])
    return sink


def take_snapshot(directory: StateDir, engine, sink, manifest: dict, log):
    """Flush the output to disk, then write a snapshot of `engine` with `manifest` (the input
    position) and the output position. A snapshot that cannot be written (a full disk) is
    reported on `log` and None returned: the run goes on, the previous snapshot stays."""

    sink.flush()
    os.fsync(sink.fileno())
    try:
        return directory.save(engine, dict(manifest, out_bytes=sink.tell()))
    except (OSError, PrologError) as error:
        print(f"retalisc: warning: the snapshot could not be written ({error}); the run goes on, "
              f"the previous snapshot stays the one a restart uses", file=log)
        return None


def _holding_the_state_directory(run):
    """`run` (its argument `state` a state directory) holds the directory's lock while it runs."""
    @wraps(run)
    def held(*args, **kwargs):
        directory = StateDir(inspect.signature(run).bind(*args, **kwargs).arguments["state"])
        directory.lock()
        try:
            return run(*args, **kwargs)
        finally:
            directory.unlock()
    return held


class Recovery:
    """Crash recovery around any source and sink of the feed loop (feed.FeedLoop's
    `checkpoint`): a checkpoint is the source's position (`position(batch)`: the manifest's input
    entries, e.g. the byte offset and line of an event file, the messages of a recording
    replayed), the sink's position (the bytes of the output file, `BinarySink.tell`) and the
    Engine's snapshot (`StateDir.save`). A snapshot is taken when a first run starts and then
    every `every` input items or `seconds` seconds, at a batch boundary; each batch consumed
    since is a journal record. `journal` (EventJournal): the source is a live input whose lines
    are journaled; it is synced before and moved to the new segment after each snapshot.
    `restored`: the manifest the run goes on from (None: a first run)."""

    def __init__(self, directory: StateDir, engine, sink, input_key: str, input_name: str, restored,
                 position, start: dict, every: int, seconds: float, log, journal: "Optional[EventJournal]" = None):
        self.directory = directory
        self.engine = engine
        self.sink = sink
        self.input_key = input_key
        self.input_name = input_name
        self.restored = restored
        self.position = position
        self.start = start
        self.every = every
        self.seconds = seconds
        self.log = log
        self.journal = journal
        self.since_items, self.since_time = 0, time.monotonic()

    def begin(self, first: bool) -> None:
        """The loop starts: a first run takes its first snapshot (after the first output)."""
        if first:
            self.snapshot(self.start)
        self.since_items, self.since_time = 0, time.monotonic()

    def after(self, batch) -> None:
        """A batch is consumed and its output written (a position of None: the source ended)."""
        position = self.position(batch)
        if position is not None:
            self.advance(position, len(batch.lines))

    def advance(self, position: dict, items: int) -> None:
        self.since_items += items
        self.directory.journal(dict(position, out_bytes=self.sink.tell()))
        if self.since_items >= self.every or time.monotonic() - self.since_time >= self.seconds:
            self.snapshot(position)
            self.since_items, self.since_time = 0, time.monotonic()

    def snapshot(self, position: dict):
        if self.journal is not None:
            self.journal.sync()
        manifest = take_snapshot(self.directory, self.engine, self.sink.stream,
                                 dict(position, **{self.input_key: self.input_name}), self.log)
        if self.journal is not None and manifest is not None:
            self.journal.open(manifest["number"])        # the lines read from now on
            self.journal.prune(self.directory)
        return manifest

    def close(self) -> None:
        if self.journal is not None:
            self.journal.close()


@_holding_the_state_directory
def run_recoverable(engine, events: str, out: str, state: Union[str, Path], batch_size: int = 2000,
                    snapshot_events: int = DEFAULT_SNAPSHOT_EVENTS,
                    snapshot_seconds: float = DEFAULT_SNAPSHOT_SECONDS, drop_pending: bool = False,
                    first_output=(), allow_control: bool = False, strict: bool = False,
                    progress=None, log=None) -> int:
    """`retalisc run --state DIR`: as run.run_event_file for an event file and an output file,
    and the run survives a crash. A snapshot (the engine's state with the input and output
    positions) is written when the run starts and then every `snapshot_events` input lines or
    `snapshot_seconds` seconds, at a batch boundary. Started again with the same DIR, the run
    restores the newest complete snapshot, cuts the output file back to the snapshot's output
    position and reads the input from the snapshot's input position: the output file ends
    byte-identical to that of a run that never stopped. A snapshot that cannot be written (a
    full disk) is reported and the run goes on. With `events` '-' (standard input, a live
    input) the lines are journaled (EventJournal) before they are processed, a restart
    replays the journal after the snapshot and then reads standard input on; the output is
    flushed after each batch. The loop is feed.FeedLoop, with `Recovery` around its source and
    sink. Returns the exit status."""
    log = log or sys.stderr
    directory = StateDir(state)
    live = events == "-"
    events_path = "-" if live else os.path.abspath(events)
    restored = restore_newest(directory, engine, "events", events_path, log)
    sink = BinarySink(open_output(out, restored), str(out))
    if restored is None:
        offset, line = 0, 1
    else:
        offset, line = restored.get("input_bytes", 0), restored["input_line"]
        print(f"retalisc: restored snapshot {restored['number']} of {directory.directory} "
              f"(input line {line}, {restored['out_bytes']} output bytes)", file=log)
    name = "<stdin>" if live else events
    journal = None
    if live:
        journal = EventJournal(directory)
        if restored is None:
            for _, path in journal.segments():          # of a run that never took its first snapshot
                path.unlink(missing_ok=True)
        stream = None
        batches = _journaled_batches(journal, restored, line, batch_size, max_line_bytes(engine))
        display = Progress(stream=sys.stderr, total=None, enabled=False)

        def position(batch):
            return {"input_line": batch.first + len(batch.lines)}
        start = {"input_line": line}
    else:
        stream = open(events_path, "rb")
        batches = file_batches(stream, batch_size, max_line_bytes(engine), offset, line)
        display = Progress(stream=sys.stderr, total=os.path.getsize(events_path), enabled=progress)

        def position(batch):
            return {"input_bytes": batch.position, "input_line": batch.first + len(batch.lines)}
        start = {"input_bytes": offset, "input_line": line}
    source = LineSource(name, batches, owned=stream, allow_control=allow_control, strict=strict, live=live)
    recovery = Recovery(directory, engine, sink, "events", events_path, restored, position, start,
                        snapshot_events, snapshot_seconds, log, journal)
    loop = FeedLoop(engine, source, Sinks([sink]), display=display, drop_pending=drop_pending, strict=strict)
    return loop.run(first_output, checkpoint=recovery)


def _journaled_batches(journal: EventJournal, restored, first_line: int, batch_size: int,
                       limit: Optional[int] = None):
    """The batches of standard input with a journal (a source of the feed loop): first the
    journaled lines read after the restored snapshot (replayed), then the lines of standard
    input as they arrive, each batch appended to the journal before it is processed. The
    journal's segment is that of the newest snapshot: the caller opens it when it takes the
    first snapshot of a new run."""
    line = first_line
    if restored is not None:
        replayed = journal.replay(restored["number"])
        segments = [number for number, _ in journal.segments() if number >= restored["number"]]
        journal.open(segments[-1] if segments else restored["number"])
        for start in range(0, len(replayed), batch_size):
            lines = replayed[start:start + batch_size]
            yield Batch(line, lines, 0)
            line += len(lines)
    for batch in live_batches(sys.stdin.fileno(), batch_size, limit, first_line=line):
        journal.append(batch.lines)
        yield batch


DEFAULT_AQ_SNAPSHOT_COMMANDS = 10_000   # script commands between two snapshots of `retalisc aq --state`
DEFAULT_AQ_BATCH = SCRIPT_BATCH


@_holding_the_state_directory
def run_aq_recoverable(aq, script: str, out: str, state: Union[str, Path], display_name: Optional[str] = None,
                       batch_size: int = DEFAULT_AQ_BATCH, snapshot_commands: int = DEFAULT_AQ_SNAPSHOT_COMMANDS,
                       snapshot_seconds: float = DEFAULT_SNAPSHOT_SECONDS, log=None) -> int:
    """`retalisc aq --script SCRIPT --out OUT --state DIR`: the update script run on the loaded
    ActiveQueries `aq`, its notifications written to `out` as `retalisc aq` prints them, and the
    run survives a crash as `run_recoverable` does: a snapshot (the tables, records, facts and
    rules, with the script line reached and the output position) when the run starts and every
    `snapshot_commands` commands or `snapshot_seconds` seconds; a restart with the same DIR
    restores the newest complete one, cuts `out` back and goes on from its script line. A bad
    script line or a failed command ends the run as without --state (its message on `log`,
    with `display_name` for the script; exit status 2 or 1). Returns the exit status."""

    log = log or sys.stderr
    batch_size = max(1, min(batch_size, snapshot_commands))   # snapshots fall between batches
    directory = StateDir(state)
    script_path = os.path.abspath(script)
    restored = restore_newest(directory, aq, "script", script_path, log)
    sink = BinarySink(open_output(out, restored), str(out))
    line = 1 if restored is None else restored["input_line"]
    if restored is not None:
        print(f"retalisc: restored snapshot {restored['number']} of {directory.directory} "
              f"(script line {line}, {restored['out_bytes']} output bytes)", file=log)
    source = ScriptSource(script_path, display_name or script, line, batch_size)
    recovery = Recovery(directory, aq, sink, "script", script_path, restored,
                        lambda batch: None if source.done else {"input_line": source.line}, {"input_line": line},
                        snapshot_commands, snapshot_seconds, log)
    return FeedLoop(aq, source, Sinks([sink]), signals=False, log=log).run(checkpoint=recovery)


@_holding_the_state_directory
def run_bag_recoverable(engine, bag_path: str, out: str, state: Union[str, Path], options=None,
                        batch_size: int = 2000, snapshot_events: int = DEFAULT_SNAPSHOT_EVENTS,
                        snapshot_seconds: float = DEFAULT_SNAPSHOT_SECONDS, drop_pending: bool = False,
                        first_output=(), log=None) -> int:
    """`retalisc run PROGRAM --bag RECORDING --out OUT --state DIR`: the recording replayed as
    `replay_bag` replays it (as fast as possible), surviving a crash as `run_recoverable` does:
    the same loop (replay_bag's), with `Recovery` around its source and sink.
    The input position is the number of messages of the selection replayed (the recording and
    the options that select and convert its messages are part of the snapshot's input name:
    a state directory of another selection is refused); a restart passes over that many
    messages and goes on. Returns the exit status (2: the recording cannot be read)."""
    log = log or sys.stderr
    options = options or BagOptions(convention=Convention.of_program(engine))
    directory = StateDir(state)
    selection = json.dumps({"bag": os.path.abspath(bag_path), "topics": options.topics, "start": options.start,
                            "duration": options.duration, "stamp": options.stamp,
                            "typestore": options.typestore, "wrap_topic": options.convention.wrap_topic,
                            "plain_strings": options.convention.plain_strings}, sort_keys=True)
    restored = restore_newest(directory, engine, "bag", selection, log)

    def checkpoint(sink):
        done = 0 if restored is None else restored["input_messages"]
        if restored is not None:
            print(f"retalisc: restored snapshot {restored['number']} of {directory.directory} "
                  f"(message {done + 1}, {restored['out_bytes']} output bytes)", file=log)
        return Recovery(directory, engine, sink, "bag", selection, restored,
                        lambda batch: {"input_messages": batch.position}, {"input_messages": done},
                        snapshot_events, snapshot_seconds, log)

    return replay_bag(engine, bag_path, out, options, batch_size=batch_size, drop_pending=drop_pending,
                      first_output=first_output, progress=False,
                      recoverable=(lambda: BinarySink(open_output(out, restored), str(out)), checkpoint,
                                   0 if restored is None else restored["input_messages"]))
