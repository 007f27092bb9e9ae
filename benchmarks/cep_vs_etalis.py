"""Event processing end to end, side by side with the original ETALIS engine in the same run.

The same stream (N events `a/b/c(Id, V)`, ids 1..100, values 1..100, one per time unit) goes
through five patterns under ETALIS's `recent` consumption policy, on both sides:

  P0 no match            p0(I) <- zzz(I).
  P1 sequence            p1(I, X, Y, Z) <- a(I, X) seq b(I, Y) seq c(I, Z).
  P3 negation            p3(I, X, Y) <- (a(I, X) seq b(I, Y)) cnot c(I, _).
  P4 disjunction         p4(I, X, Y) <- (a(I, X) seq b(I, Y)) or c(I, X).
  P5 condition (10 %)    p5(I, X, Y) <- a(I, X) seq b(I, Y) where (Y < 11).

Paths, CPU seconds (so that other jobs on the machine count less), median of --repeat runs:

  etalis   ETALIS (benchmarks/etalis_bench.pl), events already in memory
  engine   retalisc's compiled program, events already in memory
  swipl    `swipl P.pl EVENTS.jsonl`: reading JSON Lines, processing, writing output
  run      `retalisc run P.rtl --events EVENTS.jsonl` (Python start-up and the compile cache included;
           from the second run on, the program comes from the cache and the run is handed over to swipl)

Targets: swipl >= 10x ETALIS on P1-P5; P1 >= 100k events/s and P0 >= 300k events/s on swipl;
run within 1.3x of swipl. ETALIS is looked for in ../shared/peers/etalis or --etalis DIR; when
it is absent its column is skipped with a message.

Usage: python benchmarks/cep_vs_etalis.py [--events N] [--repeat K] [--etalis DIR] [--out-dir DIR]
                                          [--only P3 ...]
Writes DIR/cep_vs_etalis.json and DIR/cep_vs_etalis.png.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from cep_throughput import ENGINE_GOAL, make_stream  # noqa: E402
from plotting import pyplot  # noqa: E402
from retalisc.compiler import compile_source  # noqa: E402

PATTERNS = {
    "P0 no match": "p0(I) <- zzz(I).",
    "P1 a seq b seq c": "p1(I, X, Y, Z) <- a(I, X) seq b(I, Y) seq c(I, Z).",
    "P3 (a seq b) cnot c": "p3(I, X, Y) <- (a(I, X) seq b(I, Y)) cnot c(I, _).",
    "P4 (a seq b) or c": "p4(I, X, Y) <- (a(I, X) seq b(I, Y)) or c(I, X).",
    "P5 where 10 %": "p5(I, X, Y) <- a(I, X) seq b(I, Y) where (Y < 11).",
}
RECENT = ":- set_etalis_flag(event_consumption_policy, recent).\n"
PATHS = ("etalis", "engine", "swipl", "run")
DEFAULT_ETALIS = ROOT.parent / "shared" / "peers" / "etalis"


def child_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_cpu(command, **kwargs):
    """Run a command; its CPU seconds (user + system) and its completed process."""
    before = child_cpu()
    done = subprocess.run(command, capture_output=True, text=True, **kwargs)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, command))} failed:\n{done.stderr[-2000:]}")
    return child_cpu() - before, done


def measure_etalis(etalis: Path, rules: Path, terms: Path):
    _, done = run_cpu(["swipl", "--traditional", "-q", str(ROOT / "benchmarks" / "etalis_bench.pl"),
                       str(etalis), "recent", str(rules), str(terms)])
    seconds, detections = done.stdout.split()
    return float(seconds), int(detections)


def measure_engine(program: Path, terms: Path):
    _, done = run_cpu(["swipl", "-g", ENGINE_GOAL.format(events=terms), str(program), "--no-such-file"])
    seconds, derived = done.stdout.split()
    return float(seconds), int(derived)


def measure_swipl(program: Path, jsonl: Path):
    seconds, done = run_cpu(["swipl", str(program), str(jsonl)])
    return seconds, len(done.stdout.splitlines())


def measure_run(source: Path, jsonl: Path):
    seconds, done = run_cpu([sys.executable, "-m", "retalisc", "run", str(source), "--events", str(jsonl),
                             "--no-progress"], env={**os.environ, "PYTHONPATH": str(ROOT)})
    return seconds, len(done.stdout.splitlines())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=100_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--etalis", type=Path, default=DEFAULT_ETALIS)
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--only", nargs="*", help="run only these patterns (P0 P1 P3 P4 P5); P0 and P1 always run")
    args = parser.parse_args()
    args.out_dir.mkdir(parents=True, exist_ok=True)
    etalis = args.etalis if (args.etalis / "src" / "etalis.P").exists() else None
    if etalis is None:
        print(f"ETALIS not found at {args.etalis} (pass --etalis DIR): its column is skipped", file=sys.stderr)
    work = Path(tempfile.mkdtemp(prefix="cep-vs-etalis-"))
    events = make_stream("abc", args.events, False)
    jsonl, terms = work / "events.jsonl", work / "events.pl"
    jsonl.write_text("".join(json.dumps({"event": e, "t": t}) + "\n" for e, _, t in events))
    terms.write_text("".join(f"ev({e}, {s}, {t}).\n" for e, s, t in events))

    load_before = os.getloadavg()
    patterns = {name: rule for name, rule in PATTERNS.items()
                if not args.only or name[:2] in set(args.only) | {"P0", "P1"}}
    results = []
    for index, (name, rule) in enumerate(patterns.items(), start=1):
        source = work / f"p{index}.rtl"
        source.write_text(RECENT + rule + "\n")
        rules = work / f"p{index}.event"
        rules.write_text(rule + "\n")
        program = work / f"p{index}.pl"
        program.write_text(compile_source(source.read_text(), str(source), output_name=program.name).prolog)
        measures = {"etalis": lambda: measure_etalis(etalis, rules, terms),
                    "engine": lambda: measure_engine(program, terms),
                    "swipl": lambda: measure_swipl(program, jsonl),
                    "run": lambda: measure_run(source, jsonl)}
        row = {"pattern": name, "rule": rule}
        for path in PATHS:
            if path == "etalis" and etalis is None:
                continue
            runs = []
            for k in range(args.repeat):
                print(f"[{index}/{len(patterns)}] {name}: {path} {k + 1}/{args.repeat} ...", file=sys.stderr,
                      flush=True)
                runs.append(measures[path]())
            seconds = statistics.median(s for s, _ in runs)
            row[path] = {"seconds": seconds, "events_per_s": args.events / max(seconds, 1e-9),
                         "derived": runs[0][1]}
        results.append(row)

    load = {"before": load_before, "after": os.getloadavg()}
    empty = work / "empty.jsonl"
    empty.write_text("")
    startup = statistics.median(measure_swipl(work / "p1.pl", empty)[0] for _ in range(args.repeat))
    report(results, args.events, etalis is not None)
    per_line = 1e6 * (results[0]["swipl"]["seconds"] - startup) / args.events
    print(f"start-up: swipl with the P0 program on an empty file takes {startup:.3f} CPU s; "
          f"the rest of P0 is {per_line:.2f} us per line")
    print("load average (1, 5, 15 min): before {before}, after {after} (CPU times grow on a busy machine)".format(
        **{k: ", ".join(f"{x:.2f}" for x in v) for k, v in load.items()}))
    summary = {"events": args.events, "load_average": load, "startup_seconds": startup, "results": results}
    (args.out_dir / "cep_vs_etalis.json").write_text(json.dumps(summary, indent=2))
    plot(results, args.out_dir / "cep_vs_etalis.png", args.events)
    print(f"wrote {args.out_dir / 'cep_vs_etalis.json'} and {args.out_dir / 'cep_vs_etalis.png'}")
    return 0


def report(results, n: int, with_etalis: bool) -> None:
    print(f"\n{n:,} events, recent policy, CPU seconds, events/s (median)\n")
    header = f"{'pattern':24}" + "".join(f"{p:>12}" for p in PATHS) + f"{'derived':>9}{'swipl/ETALIS':>14}"
    print(header)
    print("-" * len(header))
    for row in results:
        cells = "".join(f"{row[p]['events_per_s']:>12,.0f}" if p in row else f"{'-':>12}" for p in PATHS)
        ratio = f"{row['swipl']['events_per_s'] / row['etalis']['events_per_s']:>13.1f}x" if with_etalis else ""
        print(f"{row['pattern']:24}{cells}{row['swipl']['derived']:>9,}{ratio}")
    print()
    for row in results:
        ours = {row[p]["derived"] for p in ("engine", "swipl", "run")}
        if len(ours) != 1:
            print(f"warning: the retalisc paths disagree on {row['pattern']}: {sorted(ours)}")
    by_name = {row["pattern"][:2]: row for row in results}

    def target(ok: bool, text: str) -> None:
        print(f"target {'met' if ok else 'MISSED':6} {text}")

    if with_etalis:
        for row in results[1:]:
            ratio = row["swipl"]["events_per_s"] / row["etalis"]["events_per_s"]
            target(ratio >= 10, f"{row['pattern']}: swipl end to end >= 10x ETALIS ({ratio:.1f}x)")
    p1 = by_name["P1"]["swipl"]["events_per_s"]
    target(p1 >= 100_000, f"P1 swipl end to end >= 100,000 events/s ({p1:,.0f})")
    p0 = by_name["P0"]["swipl"]["events_per_s"]
    target(p0 >= 300_000, f"P0 swipl end to end >= 300,000 events/s ({p0:,.0f})")
    for row in results:
        ratio = row["run"]["seconds"] / row["swipl"]["seconds"]
        target(ratio <= 1.3, f"{row['pattern']}: retalisc run within 1.3x of swipl ({ratio:.2f}x)")


def plot(results, path: Path, n: int) -> None:
    plt = pyplot()
    if plt is None:
        return
    names = [r["pattern"] for r in results]
    paths = [p for p in PATHS if p in results[0]]
    fig, ax = plt.subplots(figsize=(10, 5))
    width = 0.8 / len(paths)
    for i, p in enumerate(paths):
        ax.barh([k + i * width for k in range(len(names))], [r[p]["events_per_s"] for r in results], width, label=p)
    ax.set_xscale("log")
    ax.set_yticks([k + width * (len(paths) - 1) / 2 for k in range(len(names))])
    ax.set_yticklabels(names)
    ax.invert_yaxis()
    ax.set_xlabel("events per second (CPU time, log scale)")
    ax.set_title(f"retalisc and ETALIS, {n:,} events, recent policy")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    sys.exit(main())
