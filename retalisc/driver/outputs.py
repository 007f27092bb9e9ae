"""Where a run's outputs go, shared by the feed loops of every road (run.py, recovery.py,
robot_io/replay.py): one JSON Lines file per consumer, and the detections line of the summary."""
from __future__ import annotations

import os
from typing import IO, Dict, Optional


def detections_line(counts: Dict[str, int]) -> Optional[str]:
    """`retalis: detections per rule: r1 3, fire_alarm 0` (Engine.detections, program order),
    None for a program without event rules."""
    if not counts:
        return None
    return "retalis: detections per rule: " + ", ".join(f"{rule} {count:,}" for rule, count in counts.items())


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
