"""Latency of a live stream: from an input line written into a pipe to the output line it
causes, through `retalisc run PROGRAM --events -` (standard input read in the runtime's loop),
through the standalone program `swipl PROGRAM.pl -`, and through `retalisc run PROGRAM --events
- --progress` (a progress line makes Python read the lines and hand them to Prolog).

A writer sends event lines at a steady rate (default 2,000 events/s) into the process's
standard input; every event derives one output event that carries the event's number, and a
reader timestamps each output line as it arrives. The latency of an event is the arrival time
of its output minus the time its line was written. Events are paced on the wall clock (the
writer sleeps until each one is due), so they arrive one by one as a robot's sensor messages would; the
process must process and flush each as it comes, batching only what is already waiting.

Target: p99 under 1 ms at 2,000 events/s, for every path.

On a shared machine the tail depends on the other load: each path runs `--runs` times (the
paths taking turns), the figures are the median of the runs, and the load average is
printed and saved with them. The CPU time each process spends per event (Linux) is given
too: it does not depend on the load as much as the latency does.

Usage: python benchmarks/live_latency.py [--rate 2000] [--seconds 5] [--runs 3] [--out-dir DIR] [--quick]
Writes DIR/live_latency.json and DIR/live_latency.png.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PROGRAM = "pong(N) <- ping(N).\n"
TARGET_P99_MS = 1.0
WARMUP = 200                        # events not counted (process start, first calls)


def cpu_seconds(pid: int):
    """User + system CPU time of process `pid` so far (Linux /proc), None elsewhere."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def run_path(command, rate: float, count: int, env):
    """Latencies in ms of `count` events sent at `rate` per second through `command`, and the
    CPU time (s) the process spent on them (None where it cannot be read)."""
    proc = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            env=env, bufsize=0, cwd=ROOT)       # `python -m` imports from the working directory
    received = {}
    ready = threading.Event()

    def reader():
        for raw in proc.stdout:
            now = time.perf_counter()
            line = raw.decode()
            if '"pong(' in line:
                number = int(line.split('"pong(', 1)[1].split(")", 1)[0])
                received[number] = now
                if number == -1:
                    ready.set()
    thread = threading.Thread(target=reader, daemon=True)
    thread.start()
    # the process is ready once it answers a first event
    proc.stdin.write(b'{"event": "ping(-1)", "t": 0}\n')
    if not ready.wait(60):
        proc.kill()
        raise RuntimeError(f"{command[0]} did not answer")
    cpu_before = cpu_seconds(proc.pid)
    sent = {}
    period = 1.0 / rate
    start = time.perf_counter()
    for number in range(count):
        due = start + number * period
        wait = due - time.perf_counter()
        if wait > 0:
            time.sleep(wait)            # sleeping, not spinning: the reader thread needs the GIL
        line = f'{{"event": "ping({number})", "t": {1 + number * period:.6f}}}\n'.encode()
        sent[number] = time.perf_counter()
        proc.stdin.write(line)
    last = time.perf_counter() + 10
    while count - 1 not in received and time.perf_counter() < last:
        time.sleep(0.01)
    cpu_after = cpu_seconds(proc.pid)
    proc.stdin.close()
    proc.wait(timeout=120)
    thread.join(timeout=10)
    missing = [n for n in range(count) if n not in received]
    if missing:
        raise RuntimeError(f"{len(missing)} events produced no output (first: {missing[0]})")
    cpu = cpu_after - cpu_before if cpu_before is not None and cpu_after is not None else None
    return [(received[n] - sent[n]) * 1000 for n in range(WARMUP, count)], cpu


def percentile(values, p):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(p / 100 * (len(ordered) - 1))))]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=2000.0)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--out-dir", default=str(ROOT / "benchmarks" / "results"))
    parser.add_argument("--runs", type=int, default=3,
                        help="runs per path (the paths take turns); the figures are the median of the runs")
    parser.add_argument("--quick", action="store_true", help="one second and one run, for a smoke test")
    args = parser.parse_args()
    sys.setswitchinterval(1e-4)         # the reader thread timestamps lines promptly
    seconds = 1.0 if args.quick else args.seconds
    count = WARMUP + int(args.rate * seconds)
    out_dir = Path(args.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    work = Path(tempfile.mkdtemp(prefix="live-latency-"))
    program = work / "pingpong.rtl"
    program.write_text(PROGRAM)
    subprocess.run([sys.executable, "-m", "retalisc", "compile", str(program), "-o", str(work / "pingpong.pl")],
                   check=True, env=env, cwd=ROOT)
    paths = {
        "retalisc run --events -": [sys.executable, "-m", "retalisc", "run", str(program), "--events", "-",
                                    "--max-delay", "inf"],
        "swipl PROGRAM.pl -": [shutil.which("swipl") or "swipl", str(work / "pingpong.pl"), "--max-delay=inf", "-"],
        # a progress line makes Python read the lines (retalisc/driver/run.py, in_prolog_loop)
        "retalisc run --events - --progress": [sys.executable, "-m", "retalisc", "run", str(program), "--events", "-",
                                               "--max-delay", "inf", "--progress"],
    }
    runs = 1 if args.quick else args.runs
    load_before = os.getloadavg()[0]
    print(f"live latency: {count - WARMUP:,} events at {args.rate:,.0f}/s per path (first {WARMUP} not counted), "
          f"{runs} run(s) per path, the paths taking turns; load average {load_before:.2f} on {os.cpu_count()} CPUs")
    per_run = {name: [] for name in paths}
    for run in range(runs):
        for name, command in paths.items():
            latencies, cpu = run_path(command, args.rate, count, env)
            r = {"p50_ms": statistics.median(latencies), "p90_ms": percentile(latencies, 90),
                 "p99_ms": percentile(latencies, 99), "max_ms": max(latencies),
                 "cpu_us_per_event": None if cpu is None else cpu / count * 1e6, "latencies_ms": latencies}
            per_run[name].append(r)
            cpu_text = "" if cpu is None else f"  CPU {r['cpu_us_per_event']:.0f} us/event"
            print(f"  run {run + 1} {name:36s} p50 {r['p50_ms']:.3f} ms  p90 {r['p90_ms']:.3f} ms  "
                  f"p99 {r['p99_ms']:.3f} ms  max {r['max_ms']:.2f} ms{cpu_text}")
    load_after = os.getloadavg()[0]
    results = {}
    for name, rows in per_run.items():       # the median of the runs; the plot shows the median run
        middle = sorted(rows, key=lambda r: r["p99_ms"])[len(rows) // 2]
        cpus = [r["cpu_us_per_event"] for r in rows if r["cpu_us_per_event"] is not None]
        results[name] = {key: statistics.median(r[key] for r in rows)
                         for key in ("p50_ms", "p90_ms", "p99_ms", "max_ms")}
        results[name]["cpu_us_per_event"] = statistics.median(cpus) if cpus else None
        results[name]["runs"] = [{k: v for k, v in r.items() if k != "latencies_ms"} for r in rows]
        results[name]["latencies_ms"] = middle["latencies_ms"]
    print(f"median of {runs} run(s) (load average {load_before:.2f} before, {load_after:.2f} after):")
    for name, r in results.items():
        verdict = "met" if r["p99_ms"] < TARGET_P99_MS else "MISSED"
        print(f"  {name:36s} p50 {r['p50_ms']:.3f} ms  p99 {r['p99_ms']:.3f} ms  target {verdict}"
              f" (p99 < {TARGET_P99_MS} ms at {args.rate:,.0f} events/s)")
    stem = "live_latency_quick" if args.quick else "live_latency"
    (out_dir / f"{stem}.json").write_text(json.dumps(
        {"rate": args.rate, "events": count - WARMUP, "runs": runs, "cpus": os.cpu_count(),
         "load_average": [load_before, load_after],
         "paths": {n: {k: v for k, v in r.items() if k != "latencies_ms"} for n, r in results.items()}},
        indent=2))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(matplotlib not installed: no plot)")
        return 0
    figure, axis = plt.subplots(figsize=(7, 4))
    for name, r in results.items():
        ordered = sorted(r["latencies_ms"])
        axis.plot(ordered, [100 * (i + 1) / len(ordered) for i in range(len(ordered))], label=name)
    axis.axvline(TARGET_P99_MS, color="grey", linestyle="--", label="target p99 1 ms")
    axis.axhline(99, color="grey", linestyle=":")
    axis.set_xscale("log")
    axis.set_xlabel("latency, input line to output line (ms)")
    axis.set_ylabel("events (%)")
    axis.set_title(f"live latency at {args.rate:,.0f} events/s")
    axis.legend()
    figure.tight_layout()
    figure.savefig(out_dir / f"{stem}.png", dpi=110)
    print(f"wrote {out_dir / (stem + '.json')} and {out_dir / (stem + '.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
