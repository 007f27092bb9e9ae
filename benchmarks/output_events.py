"""Outputs on the Python roads: collecting them, reading their terms, writing their lines,
now (outputs cross as data: one JSON array a call, `OutputEvent.from_data`) against before (git
728a727: one JSON line an output, matched by a regex, `out.term` read back by Prolog), measured
in the same run.

The "before" runtime is the tree of commit 728a727 (`git archive`, its C helpers built) in a
temporary directory; each measurement runs in a fresh Python process with that tree or this
one on its path, the two alternating, --repeat times; the figure is the best of the repeats
(the machine is shared: the best run is the one least disturbed). A measurement feeds N events
in batches of --batch with `Engine.feed_batch` to a program that derives four events from each
(terms with atoms, quoted atoms, floats, lists and nesting, none with a JSON escape in its
text: before, every line was the one its regex took), and then, per road:

  - collect:   nothing more (the list of OutputEvents is the road);
  - name/args: reads `out.name` and `out.args` of every output;
  - JSON line: writes `out.line` of every output to a file (the `--out` road, feed.py's sinks).

The figures are microseconds per output: in all (the processing of the events included, the
same work on both sides, so the differences are small beside the machine's noise), and on the
Python side alone (outside the bridge's calls into Prolog: what the boundary's form changes).
Targets: each road at least as fast as before, in all and on the Python side (before / now >= 1).

Usage: python benchmarks/output_events.py [--events N] [--batch B] [--repeat R] [--out-dir DIR]
Writes DIR/output_events.json and DIR/output_events.png.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BEFORE = "728a727"
ROADS = ("collect", "name/args", "JSON line")
PROGRAM = """seen(Who, at(Place, X, Y), [T, ok]) <- pose(Who, Place, X, Y, T).
in_room(Place) <- pose(_, Place, _, _, _).
moved(Who, X, Y) <- pose(Who, _, X, Y, _).
track(Who, [X, Y], step(T, done)) <- pose(Who, _, X, Y, T).
"""
OUTPUTS_PER_EVENT = 4


def worker(road: str, events: int, batch: int) -> tuple:
    """Microseconds per output of `road` in this process (the runtime on sys.path): in all, and
    on the Python side (outside the bridge's calls into Prolog)."""
    from retalisc.driver.engine import Engine

    engine = Engine.from_source(PROGRAM, "output_events.rtl")
    call, in_prolog = engine.bridge.apply, [0.0]

    def timed(*args):
        started = time.perf_counter()
        try:
            return call(*args)
        finally:
            in_prolog[0] += time.perf_counter() - started
    items = [(f"pose(robot_{i % 7}, 'Room {i % 3}', {i % 100}.5, -{i % 50}, {i})", i + 1) for i in range(events)]
    batches = [items[i:i + batch] for i in range(0, len(items), batch)]
    engine.feed_batch(batches[0][:10])                # warm up (loading, first calls)
    engine.clear()
    engine.bridge.apply = timed
    sink = open(os.devnull, "w", encoding="utf-8")
    outputs = 0
    start = time.perf_counter()
    for group in batches:
        produced = engine.feed_batch(group)
        outputs += len(produced)
        if road == "name/args":
            for out in produced:
                out.name
                out.args
        elif road == "JSON line":
            write = sink.write
            for out in produced:
                write(out.line + "\n")
    elapsed = time.perf_counter() - start
    sink.close()
    if outputs != OUTPUTS_PER_EVENT * events:
        raise SystemExit(f"{outputs} outputs for {events} events")
    return elapsed / outputs * 1e6, (elapsed - in_prolog[0]) / outputs * 1e6


def before_tree(directory: Path) -> Path:
    """The runtime of commit BEFORE in `directory`, its C helpers built."""
    tree = directory / "before"
    tree.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", BEFORE, "retalisc", "prolog_runtime"],
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
    subprocess.run(["bash", "prolog_runtime/c/build.sh"], cwd=tree, check=True, capture_output=True)
    return tree


def run_worker(tree: Path, road: str, events: int, batch: int) -> tuple:
    environment = dict(os.environ, PYTHONPATH=str(tree))
    done = subprocess.run([sys.executable, __file__, "--worker", road, "--events", str(events), "--batch",
                           str(batch)], capture_output=True, text=True, env=environment, cwd=str(tree))
    if done.returncode != 0:
        raise SystemExit(f"{tree} {road}: {done.stderr}")
    total, python_side = done.stdout.split()[-2:]
    return float(total), float(python_side)


def measure(events: int, batch: int, repeat: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="output_events-") as directory:
        trees = {"before": before_tree(Path(directory)), "now": ROOT}
        runs = {road: {name: [] for name in trees} for road in ROADS}
        for _ in range(repeat):
            for road in ROADS:
                for name, tree in trees.items():
                    runs[road][name].append(run_worker(tree, road, events, batch))
    results = {}
    for part, index in (("in all", 0), ("Python side", 1)):
        results[part] = {road: {name: min(run[index] for run in values) for name, values in row.items()}
                         for road, row in runs.items()}
    print(f"{events} events, {OUTPUTS_PER_EVENT * events} outputs, batches of {batch}, best of {repeat} "
          f"(us per output)")
    for part, table in results.items():
        print(f"  {part}")
        print(f"    {'road':10} {'before':>8} {'now':>8} {'before/now':>10}")
        for road, row in table.items():
            print(f"    {road:10} {row['before']:8.2f} {row['now']:8.2f} {row['before'] / row['now']:10.2f}x")
    return results


def report(results: dict) -> list:
    targets = []
    for part, table in results.items():
        for road, row in table.items():
            ratio = row["before"] / row["now"]
            targets.append((ratio >= 1.0, f"{road}, {part}: before / now = {ratio:.2f}x "
                                          f"(>= 1: at least as fast as {BEFORE})"))
    for met, text in targets:
        print(f"target {'met' if met else 'MISSED':6} {text}")
    return targets


def plot(results: dict, path: Path) -> None:
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from plotting import pyplot

    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(1, len(results), figsize=(11, 3.8))
    width = 0.38
    for ax, (part, table) in zip(axes, results.items()):
        roads = list(table)
        for i, name in enumerate(("before", "now")):
            ax.bar([r + i * width for r in range(len(roads))], [table[road][name] for road in roads], width,
                   label=f"before ({BEFORE})" if name == "before" else "now (outputs as data)")
        ax.set_xticks([r + width / 2 for r in range(len(roads))], roads)
        ax.set_ylabel("microseconds per output")
        ax.set_title(f"{part}")
        ax.set_yscale("log")
    axes[0].legend()
    fig.suptitle("Outputs on the Python roads (Engine.feed_batch)")
    fig.tight_layout()
    fig.savefig(path)
    print(f"plot: {path}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=10000)
    parser.add_argument("--batch", type=int, default=500)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--worker", choices=ROADS, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(*worker(args.worker, args.events, args.batch))
        return 0
    results = measure(args.events, args.batch, args.repeat)
    targets = report(results)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    (args.out_dir / "output_events.json").write_text(json.dumps(
        {"events": args.events, "batch": args.batch, "repeat": args.repeat, "results": results,
         "targets": [{"met": met, "text": text} for met, text in targets]}, indent=2))
    plot(results, args.out_dir / "output_events.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
