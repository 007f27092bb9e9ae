"""Absence rule against the 1 Hz tick work-around: "a person was seen, then the door
closed within 10 s, and no one was seen in the room for 30 s after".

The same stream of sightings and door closings (ROOMS rooms, one situation per room every
GAP seconds on average, half of them broken by a sighting inside the 30 s) goes through

  absence   empty(R, P) <- not(seen(_, R)).[(seen(P, R) seq door_closed(R)).10, 30].
  ticks     the work-around: the same pattern closed by a `tick` input event
            every second, `where T - E >= 30, T - E < 31`, inside a window of 41 s
            (without it the pairs are never forgotten), fed one tick per second of stream

through the Python driver (`Engine.feed_batch`, batches of 2000, the same harness for both).
The absence run ends with `end_of_input` under `flush_timers` so that it decides the last
situations too; both must detect the same (room, person, sighting time) situations. The
figure is events of the situation stream per second of run time, and the target is the
absence rule at least 5x cheaper than the tick version. Densities: the robot
(sparse: GAP 300 s, the default target) and a busy building (GAP 40 s).

Usage: python benchmarks/absence.py [--seconds N] [--out-dir DIR] [--quick]
Writes DIR/absence.json and DIR/absence.png.
"""
from __future__ import annotations

import argparse
import json
import random
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retalisc.driver.engine import Engine  # noqa: E402

ABSENCE = "empty(R, P) <- not(seen(_, R)).[(seen(P, R) seq door_closed(R)).10, 30].\n"
TICKS = ("empty(R, P) <- (not(seen(_, R)).[(seen(P, R) seq door_closed(R)^E).10, tick^T]\n"
         "                 where (T - E >= 30, T - E < 31)).41.\n")
ROOMS = 10
DENSITIES = {"robot (a situation per room every ~300 s)": 300, "busy building (every ~40 s)": 40}
TARGET = 5.0


def situations(seconds: int, gap: int, seed: int = 7):
    """(event, time) in time order: per room, a sighting, the door 1-9 s later, and for half
    of them a sighting 2-28 s after the door."""
    rng = random.Random(seed)
    events = []
    for room in range(ROOMS):
        t = rng.uniform(0, gap)
        while t < seconds - 60:
            person = f"p{rng.randrange(50)}"
            events.append((f"seen({person}, room{room})", round(t, 3)))
            door = t + rng.uniform(1, 9)
            events.append((f"door_closed(room{room})", round(door, 3)))
            if rng.random() < 0.5:
                events.append((f"seen(p{rng.randrange(50)}, room{room})", round(door + rng.uniform(2, 28), 3)))
            t = door + 40 + rng.expovariate(1 / gap)
    return sorted(events, key=lambda e: e[1])


def with_ticks(events, seconds: int):
    ticks = [("tick", float(t)) for t in range(seconds + 1)]
    return sorted(events + ticks, key=lambda e: (e[1], e[0] != "tick"))


def run(program: str, stream, flush: bool):
    engine = Engine.from_source(program, "absence_bench.rtl")
    engine.clear()
    engine.set_flag("max_delay", "1")
    engine.set_flag("flush_timers", "true" if flush else "false")
    produced = []
    started = time.perf_counter()
    for i in range(0, len(stream), 2000):
        produced += engine.feed_batch(stream[i:i + 2000])
    produced += engine.end_of_input()
    seconds = time.perf_counter() - started
    engine.set_flag("flush_timers", "false")
    found = sorted((o.event, o.start) for o in produced if o.op == "add")
    return seconds, found


def measure(seconds: int):
    rows = []
    for name, gap in DENSITIES.items():
        stream = situations(seconds, gap)
        absence_s, absence_found = run(ABSENCE, stream, flush=True)
        ticked = with_ticks(stream, seconds)
        ticks_s, ticks_found = run(TICKS, ticked, flush=False)
        rows.append({"density": name, "gap": gap, "events": len(stream), "ticks": len(ticked) - len(stream),
                     "situations": len(absence_found), "same_detections": absence_found == ticks_found,
                     "absence_s": absence_s, "ticks_s": ticks_s,
                     "absence_eps": len(stream) / absence_s, "ticks_eps": len(stream) / ticks_s,
                     "ratio": ticks_s / absence_s})
    return rows


def plot(rows, png: Path) -> None:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing: no plot")
        return
    fig, ax = plt.subplots(figsize=(7, 3.8))
    names = [r["density"].split(" (")[0] for r in rows]
    xs = range(len(rows))
    ax.bar([x - 0.2 for x in xs], [r["absence_s"] for r in rows], 0.4, label="absence not(C).[A, 30]")
    ax.bar([x + 0.2 for x in xs], [r["ticks_s"] for r in rows], 0.4, label="1 Hz tick work-around")
    for x, r in zip(xs, rows):
        ax.text(x, max(r["absence_s"], r["ticks_s"]) * 1.02, f"{r['ratio']:.1f}x", ha="center")
    ax.set_xticks(list(xs), names)
    ax.set_ylim(0, max(max(r["absence_s"], r["ticks_s"]) for r in rows) * 1.35)
    ax.set_ylabel("run time (s)")
    ax.set_title("The same situations: absence rule vs tick work-around")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(png, dpi=120)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=int, default=40_000, help="event time of the stream (default 40,000 s)")
    parser.add_argument("--quick", action="store_true", help="a short stream (smoke test)")
    parser.add_argument("--out-dir", default=str(ROOT / "benchmarks" / "results"))
    args = parser.parse_args()
    seconds = 600 if args.quick else args.seconds
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = measure(seconds)
    for r in rows:
        print(f"{r['density']}: {r['events']:,} events ({r['situations']:,} situations) + {r['ticks']:,} ticks; "
              f"absence {r['absence_s']:.3f} s ({r['absence_eps']:,.0f} ev/s), ticks {r['ticks_s']:.3f} s "
              f"({r['ticks_eps']:,.0f} ev/s): {r['ratio']:.1f}x; same detections: {r['same_detections']}")
    robot = rows[0]
    print(f"target {'met' if robot['ratio'] >= TARGET else 'MISSED':6} absence rule >= {TARGET:g}x cheaper than "
          f"the tick version (robot density): {robot['ratio']:.1f}x")
    print(f"target {'met' if all(r['same_detections'] for r in rows) else 'MISSED':6} the same situations "
          f"detected by both")
    name = "absence_quick" if args.quick else "absence"
    (out / f"{name}.json").write_text(json.dumps(rows, indent=2))
    plot(rows, out / f"{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
