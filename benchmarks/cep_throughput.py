"""Event-processing throughput of compiled ELE patterns (issue: foundation, benchmark).

100k input events (default), one per time unit, with ids 1..100, through each pattern inside
a window, on three paths:

  engine    standalone swipl, events already read: the cost of event processing alone
  swipl     standalone `swipl PROGRAM.pl EVENTS.jsonl`, end to end (JSON parsing, output)
  python    the Python driver, `Engine.feed_lines` in batches of 2000 lines, end to end

The baseline, measured in the same run on the same stream, is a program whose only rule
never matches: the floor cost of reading and dispatching an event. Ratios are
events/s of the pattern divided by events/s of the baseline on the same path.

Every pattern runs again under ETALIS's `recent` consumption policy without a window (the
setting ETALIS is usually benchmarked in). Streams named "intervals" give each event a
duration of 0..20 time units (ending at its time unit), so that par and during can match.

Usage: python benchmarks/cep_throughput.py [--events N] [--out-dir DIR]
Writes DIR/cep_throughput.json and DIR/cep_throughput.png.
"""
from __future__ import annotations

import argparse
import json
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from plotting import pyplot  # noqa: E402
from retalisc.compiler import compile_source  # noqa: E402

IDS = 100

# name -> (rules, event kinds, window, stream). `{w}` is the window.
PATTERNS = {
    "baseline (no match)": ("never <- zzz_never.", "abc", None, "atomic"),
    "a seq b seq c": ("out(I, X, Y, Z) <- (a(I, X) seq b(I, Y) seq c(I, Z)).{w}.", "abc", 300, "atomic"),
    "a and b and c": ("out(I, X, Y, Z) <- (a(I, X) and b(I, Y) and c(I, Z)).{w}.", "abc", 150, "atomic"),
    "(a seq b) or c": ("out(I, X, Y) <- ((a(I, X) seq b(I, Y)) or c(I, X)).{w}.", "abc", 300, "atomic"),
    "a seq b where Y<K (10%)": ("out(I, X, Y) <- (a(I, X) seq b(I, Y) where Y < 11).{w}.", "ab", 300, "atomic"),
    "a seq b where Y<K (50%)": ("out(I, X, Y) <- (a(I, X) seq b(I, Y) where Y < 51).{w}.", "ab", 300, "atomic"),
    "a seq b where Y<K (100%)": ("out(I, X, Y) <- (a(I, X) seq b(I, Y) where Y < 101).{w}.", "ab", 300, "atomic"),
    "not(c).[a, b]": ("out(I, X, Y) <- (not(c(I, _)).[a(I, X), b(I, Y)]).{w}.", "abc", 300, "atomic"),
    "a par b": ("out(I, X, Y) <- (a(I, X) par b(I, Y)).{w}.", "ab", 300, "intervals"),
    "a during b": ("out(I, X, Y) <- (a(I, X) during b(I, Y)).{w}.", "ab", 300, "intervals"),
    "3-level hierarchy": ("l1(I, X, Y) <- (a(I, X) seq b(I, Y)).{w}.\n"
                          "l2(I, X, Z) <- (l1(I, X, _) seq c(I, Z)).{w}.\n"
                          "l3(I, X) <- (l2(I, X, _) and a(I, _)).{w}.", "abc", 200, "atomic"),
}
RECENT = ":- set_etalis_flag(event_consumption_policy, recent).\n"


def variants():
    """Every pattern with its window and unrestricted policy, then under `recent` unwindowed."""
    for name, (rule, kinds, window, stream) in PATTERNS.items():
        yield name, rule.replace(".{w}", ".{w}" if window else "").format(w=window), kinds, window, stream
    for name, (rule, kinds, window, stream) in PATTERNS.items():
        if window is None:
            continue
        unwindowed = _strip_window(rule)
        yield f"{name} [recent]", RECENT + unwindowed, kinds, None, stream


def _strip_window(rule: str) -> str:
    """`head <- (P).{w}.` -> `head <- (P).` for every rule of the text."""
    return rule.replace(").{w}.", ").")


ENGINE_GOAL = """
retalis:rtl_output_to(buffer),
read_file_to_terms('{events}', Terms, []),
statistics(cputime, T0),
forall(member(ev(E, S, T), Terms), retalis:rtl_event(E, S, T)),
statistics(cputime, T1),
retalis:rtl_stat(derived, D),
Elapsed is T1 - T0,
format("~w ~w~n", [Elapsed, D]),
halt.
"""


def make_stream(kinds: str, n: int, intervals: bool, seed: int = 7):
    rng = random.Random(seed)
    events = []
    for t in range(1, n + 1):
        kind = rng.choice(kinds)
        start = t - rng.randint(0, 20) if intervals else t
        events.append((f"{kind}({rng.randint(1, IDS)}, {rng.randint(1, 100)})", start, t))
    return events


def write_streams(directory: Path, kinds: str, stream: str, n: int):
    events = make_stream(kinds, n, stream == "intervals")
    jsonl = directory / f"events_{kinds}_{stream}.jsonl"
    terms = directory / f"events_{kinds}_{stream}.pl"
    jsonl.write_text("".join(json.dumps({"event": e, "start": s, "end": t}) + "\n" for e, s, t in events))
    terms.write_text("".join(f"ev({e}, {s}, {t}).\n" for e, s, t in events))
    return jsonl, terms


def measure_engine(program: Path, terms: Path):
    run = subprocess.run(["swipl", "-g", ENGINE_GOAL.format(events=terms), str(program), "--no-such-file"],
                         capture_output=True, text=True, check=True)
    elapsed, derived = run.stdout.split()
    return float(elapsed), int(derived)


def measure_swipl(program: Path, jsonl: Path):
    start = time.perf_counter()
    run = subprocess.run(["swipl", str(program), str(jsonl)], capture_output=True, text=True, check=True)
    elapsed = time.perf_counter() - start
    return elapsed, len(run.stdout.splitlines())


def measure_python(source: str, name: str, jsonl: Path):
    from retalisc.driver.engine import Engine

    engine = Engine.from_source(source, name)
    lines = jsonl.read_text().splitlines()
    start = time.perf_counter()
    derived = 0
    for i in range(0, len(lines), 2000):
        produced, _ = engine.feed_lines("\n".join(lines[i:i + 2000]), i + 1)
        derived += len(produced)
    return time.perf_counter() - start, derived


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=100_000)
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--only", help="run only the patterns whose name contains this text")
    args = parser.parse_args()
    args.out_dir.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="cep-bench-"))
    wanted = {(k, st) for _, k, _, st in PATTERNS.values()}
    streams = {key: write_streams(work, key[0], key[1], args.events) for key in sorted(wanted)}
    runs = list(variants())
    if args.only:
        runs = [r for r in runs if args.only in r[0] or r[0].startswith("baseline")]

    results = []
    for index, (name, source, kinds, window, stream) in enumerate(runs, start=1):
        print(f"[{index}/{len(runs)}] {name} ...", file=sys.stderr, flush=True)
        program = work / f"p{index}.pl"
        program.write_text(compile_source(source, f"p{index}.rtl", output_name=program.name).prolog)
        jsonl, terms = streams[(kinds, stream)]
        row = {"pattern": name, "window": window, "rule": source}
        for path, measure in (("engine", lambda: measure_engine(program, terms)),
                              ("swipl", lambda: measure_swipl(program, jsonl)),
                              ("python", lambda: measure_python(source, f"p{index}.rtl", jsonl))):
            elapsed, derived = measure()
            row[path] = {"seconds": elapsed, "events_per_s": args.events / elapsed, "derived": derived}
        results.append(row)

    base = results[0]
    print(f"\n{args.events:,} events, one per time unit, ids 1..{IDS}; events/s (ratio to the baseline "
          "on the same path)\n")
    header = f"{'pattern':36} {'window':>6} {'derived':>8} {'engine':>18} {'swipl jsonl':>18} {'python':>18}"
    print(header)
    print("-" * len(header))
    for row in results:
        cells = []
        for path in ("engine", "swipl", "python"):
            rate = row[path]["events_per_s"]
            ratio = rate / base[path]["events_per_s"]
            cells.append(f"{rate:>10,.0f} ({ratio:4.2f})")
        window = "-" if row["window"] is None else str(row["window"])
        print(f"{row['pattern']:36} {window:>6} {row['engine']['derived']:>8,} {cells[0]:>18} {cells[1]:>18} "
              f"{cells[2]:>18}")
    seq = next(r for r in results if r["pattern"] == "a seq b seq c")
    target = 100_000
    verdict = "met" if seq["engine"]["events_per_s"] >= target else "NOT met"
    print(f"\ntarget: >= {target:,} events/s for a seq b seq c on standalone swipl (engine path): {verdict} "
          f"({seq['engine']['events_per_s']:,.0f})")
    for row in results:
        derived = {row[p]["derived"] for p in ("engine", "swipl", "python")}
        if len(derived) != 1:
            print(f"warning: paths disagree on derived events for {row['pattern']}: {derived}")

    (args.out_dir / "cep_throughput.json").write_text(json.dumps(results, indent=2))
    plot(results, args.out_dir / "cep_throughput.png", args.events)
    print(f"wrote {args.out_dir / 'cep_throughput.json'} and {args.out_dir / 'cep_throughput.png'}")
    return 0


def plot(results, path: Path, n: int) -> None:
    plt = pyplot()
    if plt is None:
        return
    names = [r["pattern"] for r in results]
    paths = ("engine", "swipl", "python")
    fig, ax = plt.subplots(figsize=(11, 5))
    width = 0.27
    for i, p in enumerate(paths):
        ax.barh([k + i * width for k in range(len(names))], [r[p]["events_per_s"] for r in results], width,
                label=p)
    ax.axvline(100_000, color="red", linestyle="--", linewidth=1, label="target (seq, engine)")
    ax.set_yticks([k + width for k in range(len(names))])
    ax.set_yticklabels(names)
    ax.invert_yaxis()
    ax.set_xlabel("events per second")
    ax.set_title(f"retalisc ELE throughput, {n:,} events")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    sys.exit(main())
