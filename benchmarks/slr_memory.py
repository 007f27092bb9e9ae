"""SLR memory instances: the cost of memorizing, forgetting and querying (thesis 5.2.1-5.2.2).

Reproduces the shapes of the thesis's Figures 5.4-5.11 (P. Ziafati 2015) on a generated
robot stream instead of the NAO rosbag: `tf(Parent, Child, [X, Y, Z], [Qx, Qy, Qz, Qw])`
events at 1900 Hz of event time, the 38 frame pairs of a NAO-like tree in turn, so that one
event in 38 is `tf(head, cam, _, _)` (the thesis: 50 Hz out of 1900 Hz). Every figure is
measured in its own `swipl` process: a compiled program declares the memory instances
(`c_mem/4` facts), a generated driver feeds the events through `rtl_input/4` in chunks and
reads `statistics(process_cputime)` around each chunk (the process, so that the clause
garbage collection SWI-Prolog runs in its gc thread is counted). The baseline is the same
stream through a program without memory instances, in the same benchmark run; "net" costs
are net of it.

  (a) Fig 5.4   0..160 instances of `a(X, Y, Z, W)` (nothing matches): per-event cost vs
                none. Target: within 10% of none.
  (b) Fig 5.5   20 instances of `tf(X, Y, V, Q)` of size 2,500 vs 150,000, cost per chunk
                over the whole run (the large one fills after 150,000 events); once both
                are full their per-event costs must be equal within 10%. Also 20 instances
                `tf(_, _, _, none)` that every event reaches but none unifies with: the
                matching cost alone (the thesis's purple line).
      Fig 5.6   10..40 instances of `tf(X, Y, V, Q)`, size 2,500.
  (c) Fig 5.7   0..640 instances of `tf(head, cam, _, _)`, size 2,500 (full after 95,000
                events): per-event and per-instance cost.
      Fig 5.8   10 `tf(X, Y, V, Q)` vs 320 `tf(head, cam, _, _)` vs both.
  (d) Fig 5.9-5.11  `next` and `prev` on one memory of 128 .. 16,384 (.. 131,072) records
                (queries at random times in its span, net of the empty loop); also on 128
                records with 320 other instances present. Target: cost at 16,384 under
                2x the cost at 128.
  (e)           memory updates (an assertion or a retraction, the thesis's unit) per second
                at steady state, from (b) size 2,500: every event adds one record to each
                of the 20 full memories and forgets one. Counted net of the matching-only
                run (the thesis's method: green minus purple line of Fig 5.5) and net of
                the baseline (matching included). The thesis: ~250k updates/s per core
                (2012). Target >= 500k/s (2x); aim 2.5M/s (10x). For scale, the floor:
                the same assertz/retract of the same clauses in a bare loop.
  (f)           a late event k records late (k = 0 in order, 1, 10, 100, 1000) into a full
                memory of 2,500 and of 150,000 records: the cost grows with k, not with
                the size.

Usage: python benchmarks/slr_memory.py [--quick] [--out-dir DIR]
Writes DIR/slr_memory.json and DIR/slr_memory_*.png (default DIR: benchmarks/results).
`--quick` scales every figure down (smaller memories and windows) to run in a few seconds.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retalisc.compiler import compile_source  # noqa: E402

RATE = 1900                     # tf events per second of event time (the NAO application)
QUERY_RATE = 50                 # tf(head, cam) events per second (memories of (d) and (f))
THESIS_UPDATES_PER_S = 250_000  # thesis 5.2.1: 2,500 updates per 1% of one core

# 38 frame pairs of a NAO-like tree; exactly one is (head, cam).
FRAMES = [
    ("odom", "base_link"), ("base_link", "torso"), ("torso", "neck"), ("neck", "head"),
    ("head", "cam"), ("head", "cam_bottom"), ("head", "gaze"),
    ("torso", "l_shoulder"), ("l_shoulder", "l_bicep"), ("l_bicep", "l_elbow"), ("l_elbow", "l_forearm"),
    ("l_forearm", "l_wrist"), ("l_wrist", "l_hand"), ("l_hand", "l_finger"),
    ("torso", "r_shoulder"), ("r_shoulder", "r_bicep"), ("r_bicep", "r_elbow"), ("r_elbow", "r_forearm"),
    ("r_forearm", "r_wrist"), ("r_wrist", "r_hand"), ("r_hand", "r_finger"),
    ("torso", "l_pelvis"), ("l_pelvis", "l_hip"), ("l_hip", "l_thigh"), ("l_thigh", "l_tibia"),
    ("l_tibia", "l_ankle"), ("l_ankle", "l_foot"), ("l_foot", "l_sole"),
    ("torso", "r_pelvis"), ("r_pelvis", "r_hip"), ("r_hip", "r_thigh"), ("r_thigh", "r_tibia"),
    ("r_tibia", "r_ankle"), ("r_ankle", "r_foot"), ("r_foot", "r_sole"),
    ("base_link", "imu"), ("torso", "sonar_l"), ("torso", "sonar_r"),
]
assert len(FRAMES) == 38 and FRAMES.count(("head", "cam")) == 1
HEAD_CAM = FRAMES.index(("head", "cam"))

DRIVER = r"""
:- use_module(library(lists)).
:- use_module(library(apply)).

@PAIRS@

% The I-th event: `robot` cycles through the 38 frame pairs at @RATE@ Hz, `headcam` is
% tf(head, cam) only at @QRATE@ Hz.
stream_event(robot, I, tf(P, C, [X, Y, 0.5], [0.0, 0.0, S, 1.0]), T) :-
    K is I mod 38,
    pair(K, P, C),
    T is I / @RATE@.0,
    X is (I mod 997) / 997.0,
    Y is (I mod 991) / 991.0,
    S is (I mod 983) / 983.0.
stream_event(headcam, I, tf(head, cam, [X, Y, 0.5], [0.0, 0.0, S, 1.0]), T) :-
    T is I / @QRATE@.0,
    X is (I mod 997) / 997.0,
    Y is (I mod 991) / 991.0,
    S is (I mod 983) / 983.0.

feed([]).
feed([ev(E, T)|Es]) :-
    retalis:rtl_input(add, E, T, T),
    feed(Es).

events(Stream, From, To, Evs) :-
    findall(ev(E, T), ( between(From, To, I), stream_event(Stream, I, E, T) ), Evs).

fill(Stream, From, To, Chunk) :-
    (   From > To
    ->  true
    ;   Upto is min(To, From + Chunk - 1),
        events(Stream, From, Upto, Evs),
        feed(Evs),
        retalis:rtl_take_output(_),
        Next is Upto + 1,
        fill(Stream, Next, To, Chunk)
    ).

records(Total) :-
    aggregate_all(sum(S), rtl_slr:rtl_memory_size(_, S), Total).

% Feed events 1..Total in chunks, timing each chunk.
bench_stream(Stream, Total, Chunk) :-
    retalis:rtl_output_to(buffer),
    bench_chunks(Stream, 1, Total, Chunk),
    records(R),
    format("records ~w~n", [R]),
    halt(0).

bench_chunks(Stream, From, Total, Chunk) :-
    (   From > Total
    ->  true
    ;   To is min(Total, From + Chunk - 1),
        events(Stream, From, To, Evs),
        statistics(inferences, I0),
        statistics(process_cputime, C0),
        feed(Evs),
        statistics(process_cputime, C1),
        statistics(inferences, I1),
        retalis:rtl_take_output(_),
        S is C1 - C0,
        I is I1 - I0,
        format("chunk~w ~15g~ninf~w ~w~n", [To, S, To, I]),
        Next is To + 1,
        bench_chunks(Stream, Next, Total, Chunk)
    ).

% The floor: what 20 memories cost in SWI-Prolog's assertz/retract alone. Instances x Size
% clauses of the records' shape (same keys, the stream's events as templates), then per
% event one assertz and one retract (of the oldest) per instance, timed per chunk.
:- dynamic floor_record/4.

bench_floor(Instances, Size, Total, Chunk) :-
    forall(between(1, Size, I),
           ( stream_event(robot, I, E, T),
             forall(between(1, Instances, H), ( K is H * 1099511627776 + I, assertz(floor_record(K, T, T, E)) )) )),
    From is Size + 1,
    floor_chunks(From, Total, Chunk, Instances, Size),
    halt(0).

floor_chunks(From, Total, Chunk, Instances, Size) :-
    (   From > Total
    ->  true
    ;   To is min(Total, From + Chunk - 1),
        findall(I-ev(E, T), ( between(From, To, I), stream_event(robot, I, E, T) ), Evs),
        statistics(process_cputime, C0),
        floor_feed(Evs, Instances, Size),
        statistics(process_cputime, C1),
        S is C1 - C0,
        format("chunk~w ~15g~n", [To, S]),
        Next is To + 1,
        floor_chunks(Next, Total, Chunk, Instances, Size)
    ).

floor_feed([], _, _).
floor_feed([I-ev(E, T)|Es], Instances, Size) :-
    floor_event(1, Instances, Size, I, E, T),
    floor_feed(Es, Instances, Size).

floor_event(H, Instances, Size, I, E, T) :-
    (   H > Instances
    ->  true
    ;   K is H * 1099511627776 + I,
        assertz(floor_record(K, T, T, E)),
        K0 is K - Size,
        retract(floor_record(K0, _, _, _)),
        H1 is H + 1,
        floor_event(H1, Instances, Size, I, E, T)
    ).

% Fill memory `q`, then time Queries next/prev queries at random times within its span,
% and the same loop without the query; the least of Reps runs of each.
bench_query(Fill, Queries, Reps) :-
    retalis:rtl_output_to(buffer),
    fill(headcam, 1, Fill, 10000),
    rtl_slr:rtl_memory_size(q, Size),
    rtl_slr:rtl_memory_records(q, [_^[_, Lo]|_]),
    Hi is Fill / @QRATE@.0,
    set_random(seed(11)),
    findall(Z, ( between(1, Queries, _), random(R), Z is Lo + R * (Hi - Lo) ), Zs),
    format("size ~w~n", [Size]),
    forall(member(Kind, [loop, next, prev]),
           ( least_time(Reps, Kind, Zs, Seconds, Found),
             format("~w ~15g~n~w_found ~w~n", [Kind, Seconds, Kind, Found]) )),
    halt(0).

least_time(Reps, Kind, Zs, Least, Found) :-
    findall(S-F, ( between(1, Reps, _), time_queries(Kind, Zs, S, F) ), Runs),
    msort(Runs, [Least-Found|_]).

time_queries(Kind, Zs, Seconds, Found) :-
    garbage_collect,
    statistics(process_cputime, C0),
    query_loop(Zs, Kind, 0, Found),
    statistics(process_cputime, C1),
    Seconds is C1 - C0.

query_loop([], _, N, N).
query_loop([Z|Zs], Kind, N0, N) :-
    (   query(Kind, Z) -> N1 is N0 + 1 ; N1 = N0 ),
    query_loop(Zs, Kind, N1, N).

query(loop, Z) :- number(Z).
query(next, Z) :- rtl_slr:next(q, tf(head, cam, _, _)^_, Z, inf).
query(prev, Z) :- rtl_slr:prev(q, tf(head, cam, _, _)^_, Z).

% Fill memory `late` (in order), then time Inserts events K records late: each ends
% between the K-th and the (K+1)-th newest record (K = 0: at the clock, in order). The
% memory stays full, so every insert also forgets the oldest record.
bench_late(Fill, K, Inserts, Chunks) :-
    retalis:rtl_output_to(buffer),
    fill(headcam, 1, Fill, 10000),
    retalis:rtl_clock(Clock),
    (   K =:= 0 -> T = Clock ; T is Clock - (K - 0.5) / @QRATE@.0 ),
    stream_event(headcam, 1, E, _),
    Per is Inserts // Chunks,
    length(Evs, Per),
    maplist(=(ev(E, T)), Evs),
    forall(between(1, Chunks, C),
           ( garbage_collect,
             statistics(process_cputime, C0),
             feed(Evs),
             statistics(process_cputime, C1),
             S is C1 - C0,
             format("chunk~w ~15g~n", [C, S]) )),
    rtl_slr:rtl_memory_size(late, Size),
    format("size ~w~n", [Size]),
    halt(0).
"""


def driver_text() -> str:
    pairs = "\n".join(f"pair({k}, {p}, {c})." for k, (p, c) in enumerate(FRAMES))
    return (DRIVER.replace("@PAIRS@", pairs).replace("@RATE@", str(RATE))
            .replace("@QRATE@", str(QUERY_RATE)))


@dataclass
class Runner:
    work: Path
    log: bool = True
    count: int = 0
    driver: Path = field(init=False)

    def __post_init__(self) -> None:
        self.driver = self.work / "driver.pl"
        self.driver.write_text(driver_text())

    def run(self, label: str, declarations: List[str], goal: str) -> Dict[str, str]:
        """Compile a program with `declarations` (and one rule that never fires), run `goal`
        in a fresh swipl; return its `key value` lines."""
        self.count += 1
        name = f"slr{self.count}"
        source = "never <- zzz_never.\n" + "".join(d + "\n" for d in declarations)
        program = self.work / f"{name}.pl"
        program.write_text(compile_source(source, f"{name}.rtl", output_name=program.name,
                                          module=f"rtl_{name}").prolog)
        if self.log:
            print(f"  [{self.count}] {label} ...", file=sys.stderr, flush=True)
        command = ["swipl", "--no-tty", "-q", "--stack-limit=8g", "-g", f"consult('{self.driver}')",
                   "-g", goal, str(program), "--no-such-file"]
        started = time.time()
        proc = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if self.log:
            print(f"      {time.time() - started:.1f} s", file=sys.stderr, flush=True)
        if proc.returncode != 0 or not proc.stdout.strip():
            raise RuntimeError(f"{label}: swipl failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
        out = {}
        for line in proc.stdout.splitlines():
            parts = line.split()
            if len(parts) == 2:
                out[parts[0]] = parts[1]
        return out


def mems(count: int, pattern: str, size, prefix: str) -> List[str]:
    return [f"c_mem({prefix}{i}, {pattern}-[], {size}, inf)." for i in range(count)]


def chunk_series(out: Dict[str, str], prefix: str = "chunk") -> List[tuple]:
    """[(events so far, figure of the chunk ending there)] in order."""
    rows = [(int(k[len(prefix):]), float(v)) for k, v in out.items() if k.startswith(prefix)]
    return sorted(rows)


@dataclass
class StreamFigure:
    label: str
    instances: int
    series: List[tuple]         # (events fed, chunk seconds)
    chunk: int
    steady_from: int            # events after which the memories are full
    records: int

    def steady(self) -> List[float]:
        return [s for end, s in self.series if end - self.chunk >= self.steady_from]

    inferences: List[tuple] = field(default_factory=list)   # (events fed, chunk inferences)

    def per_event(self) -> float:
        """Per-event CPU seconds: the median chunk after steady_from. (Not the least: the
        clause garbage collector runs in its own thread, so a short chunk may miss its share.)"""
        return statistics.median(self.steady()) / self.chunk

    def spread(self) -> float:
        """Median chunk over least chunk: how noisy the figure is."""
        window = self.steady()
        return statistics.median(window) / min(window)

    def inferences_per_event(self) -> float:
        """Prolog inferences per event once full: a count, free of timing noise (assertz,
        retract and garbage collection are one inference or none)."""
        window = [n for end, n in self.inferences if end - self.chunk >= self.steady_from]
        return statistics.median(window) / self.chunk if window else float("nan")


def stream_figure(runner: Runner, label: str, declarations: List[str], fill: int, window: int, chunk: int,
                  instances: int) -> StreamFigure:
    total = fill + window
    out = runner.run(label, declarations, f"bench_stream(robot, {total}, {chunk})")
    return StreamFigure(label, instances, chunk_series(out), chunk, fill, int(out.get("records", 0)),
                        chunk_series(out, "inf"))


@dataclass
class Config:
    window: int                 # steady-state events measured per stream figure (after the fill)
    chunk: int                  # events per timed chunk
    irrelevant: List[int]       # (a) instance counts
    big: int                    # (b) the large size
    small: int = 2500
    tf_counts: List[int] = field(default_factory=lambda: [10, 20, 30, 40])
    tf_window: int = 15000      # window of the Fig 5.6 runs
    headcam_counts: List[int] = field(default_factory=lambda: [80, 160, 320, 640])
    headcam_size: int = 500     # full after 38 x 500 = 19,000 events
    query_sizes: List[int] = field(default_factory=lambda: [128, 1024, 16384, 131072])
    queries: int = 20000
    late_sizes: List[int] = field(default_factory=lambda: [2500, 150000])
    late_ks: List[int] = field(default_factory=lambda: [0, 1, 10, 100, 1000])
    late_ks_big: List[int] = field(default_factory=lambda: [0, 1, 10, 100, 1000])   # for the larger sizes
    moves: int = 300000         # (f) records moved per figure: inserts = moves / k, within [300, 6000]
    max_inserts: int = 6000


FULL = Config(window=30000, chunk=5000, irrelevant=[20, 40, 80, 160], big=150000)
QUICK = Config(window=3000, chunk=1000, irrelevant=[160], big=5000, tf_counts=[20], tf_window=3000,
               headcam_counts=[640], headcam_size=40, query_sizes=[128, 16384], queries=3000,
               late_sizes=[2500, 10000], late_ks=[0, 10, 100], late_ks_big=[100], moves=30000,
               max_inserts=900)


def run_all(cfg: Config, runner: Runner, quick: bool) -> dict:
    version = subprocess.run(["swipl", "--version"], capture_output=True, text=True).stdout.split()
    res: dict = {"quick": quick, "rate_hz": RATE, "swipl": version[2] if len(version) > 2 else "?"}
    res["baseline"] = stream_figure(runner, "baseline: no memory instances", [], cfg.chunk, cfg.window, cfg.chunk, 0)

    # (a) Fig 5.4
    res["irrelevant"] = [stream_figure(runner, f"(a) {n} x a(X,Y,Z,W)", mems(n, "a(X, Y, Z, W)", 2500, "a"),
                                       cfg.chunk, cfg.window, cfg.chunk, n) for n in cfg.irrelevant]

    # (b) Fig 5.5: the large memories are timed over their whole fill, then both once full.
    sizes = {}
    for size in (cfg.small, cfg.big):
        sizes[size] = stream_figure(runner, f"(b) 20 x tf(X,Y,V,Q) size {size:,}",
                                    mems(20, "tf(X, Y, V, Q)", size, "m"), size, cfg.window, cfg.chunk, 20)
    res["sizes"] = sizes
    res["match_only"] = stream_figure(runner, "(b) 20 x tf(_,_,_,none): reached, never unify",
                                      mems(20, "tf(_, _, _, none)", cfg.small, "u"), cfg.chunk, cfg.window,
                                      cfg.chunk, 20)
    out = runner.run(f"(e) floor: assertz + retract alone, 20 x {cfg.small:,} clauses", [],
                     f"bench_floor(20, {cfg.small}, {cfg.small + cfg.window}, {cfg.chunk})")
    res["floor"] = StreamFigure("floor", 20, chunk_series(out), cfg.chunk, cfg.small, 20 * cfg.small)
    # Fig 5.6
    res["tf_counts"] = [sizes[cfg.small] if n == 20 else
                        stream_figure(runner, f"(b) {n} x tf(X,Y,V,Q) size {cfg.small:,}",
                                      mems(n, "tf(X, Y, V, Q)", cfg.small, "m"), cfg.small, cfg.tf_window,
                                      cfg.chunk, n)
                        for n in cfg.tf_counts]

    # (c) Fig 5.7 and 5.8
    hc_fill = cfg.headcam_size * len(FRAMES)
    res["headcam"] = [stream_figure(runner, f"(c) {n} x tf(head,cam,_,_) size {cfg.headcam_size:,}",
                                    mems(n, "tf(head, cam, _, _)", cfg.headcam_size, "h"), hc_fill, cfg.window,
                                    cfg.chunk, n) for n in cfg.headcam_counts]
    if not quick:
        mixed = mems(10, "tf(X, Y, V, Q)", cfg.small, "m") + mems(320, "tf(head, cam, _, _)", cfg.headcam_size, "h")
        res["mixed"] = stream_figure(runner, "(c) 10 x tf(X,Y,V,Q) + 320 x tf(head,cam,_,_)", mixed,
                                     max(hc_fill, cfg.small), cfg.window, cfg.chunk, 330)

    # (d) Fig 5.9-5.11
    queries = []
    for size in cfg.query_sizes:
        out = runner.run(f"(d) next/prev on {size:,} records", [f"c_mem(q, tf(head, cam, _, _)-[], {size}, inf)."],
                         f"bench_query({size + 100}, {cfg.queries}, 3)")
        queries.append(query_row(size, out, cfg.queries, others=0))
    if not quick:
        out = runner.run("(d) next/prev on 128 records, 320 other instances",
                         ["c_mem(q, tf(head, cam, _, _)-[], 128, inf)."] + mems(320, "tf(head, cam, _, _)", 2500, "h"),
                         f"bench_query(228, {cfg.queries}, 3)")
        queries.append(query_row(128, out, cfg.queries, others=320))
    res["queries"] = queries

    # (f) late arrivals
    late = []
    for size in cfg.late_sizes:
        for k in (cfg.late_ks if size == cfg.late_sizes[0] else cfg.late_ks_big):
            if k >= size // 2:
                continue
            inserts = 3 * (max(300, min(cfg.max_inserts, cfg.moves // max(k, 1))) // 3)
            out = runner.run(f"(f) {k} records late into {size:,}",
                             [f"c_mem(late, tf(head, cam, _, _)-[], {size}, inf)."],
                             f"bench_late({size + 100}, {k}, {inserts}, 3)")
            times = [float(v) for key, v in out.items() if key.startswith("chunk")]
            late.append({"size": size, "k": k, "inserts": inserts, "per_insert": statistics.median(times) / (inserts // 3),
                         "records": int(out["size"])})
    res["late"] = late
    return res


def query_row(size: int, out: Dict[str, str], n: int, others: int) -> dict:
    loop = float(out["loop"]) / n
    row = {"size": size, "records": int(out["size"]), "others": others, "loop": loop}
    for kind in ("next", "prev"):
        row[kind] = float(out[kind]) / n
        row[kind + "_net"] = row[kind] - loop
        row[kind + "_found"] = int(out[kind + "_found"])
    return row


def us(seconds: float) -> str:
    return f"{seconds * 1e6:9.3f} us"


def report(res: dict, cfg: Config) -> List[tuple]:
    """Print the table; return [(target text, met)]."""
    targets = []
    base = res["baseline"].per_event()
    print(f"\nSLR memory instances; robot stream of tf/4 events at {RATE} Hz (1 in 38 is tf(head, cam, _, _)); "
          f"process CPU per event, median of the {cfg.chunk:,}-event chunks of {cfg.window:,} events once the "
          f"memories are full (spread: median chunk / least chunk; inferences per event)\n")
    print(f"{'figure':58} {'per event':>12} {'ratio':>7} {'net':>12} {'spread':>7} {'inferences':>10}")
    print("-" * 111)

    def row(label, cost, fig=None, extra=""):
        spread = f"{fig.spread():7.2f}" if fig is not None else " " * 7
        inferences = f"{fig.inferences_per_event():10.1f}" if fig is not None else " " * 10
        print(f"{label:58} {us(cost):>12} {cost / base:7.3f} {us(cost - base):>12} {spread} {inferences}{extra}")

    row("baseline: no memory instances", base, res["baseline"])
    for f in res["irrelevant"]:
        row(f"(a) {f.instances} x a(X,Y,Z,W), nothing matches", f.per_event(), f)
    a160 = res["irrelevant"][-1]
    ratio_a = a160.per_event() / base
    targets.append((f"(a) {a160.instances} irrelevant instances within 10% of none: ratio {ratio_a:.3f} "
                    f"({us(a160.per_event() - base).strip()} per event)", ratio_a <= 1.10))
    fewest = res["irrelevant"][0] if len(res["irrelevant"]) > 1 else None
    if fewest is not None:
        flat = a160.per_event() / fewest.per_event()
        targets.append((f"(a) flat in the number of irrelevant instances ({a160.instances} vs {fewest.instances} "
                        f"within 10%): ratio {flat:.3f}", abs(flat - 1) <= 0.10))
    else:
        targets.append((f"(a) flat in the number of irrelevant instances: inferences per event "
                        f"{a160.inferences_per_event():.0f} with {a160.instances}, "
                        f"{res['baseline'].inferences_per_event():.0f} with none", None))

    small, big = res["sizes"][cfg.small], res["sizes"][cfg.big]
    for f in (small, big):
        size = cfg.small if f is small else cfg.big
        row(f"(b) 20 x tf(X,Y,V,Q) size {size:,} (records {f.records:,})", f.per_event(), f)
    m = res["match_only"]
    row("(b) 20 x tf(_,_,_,none): matching only", m.per_event(), m)
    ratio_b = big.per_event() / small.per_event()
    net_b = (big.per_event() - base) / (small.per_event() - base)
    targets.append((f"(b) size {cfg.big:,} vs {cfg.small:,} equal within 10% once full: ratio {ratio_b:.3f} "
                    f"(net {net_b:.3f})", abs(ratio_b - 1) <= 0.10))
    for f in res["tf_counts"]:
        if f.instances != 20:
            row(f"(b) {f.instances} x tf(X,Y,V,Q) size {cfg.small:,}", f.per_event(), f)

    for f in res["headcam"]:
        net = f.per_event() - base
        row(f"(c) {f.instances} x tf(head,cam,_,_) size {cfg.headcam_size:,}", f.per_event(), f,
            extra=f" {net / f.instances * 1e9:7.1f} ns/instance/event")
    hc = res["headcam"][-1]
    hc_net = hc.per_event() - base
    per_instance = hc_net / hc.instances
    print(f"    per instance: {per_instance * 1e9:.1f} ns per event, {per_instance * len(FRAMES) * 1e6:.3f} us per "
          f"tf(head,cam) event it records (1 in {len(FRAMES)})")
    if "mixed" in res:
        row("(c) 10 x tf(X,Y,V,Q) + 320 x tf(head,cam,_,_)", res["mixed"].per_event(), res["mixed"])
        ten = next((f for f in res["tf_counts"] if f.instances == 10), None)
        h320 = next((f for f in res["headcam"] if f.instances == 320), None)
        if ten and h320:
            print(f"    Fig 5.8: net 10 x tf(X,Y,V,Q) {us(ten.per_event() - base)}, 320 x tf(head,cam) "
                  f"{us(h320.per_event() - base)}, both {us(res['mixed'].per_event() - base)} "
                  f"(sum {us(ten.per_event() + h320.per_event() - 2 * base)})")
    targets.append((f"(c) {hc.instances} x tf(head,cam,_,_): {us(hc.per_event()).strip()} per event "
                    f"({hc.per_event() / base:.2f}x none), {per_instance * 1e9:.1f} ns per instance per event",
                    None))

    print(f"\n{'(d) query on memory q':58} {'next net':>12} {'prev net':>12} {'loop':>12}")
    for q in res["queries"]:
        label = f"{q['records']:,} records" + (f", {q['others']} other instances" if q["others"] else "")
        print(f"    {label:54} {us(q['next_net']):>12} {us(q['prev_net']):>12} {us(q['loop']):>12}")
    plain = [q for q in res["queries"] if not q["others"]]
    q_small = next(q for q in plain if q["size"] == 128)
    q_big = next(q for q in plain if q["size"] == 16384)
    for kind in ("next", "prev"):
        ratio = q_big[kind + "_net"] / q_small[kind + "_net"]
        found = q_big[kind + "_found"] == q_small[kind + "_found"] == cfg.queries
        targets.append((f"(d) {kind} on 16,384 vs 128 records under 2x: ratio {ratio:.3f}"
                        + ("" if found else " (some queries failed!)"), ratio < 2 and found))

    thesis_method = 2 * 20 / (small.per_event() - m.per_event())
    all_in = 2 * 20 / (small.per_event() - base)
    floor = 2 * 20 / res["floor"].per_event()
    print(f"\n(e) steady state, 20 full memories of {cfg.small:,}, updates (assertz or retract) per second of CPU:")
    print(f"    net of matching (thesis method)   {thesis_method:>12,.0f}/s  ({thesis_method / 2:,.0f} "
          f"memorize+forget pairs/s)")
    print(f"    net of baseline (matching too)    {all_in:>12,.0f}/s  ({all_in / 2:,.0f} pairs/s)")
    print(f"    floor: assertz+retract alone      {floor:>12,.0f}/s  spread {res['floor'].spread():.2f}  (SWI-Prolog {res.get('swipl', '')})")
    print(f"    thesis (2012)                     {THESIS_UPDATES_PER_S:>12,}/s")
    for text, value in (("net of matching", thesis_method), ("net of baseline", all_in)):
        targets.append((f"(e) updates/s {text} >= 2x thesis ({2 * THESIS_UPDATES_PER_S:,}/s): {value:,.0f}/s "
                        f"({value / THESIS_UPDATES_PER_S:.2f}x; floor {floor:,.0f}/s)",
                        value >= 2 * THESIS_UPDATES_PER_S))
    targets.append((f"(e) aim: updates/s net of matching >= 10x thesis ({10 * THESIS_UPDATES_PER_S:,}/s): "
                    f"{thesis_method:,.0f}/s", thesis_method >= 10 * THESIS_UPDATES_PER_S))

    print(f"\n{'(f) late insert into a full memory':40} {'per insert':>12} {'vs in order':>12}")
    late = res["late"]
    for r in late:
        zero = next((x for x in late if x["size"] == r["size"] and x["k"] == 0), None)
        extra = us(r["per_insert"] - zero["per_insert"]) if zero else ""
        print(f"    size {r['size']:>7,}, {r['k']:>4} records late          {us(r['per_insert']):>12} {extra:>12}")
    by = {(r["size"], r["k"]): r["per_insert"] for r in late}
    s0, s1 = cfg.late_sizes[0], cfg.late_sizes[-1]
    ratio_f = by[(s1, 100)] / by[(s0, 100)]
    targets.append((f"(f) 100 late: size {s1:,} vs {s0:,} within 10% (cost independent of size): "
                    f"ratio {ratio_f:.3f}", abs(ratio_f - 1) <= 0.10))
    grows = by[(s0, 100)] > by[(s0, 10)] > by[(s0, 0)]
    targets.append((f"(f) cost grows with lateness (size {s0:,}: k=0 {us(by[(s0, 0)]).strip()}, "
                    f"k=10 {us(by[(s0, 10)]).strip()}, k=100 {us(by[(s0, 100)]).strip()})", grows))

    print()
    for text, met in targets:
        verdict = "figure" if met is None else ("met" if met else "MISSED")
        print(f"target {verdict:6} {text}")
    return targets


def plot(res: dict, cfg: Config, out_dir: Path, prefix: str) -> List[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    base = res["baseline"].per_event() * 1e6
    paths = []

    def save(fig, name):
        path = out_dir / name
        fig.tight_layout()
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)

    # Fig 5.4, 5.6, 5.7: cost vs number of instances
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for key, label in (("irrelevant", "a(X,Y,Z,W): matches nothing (Fig 5.4)"),
                       ("tf_counts", f"tf(X,Y,V,Q), size {cfg.small:,} (Fig 5.6)"),
                       ("headcam", f"tf(head,cam,_,_), size {cfg.headcam_size:,} (Fig 5.7)")):
        figs = res[key]
        ax.plot([0] + [f.instances for f in figs], [base] + [f.per_event() * 1e6 for f in figs], marker="o",
                label=label)
    ax.axhline(base, color="grey", linestyle=":", label="no instances")
    ax.set_xscale("symlog", linthresh=10)
    ax.set_xlabel("memory instances")
    ax.set_ylabel("CPU per tf event (us)")
    ax.set_title("SLR: cost of memory instances vs their number")
    ax.legend()
    save(fig, f"{prefix}_instances.png")

    # Fig 5.5: cost per chunk over the run, small vs big
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for size, f in res["sizes"].items():
        ax.plot([(end - f.chunk / 2) / RATE for end, _ in f.series], [s / f.chunk * 1e6 for _, s in f.series],
                label=f"20 x tf(X,Y,V,Q), size {size:,}")
    m = res["match_only"]
    ax.plot([(end - m.chunk / 2) / RATE for end, _ in m.series], [s / m.chunk * 1e6 for _, s in m.series],
            label="20 x tf(_,_,_,none): matching only")
    ax.axhline(base, color="grey", linestyle=":", label="no instances")
    ax.axvline(cfg.big / RATE, color="black", linestyle="--", linewidth=0.8, label=f"{cfg.big:,} events")
    ax.set_xlabel(f"event time (s, {RATE} tf events/s)")
    ax.set_ylabel("CPU per tf event (us)")
    ax.set_ylim(bottom=0)
    ax.set_title("SLR: cost over time, memory size 2,500 vs %s (Fig 5.5)" % f"{cfg.big:,}")
    ax.legend()
    save(fig, f"{prefix}_sizes.png")

    # Fig 5.9-5.11: query cost vs memory size
    fig, ax = plt.subplots(figsize=(8, 4.5))
    plain = [q for q in res["queries"] if not q["others"]]
    for kind in ("next", "prev"):
        ax.plot([q["size"] for q in plain], [q[kind + "_net"] * 1e6 for q in plain], marker="o", label=kind)
    other = [q for q in res["queries"] if q["others"]]
    if other:
        ax.plot([q["size"] for q in other], [q["next_net"] * 1e6 for q in other], marker="x", linestyle="",
                markersize=10, label=f"next, {other[0]['others']} other instances (Fig 5.10)")
    ax.set_xscale("log", base=2)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("records in the memory")
    ax.set_ylabel("CPU per query, net of the loop (us)")
    ax.set_title("SLR: next/prev cost vs memory size (Fig 5.9-5.11)")
    ax.legend()
    save(fig, f"{prefix}_queries.png")

    # (f) late inserts
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for size in cfg.late_sizes:
        rows = [r for r in res["late"] if r["size"] == size and r["k"] > 0]
        ax.plot([r["k"] for r in rows], [r["per_insert"] * 1e6 for r in rows], marker="o",
                label=f"memory of {size:,}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("records late")
    ax.set_ylabel("CPU per insert (us)")
    ax.set_title("SLR: inserting a late event into a full memory")
    ax.legend()
    save(fig, f"{prefix}_late.png")
    return paths


def to_json(res: dict) -> dict:
    def conv(value):
        if isinstance(value, StreamFigure):
            return {"label": value.label, "instances": value.instances, "per_event_s": value.per_event(),
                    "records": value.records, "chunk": value.chunk, "series": value.series}
        if isinstance(value, dict):
            return {str(k): conv(v) for k, v in value.items()}
        if isinstance(value, list):
            return [conv(v) for v in value]
        return value
    return conv(res)


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller memories and windows (a few seconds)")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--no-plot", action="store_true")
    args = parser.parse_args(argv)
    cfg = QUICK if args.quick else FULL
    started = time.time()
    with tempfile.TemporaryDirectory(prefix="slr-bench-") as tmp:
        runner = Runner(Path(tmp))
        res = run_all(cfg, runner, args.quick)
    report(res, cfg)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    name = "slr_memory_quick" if args.quick else "slr_memory"
    (args.out_dir / f"{name}.json").write_text(json.dumps(to_json(res), indent=2) + "\n")
    written = [] if args.no_plot else plot(res, cfg, args.out_dir, name)
    print(f"\n{runner.count} swipl runs in {time.time() - started:.0f} s; wrote "
          + ", ".join(str(p) for p in [args.out_dir / f"{name}.json"] + written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
