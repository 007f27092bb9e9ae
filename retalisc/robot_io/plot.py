"""`retalisc plot OUTPUT.jsonl -o timeline.png`: events on one time axis.

One row per event type (functor/arity; a ROS message type `pkg__0__Type` is labelled
`pkg/Type`), and one row per consumer for subscription deliveries (`-> consumer`). An atomic
event is a tick at its time, an event with an interval a bar from its start to its end, so
a derived event lines up with the events it was derived from. Retractions are drawn as red
crosses. Rows are in the order of their first event. Input files are event JSON Lines (the
input format, `"t"` or `"start"`/`"end"`) or the output of `retalisc run` (with
`--echo-input` to see the input events too); lines that are not events (query results,
control lines) are left out.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, Iterable, List, Optional, Sequence, Tuple

from . import require

_FUNCTOR = re.compile(r"\s*('(?:[^'\\]|\\.)*'|[^(\s,]+)(\()?")


class PlotError(Exception):
    """An input that cannot be plotted (the message names the file and line)."""


@dataclass
class Row:
    label: str
    ticks: List[float] = field(default_factory=list)
    bars: List[Tuple[float, float]] = field(default_factory=list)
    retracted: List[float] = field(default_factory=list)
    first: float = float("inf")

    @property
    def count(self) -> int:
        return len(self.ticks) + len(self.bars) + len(self.retracted)


def event_type(text: str) -> str:
    """`name/arity` of an event term's text, without parsing the whole term: the arity is
    counted on the top level commas."""
    match = _FUNCTOR.match(text)
    if not match:
        return text[:30]
    name = match.group(1)
    if not match.group(2):
        return f"{name}/0"
    depth, arity, quote = 0, 1, None
    i = match.end()
    while i < len(text):
        c = text[i]
        if quote:
            if c == "\\":
                i += 1
            elif c == quote:
                quote = None
        elif c in "'\"`":
            quote = c
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            if depth == 0:
                break
            depth -= 1
        elif c == "," and depth == 0:
            arity += 1
        i += 1
    return f"{name}/{arity}"


def type_label(kind: str) -> str:
    """`geometry_msgs__0__PoseStamped/2` -> `geometry_msgs/PoseStamped`."""
    name, _, arity = kind.rpartition("/")
    if "__0__" in name:
        return name.strip("'").replace("__0__", "/")
    return kind


def read_rows(paths: Sequence[str]) -> Dict[str, Row]:
    """The rows of the events in `paths`, keyed by label."""
    rows: Dict[str, Row] = {}
    for path in paths:
        try:
            rows_of_file(path, rows)
        except UnicodeDecodeError as error:
            raise PlotError(f"{path}: not a UTF-8 text file ({error.reason})") from None
    return rows


def rows_of_file(path: str, rows: Dict[str, Row]) -> None:
    """Add the events of one file to `rows`."""
    with open(path, encoding="utf-8-sig") as stream:
        for number, line in enumerate(stream, start=1):
            if not line.strip():
                continue
            try:
                data = json.loads(line)
            except json.JSONDecodeError as error:
                raise PlotError(f"{path}:{number}: not JSON ({error.msg})") from None
            if not isinstance(data, dict) or not isinstance(data.get("event"), str):
                continue
            start, end = _interval(data)
            if start is None:
                continue
            label = type_label(event_type(data["event"]))
            if data.get("consumer") is not None:
                label = f"{label} -> {data['consumer']}"
            row = rows.get(label)
            if row is None:
                row = rows[label] = Row(label)
            row.first = min(row.first, start)
            if data.get("op") == "retract":
                row.retracted.append(end)
            elif end > start:
                row.bars.append((start, end))
            else:
                row.ticks.append(start)


def _interval(data: dict) -> Tuple[Optional[float], Optional[float]]:
    def number(value):
        if isinstance(value, bool):
            return None
        if isinstance(value, (int, float)):
            return float(value)
        if isinstance(value, list) and len(value) == 2 and all(isinstance(v, int) for v in value):
            return value[0] + value[1] / 1e9
        return None
    if "t" in data:
        t = number(data["t"])
        return t, t
    start, end = number(data.get("start")), number(data.get("end"))
    if start is None or end is None:
        return None, None
    return start, end


def _lanes(bars: List[Tuple[float, float]], most: int = 8) -> List[List[Tuple[float, float]]]:
    """Overlapping intervals in separate lanes (first fit, at most `most` lanes; beyond that
    they share the lane that ends first), so each bar stays visible."""
    lanes: List[List[Tuple[float, float]]] = []
    ends: List[float] = []
    for start, end in sorted(bars):
        for k, last in enumerate(ends):
            if last <= start:
                break
        else:
            if len(lanes) < most:
                lanes.append([])
                ends.append(float("-inf"))
                k = len(lanes) - 1
            else:
                k = min(range(len(ends)), key=ends.__getitem__)
        lanes[k].append((start, end))
        ends[k] = max(ends[k], end)
    return lanes


def plot_timeline(paths: Sequence[str], output: str, title: Optional[str] = None, max_rows: int = 40,
                  types: Optional[Iterable[str]] = None) -> Tuple[int, int]:
    """Draw the events of `paths` to the image `output` (format from its suffix: png, svg,
    pdf). `types` keeps only rows whose label contains one of these words. Returns (rows,
    events) drawn."""
    matplotlib = require("matplotlib", "retalisc plot")
    matplotlib.use("Agg")
    pyplot = require("matplotlib.pyplot", "retalisc plot")
    rows = list(read_rows(paths).values())
    if types:
        wanted = list(types)
        rows = [row for row in rows if any(word in row.label for word in wanted)]
    if not rows:
        raise PlotError(f"no events to plot in {', '.join(paths)}")
    rows.sort(key=lambda row: (row.first, row.label))
    rows = rows[:max_rows]
    origin = min(row.first for row in rows)
    figure, axes = pyplot.subplots(figsize=(11, 0.9 + 0.42 * len(rows)))
    colours = pyplot.get_cmap("tab10")
    for index, row in enumerate(rows):
        y = len(rows) - 1 - index
        colour = colours(index % 10)
        if row.bars:
            lanes = _lanes(row.bars)
            height = 0.7 / len(lanes)
            for k, lane in enumerate(lanes):
                axes.broken_barh([(s - origin, max(e - s, 1e-9)) for s, e in lane],
                                 (y + 0.35 - (k + 1) * height, height * 0.85),
                                 facecolors=colour, alpha=0.45, edgecolor=colour, linewidth=0.6)
        if row.ticks:
            axes.scatter([t - origin for t in row.ticks], [y] * len(row.ticks), marker="|", s=160,
                         color=colour, linewidths=1.2)
        if row.retracted:
            axes.scatter([t - origin for t in row.retracted], [y] * len(row.retracted), marker="x", s=40,
                         color="red")
    axes.set_yticks(range(len(rows)))
    axes.set_yticklabels([f"{row.label}  ({row.count:,})" for row in reversed(rows)], fontsize=8)
    axes.set_ylim(-0.7, len(rows) - 0.3)
    axes.set_xlabel(f"seconds since {origin:.3f}")
    axes.grid(axis="x", alpha=0.3)
    axes.set_title(title or ", ".join(Path(p).name for p in paths), fontsize=10)
    figure.tight_layout()
    figure.savefig(output, dpi=110)
    pyplot.close(figure)
    return len(rows), sum(row.count for row in rows)
