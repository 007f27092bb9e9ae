"""Soak test: memory and the cost per event stay flat on an endless stream through windowed
rules and a negation without a window.

10 million input events (default) are generated inside standalone swipl (not read from a
file) and fed one by one to a compiled program with three windowed rules (a sequence, a
conjunction with a condition, and a two-step hierarchy) and an unwindowed negation under
`recent`. Keys cycle, so every rule keeps
finding matches for the whole run. The runtime may only keep the partial matches of the
last `window + max_delay` seconds; if it forgot nothing, the partial-match store and the
process's resident memory would grow with the number of events.

Every 1% of the run the driver prints the number of stored partial matches
(`rtl_store_size/1`, its peak over the samples of that stretch) and the process RSS (VmRSS). The sample interval is 1/1000 of the run, at most 10,000
events. The table compares the figures at 10%, 50% and 100% of the run (1, 5 and 10 million events by default) with those at 10%.

Usage: python benchmarks/soak.py [--events N] [--out-dir DIR]
Writes DIR/soak.json and DIR/soak.png (default DIR: benchmarks/results).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retalisc.compiler import compile_source  # noqa: E402

# One event per millisecond of event time; windows of a few seconds hold a few thousand
# partial matches each.
PROGRAM = """
% soak test: windowed rules over an endless stream
pair(K) <- (a(K) seq b(K)).2.
hot(S, V) <- (temp(S, V) and smoke(S) where V > 50).1.
alarm(S) <- (hot(S, _) seq pair(S)).6.
% a negation without a window: its store may only hold what can still block a match
q1([property(consumption_policy, recent)]) 'rule:' quiet(K) <- not(temp(K, _)).[smoke(K), b(K)].
"""

KEYS = 1000

DRIVER = r"""
soak_main(N, Keys) :-
    retalis:rtl_output_to(buffer),
    Step is max(1, N // 100),
    Sample is max(1, min(10000, Step // 10)),
    nb_setval(soak_peak, 0),
    nb_setval(soak_sample, Sample),
    get_time(W0),
    soak_loop(1, N, Keys, Step, W0),
    halt(0).

soak_loop(I, N, _, _, _) :- I > N, !.
soak_loop(I, N, Keys, Step, W0) :-
    T is I * 0.001,
    K is (I // 4) mod Keys,
    (   I mod 4 =:= 0 -> E = a(K)
    ;   I mod 4 =:= 1 -> E = temp(K, V), V is (I // 4) mod 100
    ;   I mod 4 =:= 2 -> E = smoke(K)
    ;   E = b(K)
    ),
    retalis:rtl_input(add, E, T, T),
    nb_getval(soak_sample, Sample),
    (   I mod Sample =:= 0
    ->  retalis:rtl_take_output(_),
        retalis:rtl_store_size(S),
        nb_getval(soak_peak, P0),
        ( S > P0 -> nb_setval(soak_peak, S) ; true )
    ;   true
    ),
    (   I mod Step =:= 0
    ->  nb_getval(soak_peak, Peak),
        nb_setval(soak_peak, 0),
        rss_kb(Rss),
        retalis:rtl_stat(derived, D),
        get_time(W),
        Wall is W - W0,
        format("sample ~w ~w ~w ~w ~3f~n", [I, Peak, Rss, D, Wall]),
        flush_output
    ;   true
    ),
    I1 is I + 1,
    soak_loop(I1, N, Keys, Step, W0).

rss_kb(Kb) :-
    read_file_to_string('/proc/self/status', Text, []),
    split_string(Text, "\n", "", Lines),
    member(Line, Lines),
    sub_string(Line, 0, _, _, "VmRSS:"), !,
    split_string(Line, " \t", " \t", Parts),
    exclude(==(""), Parts, [_, Number|_]),
    number_string(Kb, Number).
"""


def run(events: int, out_dir: Path) -> dict:
    work = Path(tempfile.mkdtemp(prefix="retalisc-soak-"))
    program = work / "soak.pl"
    program.write_text(compile_source(PROGRAM, "soak.rtl", module="rtl_soak").prolog)
    driver = work / "soak_driver.pl"
    driver.write_text(DRIVER)
    goal = f"consult('{driver}'), soak_main({events}, {KEYS})"
    command = ["swipl", "-g", goal, str(program), "--no-such-file"]
    samples = []
    interactive = sys.stderr.isatty()
    started = time.time()
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        for line in proc.stdout:
            parts = line.split()
            if not parts or parts[0] != "sample":
                continue
            n, peak, rss, derived, wall = int(parts[1]), int(parts[2]), int(parts[3]), int(parts[4]), float(parts[5])
            samples.append({"events": n, "peak_store": peak, "rss_kb": rss, "derived": derived, "wall_s": wall})
            rate = n / wall if wall > 0 else 0
            progress = (f"{n:>12,} / {events:,} events ({100 * n / events:5.1f}%)  store peak {peak:>8,}  "
                        f"rss {rss / 1024:7.1f} MiB  {rate:,.0f} events/s")
            if interactive:
                print("\r" + progress, end="", file=sys.stderr, flush=True)
            elif len(samples) % 10 == 0:
                print(progress, file=sys.stderr, flush=True)
        stderr = proc.stderr.read()
    if interactive:
        print(file=sys.stderr)
    if proc.returncode != 0 or not samples:
        raise SystemExit(f"soak driver failed (exit {proc.returncode}):\n{stderr}")
    elapsed = time.time() - started
    checkpoints = [c for c in (events // 10, events // 2, events) if c > 0]
    rows = []
    by_events = {s["events"]: s for s in samples}
    for c in checkpoints:
        sample = by_events.get(c) or min(samples, key=lambda s: abs(s["events"] - c))
        rows.append(sample)
    result = {"events": events, "elapsed_s": elapsed, "program": PROGRAM.strip(), "keys": KEYS,
              "checkpoints": rows, "samples": samples}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "soak.json").write_text(json.dumps(result, indent=2) + "\n")
    plot(result, out_dir / "soak.png")
    return result


def rate_at(samples, events: int) -> float:
    """Events per second of wall time over the stretch of samples that ends at `events`."""
    index = min(range(len(samples)), key=lambda i: abs(samples[i]["events"] - events))
    if index == 0:
        first = samples[0]
        return first["events"] / first["wall_s"] if first["wall_s"] > 0 else float("nan")
    a, b = samples[index - 1], samples[index]
    return (b["events"] - a["events"]) / (b["wall_s"] - a["wall_s"]) if b["wall_s"] > a["wall_s"] else float("nan")


def print_table(result: dict) -> None:
    rows = result["checkpoints"]
    base = rows[0]
    samples = result["samples"]
    base_rate = rate_at(samples, base["events"])
    print(f"{'events':>12} {'peak store':>11} {'ratio':>6} {'RSS MiB':>9} {'ratio':>6} {'events/s':>10} {'ratio':>6} "
          f"{'derived':>12}")
    for row in rows:
        store_ratio = row["peak_store"] / base["peak_store"] if base["peak_store"] else float("nan")
        rss_ratio = row["rss_kb"] / base["rss_kb"]
        rate = rate_at(samples, row["events"])
        print(f"{row['events']:>12,} {row['peak_store']:>11,} {store_ratio:>6.2f} {row['rss_kb'] / 1024:>9.1f} "
              f"{rss_ratio:>6.2f} {rate:>10,.0f} {rate / base_rate:>6.2f} {row['derived']:>12,}")
    total = result["events"]
    print(f"\n{total:,} events in {result['elapsed_s']:.0f} s ({total / result['elapsed_s']:,.0f} events/s "
          "including start-up)")
    last = rows[-1]
    flat = (base["peak_store"] == 0 or last["peak_store"] <= 1.2 * base["peak_store"]) and \
        last["rss_kb"] <= 1.2 * base["rss_kb"]
    print("flat (within 20% of the first checkpoint):", "yes" if flat else "NO")
    rate_ratio = rate_at(samples, last["events"]) / base_rate
    print(f"target {'met' if flat else 'MISSED':6} store and RSS flat within 20% from 10% to 100% of the run")
    print(f"target {'met' if rate_ratio >= 0.8 else 'MISSED':6} cost per event flat: events/s at the end "
          f"{rate_ratio:.2f}x the rate at 10% (>= 0.8)")


def plot(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    samples = result["samples"]
    xs = [s["events"] / 1e6 for s in samples]
    fig, left = plt.subplots(figsize=(8, 4.5))
    left.plot(xs, [s["peak_store"] for s in samples], color="tab:blue", label="peak stored partial matches")
    left.set_xlabel("input events (millions)")
    left.set_ylabel("stored partial matches (peak per 1%)", color="tab:blue")
    left.set_ylim(0, 1.3 * max(1, max(s["peak_store"] for s in samples)))
    right = left.twinx()
    right.plot(xs, [s["rss_kb"] / 1024 for s in samples], color="tab:red", label="RSS")
    right.set_ylabel("resident memory (MiB)", color="tab:red")
    right.set_ylim(0, 1.3 * max(s["rss_kb"] for s in samples) / 1024)
    left.set_title(f"retalisc soak: {result['events']:,} events through 3 windowed rules")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--events", type=int, default=10_000_000, help="input events (default 10 million)")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    if args.events < 100:
        parser.error("--events must be at least 100")
    result = run(args.events, args.out_dir)
    print_table(result)
    print(f"\nwrote {args.out_dir / 'soak.json'} and {args.out_dir / 'soak.png'}")


if __name__ == "__main__":
    main()
