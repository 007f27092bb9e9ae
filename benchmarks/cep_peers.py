"""Event processing beside the engines a practitioner would pick instead: Flink CEP and ETALIS measured
in the same interleaved run, Esper's figures (measured outside the project) as the target.

The stream is cep_vs_etalis.py's (N events `a/b/c(Id, V)`, ids 1..100, values 1..100, one per time
unit), at 100k and 1M events; the patterns are P0-P5 (retalisc and ETALIS under `recent`):

  P0 no match            p0(I) <- zzz(I).
  P1 sequence            p1(I, X, Y, Z) <- a(I, X) seq b(I, Y) seq c(I, Z).
  P2 conjunction         p2(I, X, Y, Z) <- a(I, X) and b(I, Y) and c(I, Z).
  P3 negation            p3(I, X, Y) <- (a(I, X) seq b(I, Y)) cnot c(I, _).
  P4 disjunction         p4(I, X, Y) <- (a(I, X) seq b(I, Y)) or c(I, X).
  P5 condition (10 %)    p5(I, X, Y) <- a(I, X) seq b(I, Y) where (Y < 11).

Paths (CPU seconds, user + system, so that other jobs on the machine count less; median of --repeat):

  engine    retalisc's compiled program, events already in memory (CPU inside the process)
  swipl     retalisc end to end: `swipl P.pl EVENTS.jsonl` (process CPU measured from outside)
  etalis    ETALIS (benchmarks/etalis_bench.pl, its own process), events in memory; etalis/e2e is the
            process's CPU from outside (loading ETALIS and reading the terms included)
  flink     Flink CEP 2.3.0 (benchmarks/flink_cep_peer/FlinkCepPeer.java, its own JVM, a local mini
            cluster of parallelism 1, `keyBy(Id)`, arrival order): in memory is the process CPU of the
            job over the stream less that of the same job over one event run just before it (a job's
            start and stop excluded; a first one-event job warms the JVM up); flink/e2e is the JVM's CPU from outside
            (JVM start, reading the file, starting the mini cluster included). Modes: `restart`
            (`begin(a, skipPastLastEvent())`) and `each` (`noSkip()`).

Flink's jars come from PyPI's apache-flink-libraries wheel (`pip download`, ~330 MB) into a cache
outside the repository (--cache, default ~/.cache/retalisc-bench); the peer is compiled there with
javac. Where java, javac or the wheel cannot be had, or with --no-flink, the peer is skipped with a
message. Esper 9.0.0 cannot be fetched here (no Maven repository): issue 42's figures for it are
printed as the target, marked as measured outside the project.

Targets (issue 42, against Esper's figures): in memory at least Esper's rate on P0 and within 1.5x of
Esper on P1-P5; end to end at 1M events at least Esper's rate on P1; max RSS at most a quarter of
Esper's. Then the scaling of the in-memory cost per event from the smallest to the largest size, with
the share of garbage collection and (--profile) the top predicates of a profile of P1.

Usage: python benchmarks/cep_peers.py [--sizes 100000 1000000] [--repeat K] [--quick] [--no-flink]
                                      [--no-etalis] [--cache DIR] [--out-dir DIR] [--profile]
                                      [--replot DIR/cep_peers.json]
Writes DIR/cep_peers.json and DIR/cep_peers.png.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from cep_throughput import make_stream  # noqa: E402
from plotting import pyplot  # noqa: E402
from retalisc.compiler import compile_source  # noqa: E402

PATTERNS = {
    "P0": ("no match", "p0(I) <- zzz(I)."),
    "P1": ("a seq b seq c", "p1(I, X, Y, Z) <- a(I, X) seq b(I, Y) seq c(I, Z)."),
    "P2": ("a and b and c", "p2(I, X, Y, Z) <- a(I, X) and b(I, Y) and c(I, Z)."),
    "P3": ("(a seq b) cnot c", "p3(I, X, Y) <- (a(I, X) seq b(I, Y)) cnot c(I, _)."),
    "P4": ("(a seq b) or c", "p4(I, X, Y) <- (a(I, X) seq b(I, Y)) or c(I, X)."),
    "P5": ("a seq b where 10 %", "p5(I, X, Y) <- a(I, X) seq b(I, Y) where (Y < 11)."),
}

# What each engine's semantics computes, one sentence a pattern (the counts differ: compare cost per event).
SEMANTICS = {
    "P0": "every engine drops each event (no rule listens to zzz); no detection anywhere.",
    "P1": "retalisc/ETALIS (recent): at each c, one p1 with the newest b of that Id that has an a before it, "
          "paired with that b's newest a; Flink restart: a -> b -> c per Id with relaxed contiguity, the "
          "first b and the first c after the a, and after a match the next one starts past its c "
          "(Esper's `every (a -> b -> c)` per Id reads the same); Flink each: every a starts its own match.",
    "P2": "retalisc/ETALIS (recent): whenever the last of the three kinds arrives, one p2 with the newest "
          "of the other two kinds, in any order; Flink has no conjunction: e1 -> e2 -> e3 with three "
          "distinct kinds (an iterative condition), the first of each kind after e1.",
    "P3": "retalisc/ETALIS (recent): at each b, one p3 with the newest a when no c lies between them; "
          "Flink: a, notFollowedBy(c), followedBy(b): a c discards the pending a.",
    "P4": "retalisc/ETALIS (recent): one p4 per c and one per b that has a pending a; Flink has no "
          "disjunction of sequences: two patterns (a -> b, and c alone) on the same keyed stream, counted "
          "together.",
    "P5": "retalisc/ETALIS (recent): at each b, the newest a paired, then the where filter keeps 10 %; "
          "Flink: the condition belongs to the b state, so a pending a waits for the first b with V < 11 "
          "(fewer discarded pairs, different matches).",
}
RECENT_NOTE = ("Neither Esper nor Flink CEP can express `recent` (a stack of pending partners, newest "
               "first), so their counts differ from retalisc's: compare the cost per event. ETALIS's count is of its fired "
               "events not in the input, the intermediate events of its binarised rules included.")

# Issue 42's figures for Esper 9.0.0 (consuming reading `every (a -> b -> c)` per Id), measured outside
# the project on this machine at 100k events (1M for P1 end to end and in memory): events per CPU second.
ESPER = {
    "memory": {"P0": 2_500_000, "P1": 357_000, "P2": 167_000, "P3": 263_000, "P4": 250_000, "P5": 476_000},
    "e2e": {"P0": 42_000, "P1": 38_000, "P2": 29_000, "P3": 32_000, "P4": 31_000, "P5": 33_000},
    "memory_1m_P1": 741_000,
    "e2e_1m_P1": 169_000,
    "rss_mb": (109, 219),
}
FLINK_VERSION = "2.3.0"
FLINK_JARS = (f"flink-dist-{FLINK_VERSION}.jar", f"flink-cep-{FLINK_VERSION}.jar")
PEER_SOURCE = ROOT / "benchmarks" / "flink_cep_peer" / "FlinkCepPeer.java"
JVM_OPTIONS = ["--add-opens", "java.base/java.util=ALL-UNNAMED", "--add-opens", "java.base/java.lang=ALL-UNNAMED"]
DEFAULT_ETALIS = next((d / "shared" / "peers" / "etalis" for d in ROOT.parents
                       if (d / "shared" / "peers" / "etalis" / "src" / "etalis.P").exists()),
                      ROOT.parent / "shared" / "peers" / "etalis")

ENGINE_GOAL = """
retalis:rtl_output_to(buffer),
read_file_to_terms('{events}', Terms, []),
garbage_collect,
statistics(cputime, T0),
statistics(garbage_collection, [_, _, G0|_]),
statistics(clause_garbage_collection, [_, _, C0|_]),
forall(member(ev(E, S, T), Terms), retalis:rtl_event(E, S, T)),
statistics(cputime, T1),
statistics(garbage_collection, [_, _, G1|_]),
statistics(clause_garbage_collection, [_, _, C1|_]),
retalis:rtl_stat(derived, D),
retalis:rtl_store_size(Stored),
Elapsed is T1 - T0,
GC is (G1 - G0) / 1000,
CGC is (C1 - C0) / 1000,
format("~w ~w ~w ~w ~w~n", [Elapsed, D, GC, CGC, Stored]),
halt.
"""
PROFILE_GOAL = """
retalis:rtl_output_to(buffer),
read_file_to_terms('{events}', Terms, []),
profile(forall(member(ev(E, S, T), Terms), retalis:rtl_event(E, S, T)), [top({top}), cumulative(false)]),
halt.
"""


TIME = Path("/usr/bin/time")


def run_process(command, **kwargs):
    """Run a command in its own process: (CPU seconds user + system, max RSS in MB, wall seconds, stdout).

    The CPU is the process's (and its children's) from wait4. Linux carries a process's maximum RSS
    across exec, so a child forked from this Python would report Python's pages too: the RSS is
    /usr/bin/time's figure for the command (forked from time, a small process) where it is installed."""
    start = time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err, \
            tempfile.NamedTemporaryFile("w+", suffix=".rss") as rss:
        prefix = [str(TIME), "-f", "%M", "-o", rss.name] if TIME.exists() else []
        proc = subprocess.Popen([*prefix, *command], stdout=out, stderr=err, text=True, **kwargs)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - start
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
        lines = Path(rss.name).read_text().split()
        max_kb = int(lines[-1]) if prefix and lines and lines[-1].isdigit() else usage.ru_maxrss
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, command))} failed:\n{stderr[-3000:]}")
    return usage.ru_utime + usage.ru_stime, max_kb / 1024, wall, stdout


# --- the Flink CEP peer: fetched, extracted and compiled on demand, outside the repository ----------

def flink_peer(cache: Path, wheel: Path | None) -> tuple[list[str] | None, str]:
    """The java command line of the peer (without its arguments), or None and why it is skipped."""
    java, javac = shutil.which("java"), shutil.which("javac")
    if java is None or javac is None:
        return None, "java/javac not found"
    home = cache / f"flink-{FLINK_VERSION}"
    lib, classes = home / "lib", home / "classes"
    jars = [lib / name for name in FLINK_JARS]
    if not all(jar.exists() for jar in jars):
        if wheel is None:
            found = sorted((cache / "wheel").glob(f"apache_flink_libraries-{FLINK_VERSION}-*.whl"))
            if not found:
                print(f"fetching apache-flink-libraries {FLINK_VERSION} from PyPI into {cache / 'wheel'} "
                      "(~330 MB, once) ...", file=sys.stderr, flush=True)
                done = subprocess.run([sys.executable, "-m", "pip", "download", f"apache-flink-libraries=={FLINK_VERSION}",
                                       "--no-deps", "-d", str(cache / "wheel")], capture_output=True, text=True)
                if done.returncode != 0:
                    return None, f"pip download apache-flink-libraries failed: {done.stderr.strip()[-300:]}"
                found = sorted((cache / "wheel").glob(f"apache_flink_libraries-{FLINK_VERSION}-*.whl"))
            if not found:
                return None, "no apache-flink-libraries wheel"
            wheel = found[-1]
        lib.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(wheel) as archive:
            for name in FLINK_JARS:
                with archive.open(f"pyflink/lib/{name}") as src, open(lib / name, "wb") as dst:
                    shutil.copyfileobj(src, dst)
    classpath = ":".join(map(str, jars))
    built = classes / "FlinkCepPeer.class"
    if not built.exists() or built.stat().st_mtime < PEER_SOURCE.stat().st_mtime:
        classes.mkdir(parents=True, exist_ok=True)
        done = subprocess.run([javac, "-nowarn", "-cp", classpath, "-d", str(classes), str(PEER_SOURCE)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            return None, f"javac failed: {done.stderr.strip()[-500:]}"
    return [java, *JVM_OPTIONS, "-cp", f"{classpath}:{classes}", "FlinkCepPeer"], ""


# --- the measures ---------------------------------------------------------------------------------

def measure_engine(program: Path, terms: Path) -> dict:
    _, _, _, out = run_process(["swipl", "-g", ENGINE_GOAL.format(events=terms), str(program), "--no-such-file"])
    seconds, derived, gc, clause_gc, stored = out.split()
    return {"seconds": float(seconds), "derived": int(derived), "gc_seconds": float(gc),
            "clause_gc_seconds": float(clause_gc), "stored": int(stored)}


def measure_swipl(program: Path, jsonl: Path) -> dict:
    seconds, rss, wall, out = run_process(["swipl", str(program), str(jsonl)])
    return {"seconds": seconds, "derived": len(out.splitlines()), "rss_mb": rss, "wall": wall}


def measure_etalis(etalis: Path, rules: Path, terms: Path) -> dict:
    outside, rss, wall, out = run_process(["swipl", "--traditional", "-q", str(ROOT / "benchmarks" / "etalis_bench.pl"),
                                           str(etalis), "recent", str(rules), str(terms)])
    seconds, detections = out.split()
    return {"seconds": float(seconds), "derived": int(detections), "e2e_seconds": outside, "rss_mb": rss, "wall": wall}


def measure_flink(command: list[str], events: Path, pattern: str, mode: str) -> dict:
    outside, rss, wall, out = run_process([*command, str(events), pattern, mode])
    line = json.loads(out.strip().splitlines()[-1])
    return {"seconds": max(line["job_cpu"] - line["baseline_cpu"], 1e-3), "derived": line["detections"],
            "e2e_seconds": outside, "rss_mb": rss, "wall": wall, "job_cpu": line["job_cpu"],
            "baseline_cpu": line["baseline_cpu"]}


def write_stream(work: Path, n: int):
    events = make_stream("abc", n, False)
    jsonl, terms, text = work / f"events_{n}.jsonl", work / f"events_{n}.pl", work / f"events_{n}.txt"
    jsonl.write_text("".join(json.dumps({"event": e, "t": t}) + "\n" for e, _, t in events))
    terms.write_text("".join(f"ev({e}, {s}, {t}).\n" for e, s, t in events))
    shape = re.compile(r"(\w)\((\d+), (\d+)\)")
    text.write_text("".join("{} {} {} {}\n".format(*shape.fullmatch(e).groups(), t) for e, _, t in events))
    return jsonl, terms, text


def median_of(runs: list[dict]) -> dict:
    row = dict(runs[0])
    for key in ("seconds", "e2e_seconds", "rss_mb", "gc_seconds", "wall"):
        if key in row:
            row[key] = statistics.median(r[key] for r in runs)
    if "rss_mb" in row:
        row["rss_mb"] = max(r["rss_mb"] for r in runs)
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--patterns", nargs="+", default=list(PATTERNS), help="at the sizes but the largest")
    parser.add_argument("--large-patterns", nargs="+", default=["P0", "P1", "P3"],
                        help="the patterns run at the largest size (of many sizes)")
    parser.add_argument("--flink-modes", nargs="+", default=["restart", "each"], choices=["restart", "each"],
                        help="Flink skip strategies at the sizes but the largest (there: restart only)")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--quick", action="store_true", help="1,000 events, P0 P1 P3, no Flink (a smoke test)")
    parser.add_argument("--no-flink", action="store_true")
    parser.add_argument("--no-etalis", action="store_true")
    parser.add_argument("--etalis", type=Path, default=DEFAULT_ETALIS)
    parser.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "retalisc-bench")
    parser.add_argument("--flink-wheel", type=Path, help="an apache-flink-libraries wheel already downloaded")
    parser.add_argument("--profile", action="store_true", help="profile P1 in memory at the largest size")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--replot", type=Path, help="only draw the plot again from a cep_peers.json")
    args = parser.parse_args()
    if args.replot:
        summary = json.loads(args.replot.read_text())
        results = {int(n): v for n, v in summary["results"].items()}
        plot(results, sorted(results), args.replot.with_suffix(".png"))
        return 0
    if args.quick:
        args.sizes, args.patterns, args.large_patterns, args.no_flink = [1_000], ["P0", "P1", "P3"], [], True
    args.out_dir.mkdir(parents=True, exist_ok=True)
    sizes = sorted(set(args.sizes))

    etalis = None
    if not args.no_etalis:
        etalis = args.etalis if (args.etalis / "src" / "etalis.P").exists() else None
        if etalis is None:
            print(f"ETALIS not found at {args.etalis} (pass --etalis DIR): its column is skipped")
    flink, why = (None, "--no-flink") if args.no_flink else flink_peer(args.cache, args.flink_wheel)
    if flink is None:
        print(f"Flink CEP peer skipped: {why}")

    work = Path(tempfile.mkdtemp(prefix="cep-peers-"))
    programs = {}
    for key, (_, rule) in PATTERNS.items():
        source = work / f"{key.lower()}.rtl"
        source.write_text(":- set_etalis_flag(event_consumption_policy, recent).\n" + rule + "\n")
        (work / f"{key.lower()}.event").write_text(rule + "\n")
        program = work / f"{key.lower()}.pl"
        program.write_text(compile_source(source.read_text(), str(source), output_name=program.name).prolog)
        programs[key] = program

    load_before = os.getloadavg()
    results = {}       # size -> pattern -> path -> measure
    for size in sizes:
        jsonl, terms, text = write_stream(work, size)
        largest = size == sizes[-1] and len(sizes) > 1
        keys = [k for k in PATTERNS if k in (args.large_patterns if largest else args.patterns)]
        modes = ["restart"] if largest else args.flink_modes
        paths = ["engine", "swipl"] + (["etalis"] if etalis else []) + ([f"flink-{m}" for m in modes] if flink else [])
        runs: dict = {k: {p: [] for p in paths} for k in keys}
        for r in range(args.repeat):
            for key in keys:                       # interleaved: every engine on a pattern, then the next
                for path in paths:
                    print(f"[{size:,}] {key} {path} {r + 1}/{args.repeat} ...", file=sys.stderr, flush=True)
                    if path == "engine":
                        runs[key][path].append(measure_engine(programs[key], terms))
                    elif path == "swipl":
                        runs[key][path].append(measure_swipl(programs[key], jsonl))
                    elif path == "etalis":
                        runs[key][path].append(measure_etalis(etalis, work / f"{key.lower()}.event", terms))
                    else:
                        runs[key][path].append(measure_flink(flink, text, key, path.split("-", 1)[1]))
        results[size] = {k: {p: median_of(v) for p, v in runs[k].items()} for k in keys}

    profile = None
    if args.profile and "P1" in results[sizes[-1]]:
        _, _, _, profile = run_process(["swipl", "-g", PROFILE_GOAL.format(events=work / f"events_{sizes[-1]}.pl",
                                                                             top=15),
                                        str(programs["P1"]), "--no-such-file"])
    load = {"before": load_before, "after": os.getloadavg()}
    report(results, sizes, profile)
    print("load average (1, 5, 15 min): before {before}, after {after} (CPU times grow on a busy machine)".format(
        **{k: ", ".join(f"{x:.2f}" for x in v) for k, v in load.items()}))
    summary = {"sizes": sizes, "load_average": load, "esper_outside": ESPER,
               "results": {str(n): v for n, v in results.items()}, "profile": profile}
    (args.out_dir / "cep_peers.json").write_text(json.dumps(summary, indent=2))
    plot(results, sizes, args.out_dir / "cep_peers.png")
    print(f"wrote {args.out_dir / 'cep_peers.json'} and {args.out_dir / 'cep_peers.png'}")
    shutil.rmtree(work, ignore_errors=True)
    return 0


def rate(n: int, cell: dict | None, key: str = "seconds") -> float | None:
    return None if cell is None or key not in cell else n / max(cell[key], 1e-9)


def fmt(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value / 1e6:.2f}M" if value >= 1e6 else f"{value / 1e3:.0f}k" if value >= 1e4 else f"{value:,.0f}"


def table_rows(results, n: int):
    """(label, {pattern: events per CPU second}) of one size, in the issue's layout."""
    by = results[n]
    keys = list(by)
    esper_at = "1M events" if n == 1_000_000 else "100k events"
    rows = [("retalisc in memory", {k: rate(n, by[k].get("engine")) for k in keys}),
            (f"Esper 9.0.0 in memory ({esper_at}, outside the project)", {k: ESPER["memory"].get(k) for k in keys}
             if n != 1_000_000 else {k: ESPER["memory_1m_P1"] if k == "P1" else None for k in keys}),
            ("Flink CEP restart in memory", {k: rate(n, by[k].get("flink-restart")) for k in keys}),
            ("Flink CEP each in memory", {k: rate(n, by[k].get("flink-each")) for k in keys}),
            ("ETALIS in memory", {k: rate(n, by[k].get("etalis")) for k in keys}),
            ("retalisc `swipl P.pl E.jsonl` end to end", {k: rate(n, by[k].get("swipl")) for k in keys}),
            (f"Esper end to end ({esper_at}, outside the project)", {k: ESPER["e2e"].get(k) for k in keys}
             if n != 1_000_000 else {k: ESPER["e2e_1m_P1"] if k == "P1" else None for k in keys}),
            ("Flink CEP restart end to end (JVM start)", {k: rate(n, by[k].get("flink-restart"), "e2e_seconds")
                                                         for k in keys}),
            ("ETALIS end to end (process)", {k: rate(n, by[k].get("etalis"), "e2e_seconds") for k in keys})]
    return keys, [(label, cells) for label, cells in rows if any(v is not None for v in cells.values())]


def report(results, sizes, profile) -> None:
    for n in sizes:
        keys, rows = table_rows(results, n)
        print(f"\n{n:,} events, 100 ids, events per CPU second (median)\n")
        print("| | " + " | ".join(f"{k} {PATTERNS[k][0]}" for k in keys) + " |")
        print("|---|" + "---|" * len(keys))
        for label, cells in rows:
            print(f"| {label} | " + " | ".join(fmt(cells[k]) for k in keys) + " |")
        print("\ndetections and max RSS (MB, end to end):")
        for k in keys:
            cells = results[n][k]
            counts = ", ".join(f"{p} {c['derived']:,}" for p, c in cells.items())
            rss = ", ".join(f"{p} {c['rss_mb']:.0f}" for p, c in cells.items() if "rss_mb" in c)
            print(f"  {k}: {counts}; RSS {rss}")
            if cells["engine"]["derived"] != cells["swipl"]["derived"]:
                print(f"  warning: the retalisc paths disagree on {k}")
    print(f"\nwhat each engine computes ({RECENT_NOTE})")
    for k in results[sizes[0]]:
        print(f"  {k}: {SEMANTICS[k]}")
    print()
    targets(results, sizes)
    scaling(results, sizes, profile)


def target(ok: bool, text: str) -> None:
    print(f"target {'met' if ok else 'MISSED':6} {text}")


def targets(results, sizes) -> None:
    """Issue 42's targets against Esper's figures (measured outside the project): ours from this run."""
    base = 100_000 if 100_000 in results else sizes[0]
    by = results[base]
    note = "" if base == 100_000 else f" (ours at {base:,} events)"
    if "P0" in by:
        ours = rate(base, by["P0"]["engine"])
        target(ours >= ESPER["memory"]["P0"], f"P0 in memory >= Esper's {fmt(ESPER['memory']['P0'])} events/CPU-s "
               f"({fmt(ours)}, {ours / ESPER['memory']['P0']:.2f}x){note}")
    for k in [k for k in by if k != "P0"]:
        ours, esper = rate(base, by[k]["engine"]), ESPER["memory"][k]
        target(ours * 1.5 >= esper, f"{k} in memory within 1.5x of Esper's {fmt(esper)} events/CPU-s "
               f"({fmt(ours)}, Esper {esper / ours:.2f}x ours){note}")
    big = 1_000_000
    if big in results and "P1" in results[big]:
        ours = rate(big, results[big]["P1"]["swipl"])
        target(ours >= ESPER["e2e_1m_P1"], f"P1 end to end at 1M events >= Esper's {fmt(ESPER['e2e_1m_P1'])} "
               f"events/CPU-s ({fmt(ours)}, {ours / ESPER['e2e_1m_P1']:.2f}x)")
    else:
        print("target MISSED P1 end to end at 1M events >= Esper's 169k events/CPU-s (not run at 1M events)")
    rss = max(c["swipl"]["rss_mb"] for n in results for c in results[n].values())
    quarter = ESPER["rss_mb"][0] / 4
    target(rss <= quarter, f"max RSS end to end <= a quarter of Esper's ({ESPER['rss_mb'][0]}-{ESPER['rss_mb'][1]} MB:"
           f" <= {quarter:.0f} MB; ours {rss:.0f} MB)")
    flink = [c["flink-restart"]["rss_mb"] for n in results for c in results[n].values() if "flink-restart" in c]
    if flink:
        print(f"figure Flink CEP max RSS {min(flink):.0f}-{max(flink):.0f} MB; ours {rss:.0f} MB")


def scaling(results, sizes, profile) -> None:
    """The in-memory cost per event at each size, with the shares of garbage collection (stacks) and of
    clause garbage collection (the erased clauses of the stores), and the partial matches stored at the
    end: where a long stream goes."""
    print("\nscaling: retalisc in-memory cost per event (us), shares of garbage collection (stacks) and of"
          " clause garbage collection (the stores' erased clauses), partial matches stored at the end")
    common = [k for k in PATTERNS if all(k in results[n] for n in sizes)]
    for k in common:
        cells = []
        for n in sizes:
            e = results[n][k]["engine"]
            busy = max(e["seconds"], 1e-9)
            cells.append(f"{n:>9,}: {1e6 * e['seconds'] / n:6.2f} us (gc {100 * e['gc_seconds'] / busy:4.1f} %,"
                         f" clause gc {100 * e.get('clause_gc_seconds', 0) / busy:4.1f} %,"
                         f" {e.get('stored', 0):,} stored)")
        growth = ""
        if len(sizes) > 1:
            first, last = (results[n][k]["engine"]["seconds"] / n for n in (sizes[0], sizes[-1]))
            growth = f"  x{last / first:.2f} from {sizes[0]:,} to {sizes[-1]:,}"
        print(f"  {k}: " + "; ".join(cells) + growth)
    if profile:
        print(f"\nprofile of P1 in memory at {sizes[-1]:,} events (SWI-Prolog profiler, self time):")
        print(profile.rstrip())


def plot(results, sizes, path: Path) -> None:
    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(1, len(sizes), figsize=(6 * len(sizes) + 3, 5), squeeze=False, sharex=True)
    colours = {}                                  # one colour a row label, the same in every panel
    for n in sizes:
        for label, _ in table_rows(results, n)[1]:
            colours.setdefault(label.split(" (")[0], f"C{len(colours)}")
    for ax, n in zip(axes[0], sizes):
        keys, rows = table_rows(results, n)
        width = 0.8 / len(rows)
        for i, (label, cells) in enumerate(rows):
            ax.barh([j + i * width for j in range(len(keys))], [cells[k] or 0 for k in keys], width, label=label,
                    color=colours[label.split(" (")[0]], hatch="//" if "outside" in label else None)
        ax.set_xscale("log")
        ax.set_yticks([j + width * (len(rows) - 1) / 2 for j in range(len(keys))])
        ax.set_yticklabels([f"{k} {PATTERNS[k][0]}" for k in keys])
        ax.invert_yaxis()
        ax.set_xlabel("events per CPU second (log scale)")
        ax.set_title(f"{n:,} events (Esper, hatched: measured outside the project)")
    handles = {}                                  # one legend for every panel, right of the last one
    for ax in axes[0]:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label.split(" (")[0], handle)
    axes[0][-1].legend(list(handles.values()), list(handles), fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1))
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    sys.exit(main())
