"""Cost of synchronized rules, with and without delays (thesis 5.2.2, Figures 5.12-5.13).

The thesis's load: 1,900 transform events per second of event time, recorded in one memory of
2,500 records, and 1,000 events per second that each run one `next` query on that memory and
raise one event. Three programs run over generated streams (deterministic seeds):

  (1) unsynchronized  r(K, V) <- q(K)^T where next(tfm, tf(_, V)^_, T, inf).
  (2) synchronized    synchronized(r(K, V), next(tfm, tf(_, V)^_, T, inf), [[tfm, T]]) <- q(K)^T.
      no delay        q(K) is stamped 1 ms before the tf events around it in arrival order, so
                      the memory already holds a record after T: no query waits. (1) runs on
                      the same stream, so (1) and (2) must derive the same events.
  (3) synchronized    the same rule; q(K) is stamped 5 s *after* the tf events around it, so
      5 s delays      its query waits ~5 s for a tf record after T: about 5,000 postponed
                      matches (monitors) at once, woken by 1,900 tf records/s.

Every stream has the same tf events (`tf(F, V)`, four frame ids, one every 1/1900 s) for the
q arrivals plus 5.5 s, so that every query of (3) is released by a memory update before the
input ends; the q events arrive over the first `--seconds` seconds. All programs declare
`max_delay(tf/2, 10)`: the tf events of (3) are 5 s behind the clock (which the q stamps
drive), and a query must be released by the tf record it waits for, not by the clock.

Each program is compiled and loaded in a fresh swipl by a small driver that feeds the stream
with rtl_run_jsonl_file/1 (in files of 1,000 lines, sampling rtl_sync_pending/1 between
them), then rtl_sync_finish(run), as `swipl P.pl EVENTS.jsonl` does; statistics(cputime)
around that is the figure: CPU seconds per second of stream (median of `--repeat` runs).
Targets: (2)/(1) <= 1.3 (the thesis: the cost of synchronization is negligible when no query
is delayed) and (3)/(2) <= 1.3 (the thesis: less than 30% more CPU time).

Usage: python benchmarks/sync.py [--quick] [--seconds S] [--repeat N] [--out-dir DIR]
Writes DIR/sync.json and DIR/sync.png (sync_quick.* with --quick).
"""
from __future__ import annotations

import argparse
import json
import random
import re
import statistics
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path
from typing import Dict, List, Optional

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retalisc.compiler import compile_source  # noqa: E402

TF_RATE = 1900          # tf events per second of event time
Q_RATE = 1000           # q events (queries) per second
MEMORY = 2500           # records of the memory
DELAY = 5.0             # seconds each query of (3) waits
LAG = 0.001             # q stamped this much before the tf around it in (1) and (2)
TAIL = DELAY + 0.5      # tf events after the last q arrival
FRAMES = ("odom", "base", "head", "cam")
CHUNK = 1000            # lines per file fed to rtl_run_jsonl_file/1
TARGET = 1.3

COMMON = f"""c_mem(tfm, tf(_, _)-[], {MEMORY}, inf).
max_delay(tf/2, 10).
"""
PROGRAMS = {
    "unsync": COMMON + "r(K, V) <- q(K)^T where next(tfm, tf(_, V)^_, T, inf).\n",
    "sync": COMMON + "synchronized(r(K, V), next(tfm, tf(_, V)^_, T, inf), [[tfm, T]]) <- q(K)^T.\n",
}
CASES = [  # name, label, program, q stamp offset from its arrival time
    ("unsync", "(1) unsynchronized", "unsync", -LAG),
    ("sync", "(2) synchronized, no delay", "sync", -LAG),
    ("delayed", "(3) synchronized, 5 s delays", "sync", DELAY),
]

DRIVER = r"""
bench_run(Files) :-
    nb_setval(bench_peak, 0),
    garbage_collect,
    statistics(cputime, C0),
    statistics(inferences, I0),
    retalis:rtl_flush_raised,
    forall(member(F, Files), ( retalis:rtl_run_jsonl_file(F), bench_sample )),
    retalis:rtl_sync_finish(run),
    statistics(cputime, C1),
    statistics(inferences, I1),
    flush_output,
    Cpu is C1 - C0, Inf is I1 - I0,
    nb_getval(bench_peak, Peak),
    retalis:rtl_sync_pending(Left),
    format(user_error, "bench cpu ~6f~nbench inferences ~w~nbench peak ~w~nbench left ~w~n",
           [Cpu, Inf, Peak, Left]),
    halt(0).

bench_sample :-
    retalis:rtl_sync_pending(P),
    nb_getval(bench_peak, P0),
    ( P > P0 -> nb_setval(bench_peak, P) ; true ).
"""


def make_stream(seconds: float, q_offset: float, seed: int = 512) -> List[str]:
    """JSON lines in arrival order: tf every 1/TF_RATE s from 0 to seconds + TAIL, q(K) arriving
    at (K + 0.5)/Q_RATE for K < seconds * Q_RATE, stamped at its arrival time + q_offset."""
    rng = random.Random(seed)
    n_tf = int(round((seconds + TAIL) * TF_RATE))
    n_q = int(round(seconds * Q_RATE))
    lines: List[str] = []
    k = 0
    for i in range(n_tf):
        t = i / TF_RATE
        while k < n_q and (k + 0.5) / Q_RATE < t:
            lines.append(json.dumps({"event": f"q({k})", "t": round((k + 0.5) / Q_RATE + q_offset, 6)}))
            k += 1
        value = round(rng.uniform(-10, 10), 3)
        lines.append(json.dumps({"event": f"tf({FRAMES[i % len(FRAMES)]}, {value})", "t": round(t, 6)}))
    assert k == n_q, "the tf stream must outlast the q arrivals"
    return lines


def write_chunks(directory: Path, lines: List[str]) -> List[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    files = []
    for i in range(0, len(lines), CHUNK):
        path = directory / f"part{i // CHUNK:05d}.jsonl"
        path.write_text("\n".join(lines[i:i + CHUNK]) + "\n")
        files.append(path)
    return files


def run_case(program: Path, driver: Path, files: List[Path], output: Path) -> Dict[str, float]:
    listing = ", ".join(f"'{f}'" for f in files)
    goal = f"consult('{driver}'), bench_run([{listing}])"
    with output.open("w") as out:
        proc = subprocess.run(["swipl", "--no-tty", "-q", "-g", goal, str(program), "--no-such-file"],
                              stdout=out, stderr=subprocess.PIPE, text=True, timeout=1200)
    figures = {}
    for line in proc.stderr.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] == "bench":
            figures[parts[1]] = float(parts[2])
    if proc.returncode != 0 or "cpu" not in figures:
        raise RuntimeError(f"{program.name}: exit {proc.returncode}\n{proc.stderr[-3000:]}")
    return figures


R_LINE = re.compile(r"^r\((\d+),\s*(.+)\)$")


def derived_r(output: Path) -> Counter:
    """K -> V written for each r(K, V) event of the output (a Counter of (K, V) pairs)."""
    pairs: Counter = Counter()
    for line in output.read_text().splitlines():
        if not line.strip():
            continue
        record = json.loads(line)
        match = R_LINE.match(record.get("event", ""))
        if match:
            pairs[(int(match.group(1)), match.group(2))] += 1
    return pairs


def run_all(seconds: float, repeat: int, work: Path) -> dict:
    driver = work / "driver.pl"
    driver.write_text(DRIVER)
    programs = {}
    for name, source in PROGRAMS.items():
        path = work / f"sync_{name}.pl"
        path.write_text(compile_source(source, f"sync_{name}.rtl", output_name=path.name).prolog)
        programs[name] = path
    streams: Dict[float, List[Path]] = {}
    stream_seconds = seconds + TAIL
    n_q = int(round(seconds * Q_RATE))
    cases = []
    for name, label, program, offset in CASES:
        if offset not in streams:
            lines = make_stream(seconds, offset)
            streams[offset] = write_chunks(work / f"stream_{len(streams)}", lines)
        files = streams[offset]
        runs = []
        for r in range(repeat):
            print(f"{label}: run {r + 1}/{repeat} ...", file=sys.stderr, flush=True)
            runs.append(run_case(programs[program], driver, files, work / f"out_{name}.jsonl"))
        pairs = derived_r(work / f"out_{name}.jsonl")
        cpu = statistics.median(run["cpu"] for run in runs)
        cases.append({
            "name": name, "label": label, "rule": PROGRAMS[program].strip(), "q_offset_s": offset,
            "cpu_s": cpu, "cpu_runs": [run["cpu"] for run in runs],
            "cpu_per_stream_s": cpu / stream_seconds,
            "inferences": runs[0]["inferences"],
            "peak_pending": int(runs[0]["peak"]), "left_pending": int(runs[0]["left"]),
            "r_events": sum(pairs.values()), "r_keys": len({k for k, _ in pairs}),
            "r_duplicates": sum(1 for c in pairs.values() if c > 1),
            "_pairs": pairs,
        })
    same_12 = cases[0]["_pairs"] == cases[1]["_pairs"]
    for case in cases:
        del case["_pairs"]
    return {"seconds_of_queries": seconds, "stream_seconds": stream_seconds, "tf_per_s": TF_RATE,
            "q_per_s": Q_RATE, "memory_size": MEMORY, "delay_s": DELAY, "queries": n_q,
            "tf_events": int(round(stream_seconds * TF_RATE)), "repeat": repeat,
            "same_events_1_2": same_12, "cases": cases}


def report(res: dict) -> List[tuple]:
    cases = {c["name"]: c for c in res["cases"]}
    print(f"\n{res['queries']:,} queries (q events, {res['q_per_s']:,}/s over {res['seconds_of_queries']:g} s), "
          f"{res['tf_events']:,} tf events ({res['tf_per_s']:,}/s over {res['stream_seconds']:g} s of stream), "
          f"memory of {res['memory_size']:,} records; median of {res['repeat']} run(s)\n")
    header = f"{'case':32} {'CPU s':>8} {'CPU s/stream s':>15} {'inferences':>12} {'peak pending':>13} {'r events':>9}"
    print(header)
    print("-" * len(header))
    for c in res["cases"]:
        print(f"{c['label']:32} {c['cpu_s']:>8.3f} {c['cpu_per_stream_s']:>15.4f} {c['inferences']:>12,.0f} "
              f"{c['peak_pending']:>13,} {c['r_events']:>9,}")
    print()
    targets = []
    r21 = cases["sync"]["cpu_per_stream_s"] / cases["unsync"]["cpu_per_stream_s"]
    r32 = cases["delayed"]["cpu_per_stream_s"] / cases["sync"]["cpu_per_stream_s"]
    targets.append((f"(2)/(1) synchronization without delays costs <= {TARGET}x: ratio {r21:.3f} "
                    f"({cases['sync']['cpu_per_stream_s']:.4f} vs {cases['unsync']['cpu_per_stream_s']:.4f} "
                    "CPU s per stream s)", r21 <= TARGET))
    targets.append((f"(3)/(2) 5 s delays cost <= {TARGET}x (thesis: < +30%): ratio {r32:.3f} "
                    f"({cases['delayed']['cpu_per_stream_s']:.4f} vs {cases['sync']['cpu_per_stream_s']:.4f} "
                    f"CPU s per stream s, peak {cases['delayed']['peak_pending']:,} postponed)", r32 <= TARGET))
    n = res["queries"]
    counts = [c["r_events"] for c in res["cases"]]
    once = all(c["r_events"] == n and c["r_keys"] == n and c["r_duplicates"] == 0 for c in res["cases"])
    targets.append((f"r events: {' / '.join(f'{x:,}' for x in counts)} for {n:,} queries, each exactly once",
                    once))
    targets.append(("(1) and (2) derive the same r(K, V) events", res["same_events_1_2"]))
    expected_peak = DELAY * Q_RATE
    peak = cases["delayed"]["peak_pending"]
    targets.append((f"(3) peak postponed queries {peak:,} (about {expected_peak:,.0f}), none in (1)/(2), "
                    f"none left at the end", abs(peak - expected_peak) <= 0.1 * expected_peak
                    and cases["sync"]["peak_pending"] == 0
                    and all(c["left_pending"] == 0 for c in res["cases"])))
    for text, met in targets:
        print(f"target {'met' if met else 'MISSED':6} {text}")
    res["ratios"] = {"sync/unsync": r21, "delayed/sync": r32}
    res["targets"] = [{"text": t, "met": m} for t, m in targets]
    return targets


def plot(res: dict, path: Path) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot", file=sys.stderr)
        return
    cases = res["cases"]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    colors = ["tab:red", "tab:green", "tab:blue"]
    bars = ax.bar([c["label"] for c in cases], [c["cpu_per_stream_s"] for c in cases], color=colors)
    for bar, c in zip(bars, cases):
        ax.annotate(f"{c['cpu_per_stream_s']:.3f}" + (f"\n{c['peak_pending']:,} postponed" if c["peak_pending"] else ""),
                    (bar.get_x() + bar.get_width() / 2, bar.get_height()), ha="center", va="bottom", fontsize=9)
    base = cases[1]["cpu_per_stream_s"]
    ax.axhline(TARGET * base, color="gray", linestyle="--", linewidth=1, label=f"{TARGET}x (2)")
    ax.set_ylabel("CPU seconds per second of stream")
    ax.set_ylim(0, 1.35 * max(max(c["cpu_per_stream_s"] for c in cases), TARGET * base))
    ax.set_title(f"synchronized next queries: {res['tf_per_s']:,} tf/s, {res['q_per_s']:,} queries/s, "
                 f"memory {res['memory_size']:,}", fontsize=10)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="4 s of queries, one run (a few seconds)")
    parser.add_argument("--seconds", type=float, help="seconds of q arrivals (default 20, quick 4)")
    parser.add_argument("--repeat", type=int, help="runs per case, the median counts (default 3, quick 1)")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)
    seconds = args.seconds or (4.0 if args.quick else 20.0)
    repeat = args.repeat or (1 if args.quick else 3)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="sync-bench-") as tmp:
        res = run_all(seconds, repeat, Path(tmp))
    res["quick"] = args.quick
    report(res)
    name = "sync_quick" if args.quick else "sync"
    (args.out_dir / f"{name}.json").write_text(json.dumps(res, indent=2) + "\n")
    plot(res, args.out_dir / f"{name}.png")
    print(f"wrote {args.out_dir / (name + '.json')} and {args.out_dir / (name + '.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
