"""Recovery (docs/recovery.md): what `retalisc run --state` costs.

  (a) throughput of `retalisc run` over a 100,000-event stream (a windowed seq, a negation
      and an SLR memory of 2,500 records read in a condition) without --state, with --state
      at the default interval, and with a snapshot every 10,000 events; CPU seconds of the
      run's process (the machine may be shared). Target: --state at the default interval at
      most 10 % slower than without.
  (b) snapshot size, save time and restore time against the state size: one memory of
      N records (N = 10,000 .. 1,000,000), each record one `v(I)` event; restored into a
      second Engine of the process (another module name, so every clause is rewritten: the
      slow path; the runtime modules also hold what the earlier programs of the process kept).
  (c) restart time for a state of 1,000,000 records: loading the program and restoring the
      snapshot in a new process (`retalisc run --state` does exactly this before reading on).
  (d) active queries (`retalisc aq --state`): snapshot size, save and restore time against the
      size of the answer tables (path/2 over a chain of N edges: N(N+1)/2 answers), restored
      into a new load of the program; and the CPU time of an update script of 3,000 commands
      (tests/test_recovery_aq.py's program and script) without --state, with --state taking
      only the first snapshot, at the default interval and with a snapshot every 100 commands.
      Runs before (b): the process has loaded no event program yet, whose memories the runtime
      modules would still hold (and an AQ snapshot would carry).

Usage: python benchmarks/recovery.py [--quick] [--out-dir DIR]
Writes DIR/recovery.json and DIR/recovery.png (default DIR: benchmarks/results). `--quick`
scales everything down to run in a few seconds (the smoke test).
"""
from __future__ import annotations

import argparse
import json
import os
import random
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.plotting import pyplot  # noqa: E402

THROUGHPUT_PROGRAM = """\
c(X) <- (a(X) seq b(X)).2.
d(X) <- (not(n(X)).[a(X), b(X)]).3.
c_mem(v, v(_)-[], 2500, inf).
e(X, V) <- b(X) where prev(v, v(V)^T, inf).
"""

MEMORY_PROGRAM = "c_mem(v, v(_)-[], {n}, inf).\n"

TARGET = 0.10


def write_events(path: Path, n: int, seed: int = 1) -> None:
    rng = random.Random(seed)
    t = 0.0
    with open(path, "w", encoding="utf-8") as stream:
        for _ in range(n):
            t = round(t + rng.choice([0.01, 0.02, 0.05]), 2)
            kind = rng.choice("abnv")
            stream.write(f'{{"event": "{kind}({rng.randint(0, 20)})", "t": {t}}}\n')


def run_cpu(args) -> float:
    """CPU seconds (user + system) of one `retalisc run` process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-m", "retalisc", "run", *map(str, args)], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def throughput(tmp: Path, n: int, repeats: int, dense_every: int) -> dict:
    program = tmp / "throughput.rtl"
    program.write_text(THROUGHPUT_PROGRAM, encoding="utf-8")
    events = tmp / "events.jsonl"
    write_events(events, n)
    variants = {"without --state": [], "--state (default interval)": [], f"--state every {dense_every:,}": []}
    outputs = {}
    for repeat in range(repeats):                   # interleaved: a busy spell hits all variants
        for name in variants:
            out = tmp / f"out-{len(outputs)}.jsonl"
            args = [program, "--events", events, "--out", out]
            if name != "without --state":
                state = tmp / f"state-{repeat}-{len(outputs)}"
                args += ["--state", state]
                if "every" in name:
                    args += ["--snapshot-every", dense_every]
            variants[name].append(run_cpu(args))
            outputs[name] = out.read_bytes()
    assert len(set(outputs.values())) == 1, "every variant must write the same output"
    best = {name: min(times) for name, times in variants.items()}
    base = best["without --state"]
    slowdown = {name: t / base - 1 for name, t in best.items()}
    return {"events": n, "cpu_seconds": variants, "best": best, "slowdown": slowdown,
            "events_per_second": {name: n / t for name, t in best.items()},
            "target": TARGET, "met": slowdown["--state (default interval)"] <= TARGET}


def snapshot_costs(tmp: Path, sizes) -> list:
    from retalisc.driver.engine import Engine
    rows = []
    for n in sizes:
        engine = Engine.from_source(MEMORY_PROGRAM.format(n=n), name=f"memory{n}.rtl")
        chunk = 50_000
        for first in range(0, n, chunk):
            engine.feed_batch([(f"v({i})", i * 0.001) for i in range(first, min(n, first + chunk))])
        path = tmp / f"memory-{n}.state"
        started = time.perf_counter()
        engine.save_state(path)
        save = time.perf_counter() - started
        other = Engine.from_source(MEMORY_PROGRAM.format(n=n), name=f"memory{n}.rtl")
        started = time.perf_counter()
        other.restore_state(path)
        restore = time.perf_counter() - started
        rows.append({"records": n, "bytes": path.stat().st_size, "save_seconds": save, "restore_seconds": restore})
        print(f"  {n:>9,} records: {path.stat().st_size / 1e6:7.1f} MB, save {save:6.2f} s, restore {restore:6.2f} s",
              file=sys.stderr)
        path.unlink()
    return rows


BUILD_SCRIPT = """
import sys
from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine
n = int(sys.argv[3])
engine = Engine.from_compiled(compile_source(open(sys.argv[1]).read(), "memory.rtl", module="rtl_prog_memory"))
for first in range(0, n, 50_000):
    engine.feed_batch([(f"v({i})", i * 0.001) for i in range(first, min(n, first + 50_000))])
engine.save_state(sys.argv[2])
"""

RESTART_SCRIPT = """
import sys, time
started = time.perf_counter()
from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine
engine = Engine.from_compiled(compile_source(open(sys.argv[1]).read(), "memory.rtl", module="rtl_prog_memory"))
loaded = time.perf_counter()
engine.restore_state(sys.argv[2])
done = time.perf_counter()
print(loaded - started, done - loaded, engine.stats()["events"])
"""


def restart_time(tmp: Path, n: int) -> dict:
    """As a restart of `retalisc run --state`: a new process imports retalisc, compiles and loads
    the program (under the module name it had, as `retalisc run` does) and restores a snapshot
    of n records made by another process that ran only this program."""
    program = tmp / "restart.rtl"
    program.write_text(MEMORY_PROGRAM.format(n=n), encoding="utf-8")
    path = tmp / "restart.state"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-c", BUILD_SCRIPT, str(program), str(path), str(n)], check=True, env=env,
                   capture_output=True)
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", RESTART_SCRIPT, str(program), str(path)], check=True,
                          capture_output=True, text=True, env=env)
    total = time.perf_counter() - started
    load, restore, events = done.stdout.split()
    assert int(events) == n
    return {"records": n, "bytes": path.stat().st_size, "total_seconds": total, "load_seconds": float(load),
            "restore_seconds": float(restore)}


CHAIN_PROGRAM = """\
path(X, Y) :- edge(X, Y).
path(X, Y) :- edge(X, Z), path(Z, Y).
:- dynamic edge/2.
"""


def aq_snapshot_costs(tmp: Path, sizes) -> list:
    from retalisc.driver.active_queries import ActiveQueries
    rows = []
    for n in sizes:
        program = tmp / f"chain{n}.pl"
        program.write_text(CHAIN_PROGRAM + "".join(f"edge({i}, {i + 1}).\n" for i in range(n)), encoding="utf-8")
        script = tmp / f"chain{n}.txt"
        script.write_text("?q path(X, Y).\n", encoding="utf-8")
        aq = ActiveQueries.from_file(program)
        assert aq.run_script_batch(script, 1, 10).status == "done"
        path = tmp / f"chain-{n}.state"
        started = time.perf_counter()
        aq.save_state(path)
        save = time.perf_counter() - started
        again = ActiveQueries.from_file(program)
        started = time.perf_counter()
        again.restore_state(path)
        restore = time.perf_counter() - started
        answers = n * (n + 1) // 2
        assert len(again.answers("q")) == answers
        rows.append({"edges": n, "answers": answers, "bytes": path.stat().st_size, "save_seconds": save,
                     "restore_seconds": restore})
        print(f"  {n:>6,} edges, {answers:>9,} answers: {path.stat().st_size / 1e6:7.2f} MB, save {save:6.2f} s, "
              f"restore {restore:6.2f} s", file=sys.stderr)
        path.unlink()
        again.bridge.once("rtl_aq:aq_reset")      # the tables go: (b) measures event programs alone
    return rows


def aq_cpu(args) -> float:
    """CPU seconds (user + system) of one `retalisc aq` process and its children."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-m", "retalisc", "aq", *map(str, args)], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def aq_throughput(tmp: Path, commands: int, repeats: int) -> dict:
    sys.path.insert(0, str(ROOT / "tests"))
    from test_recovery_aq import PROGRAM, write_script
    program, script = tmp / "aq.pl", tmp / "aq.txt"
    program.write_text(PROGRAM, encoding="utf-8")
    write_script(script, commands, 11)
    variants = {"without --state": [], "--state, first snapshot only": [], "--state (default interval)": [],
                "--state every 100": []}
    outputs = {}
    for repeat in range(repeats):
        for name in variants:
            out = tmp / f"aq-out-{len(outputs)}-{repeat}.jsonl"
            args = [program, "--script", script, "--out", out]
            if name != "without --state":
                args += ["--state", tmp / f"aq-state-{repeat}-{len(outputs)}"]
                if "first" in name:
                    args += ["--snapshot-every", 10 ** 9, "--snapshot-seconds", "inf"]
                elif "every" in name:
                    args += ["--snapshot-every", 100]
            variants[name].append(aq_cpu(args))
            outputs[name] = out.read_bytes()
    assert len(set(outputs.values())) == 1, "every variant must write the same output"
    best = {name: min(times) for name, times in variants.items()}
    base = best["--state, first snapshot only"]
    return {"commands": commands, "cpu_seconds": variants, "best": best,
            "slowdown_against_first_snapshot_only": {name: t / base - 1 for name, t in best.items()}}


def plot(results: dict, path: Path) -> None:
    plt = pyplot()
    if plt is None:
        return
    rows = results["snapshot_costs"]
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    records = [r["records"] for r in rows]
    left.loglog(records, [r["save_seconds"] for r in rows], "o-", label="save")
    left.loglog(records, [r["restore_seconds"] for r in rows], "s-", label="restore")
    left.set_xlabel("records in the state")
    left.set_ylabel("seconds")
    twin = left.twinx()
    twin.loglog(records, [r["bytes"] / 1e6 for r in rows], "^--", color="grey", label="size (MB)")
    twin.set_ylabel("snapshot size (MB)")
    left.legend(loc="upper left")
    left.set_title("snapshot cost against state size")
    t = results["throughput"]
    names = list(t["events_per_second"])
    right.bar(range(len(names)), [t["events_per_second"][n] for n in names], color=["C0", "C1", "C2"])
    right.set_xticks(range(len(names)))
    right.set_xticklabels(names, fontsize=8)
    right.set_ylabel("events / CPU second")
    verdict = "met" if t["met"] else "MISSED"
    right.set_title(f"retalisc run, {t['events']:,} events: default --state "
                    f"{t['slowdown']['--state (default interval)']:+.1%} (target <= 10%: {verdict})", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    quick = args.quick
    with tempfile.TemporaryDirectory(prefix="retalisc-recovery-") as directory:
        tmp = Path(directory)
        print("(a) throughput", file=sys.stderr)
        results = {"throughput": throughput(tmp, 5_000 if quick else 100_000, 1 if quick else 3,
                                            1_000 if quick else 10_000)}
        t = results["throughput"]
        for name, rate in t["events_per_second"].items():
            print(f"  {name:28s} {rate:10,.0f} events/CPU s  {t['slowdown'][name]:+.1%}", file=sys.stderr)
        print(f"  target <= 10%: {'met' if t['met'] else 'MISSED'}", file=sys.stderr)
        print("(d) active queries: snapshot size and time", file=sys.stderr)
        results["aq_snapshot_costs"] = aq_snapshot_costs(tmp, [30] if quick else [50, 100, 150])
        print("    update script with and without --state", file=sys.stderr)
        results["aq_throughput"] = aq_throughput(tmp, 150 if quick else 3000, 1 if quick else 3)
        a = results["aq_throughput"]
        for name, seconds in a["best"].items():
            print(f"  {name:30s} {seconds:7.2f} CPU s  {a['slowdown_against_first_snapshot_only'][name]:+.1%}",
                  file=sys.stderr)
        print("(b) snapshot size and time", file=sys.stderr)
        results["snapshot_costs"] = snapshot_costs(tmp, [1_000, 10_000] if quick else [10_000, 100_000, 1_000_000])
        print("(c) restart", file=sys.stderr)
        results["restart"] = restart_time(tmp, 10_000 if quick else 1_000_000)
        r = results["restart"]
        print(f"  {r['records']:,} records ({r['bytes'] / 1e6:.1f} MB): new process {r['total_seconds']:.2f} s, "
              f"of which load {r['load_seconds']:.2f} s, restore {r['restore_seconds']:.2f} s", file=sys.stderr)
    stem = "recovery_quick" if quick else "recovery"
    (args.out_dir / f"{stem}.json").write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    plot(results, args.out_dir / f"{stem}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
