"""Cost of one call through the Python-Prolog bridge, from the thread that made the Engine and
from other threads.

Every bridge call is handed to the one Prolog thread that owns the engine (SWI-Prolog 9.0.4
cannot run one engine from several OS threads), so a call pays a handoff whichever thread makes
it. This measures that cost: `Bridge.apply` of a trivial goal (`atom_length/2`) and
`Engine.feed` of one event that matches nothing, N times from the main thread, then from a
second thread, then from four threads at once (calls serialised by the engine). The figure is
microseconds per call (median of --repeat runs).

Targets: a call from another thread costs at most 2x a call from the main thread (the handoff
must not wait for the GIL's 5 ms switch interval), and a trivial call stays under 200 us.

Usage: python benchmarks/bridge_calls.py [--calls N] [--repeat R] [--out-dir DIR]
Writes DIR/bridge_calls.json and DIR/bridge_calls.png.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retalisc.driver.bridge import Bridge  # noqa: E402
from retalisc.driver.engine import Engine  # noqa: E402

PROGRAM = "never(X) <- zzz_never(X).\n"


def per_call(call, calls: int) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        call()
    return (time.perf_counter() - start) / calls * 1e6


def in_threads(call, calls: int, threads: int) -> float:
    """Microseconds per call when `threads` threads make `calls` calls each at once."""
    workers = [threading.Thread(target=lambda: [call() for _ in range(calls)]) for _ in range(threads)]
    start = time.perf_counter()
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    return (time.perf_counter() - start) / (calls * threads) * 1e6


def measure(calls: int, repeat: int) -> dict:
    bridge = Bridge()
    engine = Engine.from_source(PROGRAM, "bridge_bench.rtl")
    clock = iter(range(1, 10**9))
    subjects = {
        "Bridge.apply(atom_length)": lambda: bridge.apply("system", "atom_length", "abc"),
        "Engine.feed(one event)": lambda: engine.feed("a(1)", next(clock)),
    }
    results = {}
    for name, call in subjects.items():
        rows = {"main thread": [], "other thread": [], "4 threads at once": []}
        for _ in range(repeat):
            rows["main thread"].append(per_call(call, calls))
            other = []
            worker = threading.Thread(target=lambda: other.append(per_call(call, calls)))
            worker.start()
            worker.join()
            rows["other thread"].append(other[0])
            rows["4 threads at once"].append(in_threads(call, calls // 4, 4))
        results[name] = {where: statistics.median(values) for where, values in rows.items()}
        print(f"{name}", flush=True)
        for where, value in results[name].items():
            print(f"  {where:18} {value:8.1f} us/call")
    return results


def report(results: dict) -> list:
    targets = []
    for name, row in results.items():
        ratio = row["other thread"] / row["main thread"]
        targets.append((ratio <= 2.0, f"{name}: other thread / main thread = {ratio:.2f} (<= 2)"))
    trivial = results["Bridge.apply(atom_length)"]["main thread"]
    targets.append((trivial < 200, f"trivial call from the main thread {trivial:.1f} us (< 200 us)"))
    for met, text in targets:
        print(f"target {'met' if met else 'MISSED':6} {text}")
    return targets


def plot(results: dict, path: Path) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot", file=sys.stderr)
        return
    names = list(results)
    wheres = list(next(iter(results.values())))
    fig, ax = plt.subplots(figsize=(7, 3.5))
    width = 0.8 / len(wheres)
    for i, where in enumerate(wheres):
        ax.bar([n + i * width for n in range(len(names))], [results[name][where] for name in names],
               width, label=where)
    ax.set_xticks([n + width for n in range(len(names))], names)
    ax.set_ylabel("microseconds per call")
    ax.set_title("Bridge call cost by calling thread")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    print(f"plot: {path}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    results = measure(args.calls, args.repeat)
    targets = report(results)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    (args.out_dir / "bridge_calls.json").write_text(json.dumps(
        {"results": results, "targets": [{"met": met, "text": text} for met, text in targets]}, indent=2))
    plot(results, args.out_dir / "bridge_calls.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
