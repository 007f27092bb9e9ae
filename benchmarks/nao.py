"""The NAO application of the thesis measured as chapter 5 measures it (Figures 5.2, 5.4-5.13),
on the recording examples/nao/make_bag.py writes at the thesis's load (1,896 transforms/s,
about 7 marker detections/s, faces at 5 Hz).

Every number is CPU seconds per second of replayed stream (the share of one core), measured
in a fresh process per case around the replay only (time.process_time: the Prolog engine runs
in that process, in the calling thread as in `retalisc run`; the modules are imported before
the clock starts), with the program a variant of examples/nao/nao.rtl:

  Fig 5.2   the whole application, replayed in real time (rate 1, CPU sampled every 0.5 s:
            the time series; fed every 10 ms, the default --tick, and every 100 ms) and as
            fast as possible; also the input pipeline alone (an
            empty program: reading the bag, converting messages to events) and the split
            rules alone. Goal: the whole application under 5% of one core in real time
            (the thesis: about 18% of a 2012 laptop core).
  Fig 5.4   N memory instances that no event reaches (`a(X, Y, Z, W)`) added to the split
            rules: cost vs N.
  Fig 5.5-5.6  N instances recording every transform (`tf(_, _, V, Q)`), size 2,500, and
            N = 5 of size 150,000 (never full here): cost vs N, and size.
  Fig 5.7-5.8  N instances of the Head -> CameraTop_frame pair (8 Hz), size 2,500.
  Fig 5.9-5.11 the application with each detection interpolating the chain K times (10 prev
            /next queries per chain): cost vs queries per second.
  Fig 5.12-5.13 synchronization: the world poses computed at once (no synchronization),
            synchronized (A.5), and C copies of the synchronized rule each waiting D seconds
            after the detection (about 7.5 * C * D postponed monitors at any time; pending
            ones are dropped at the end).
  pairs     (issue 39, item 4) the split rules with one memory per tf frame pair of the
            recording (52 pairs, 48 with parent `torso`) against the five of the application:
            CPU per transform, the ratio against the 1.5x target; each case run with this
            tree's runtime and with the runtime of --before (a checkout of the commit before
            instances were found by every constant argument: the first argument only), in
            the same run.

Usage: python benchmarks/nao.py [--quick] [--seconds S] [--only FIGS] [--before TREE] [--out-dir DIR] [--no-plot]
Prints one `target met|MISSED|figure ...` line per figure; writes nao[_quick].json and PNG plots.
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Dict, List, Optional

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from retalisc.robot_io.replay import RATE_TICK as DEFAULT_TICK  # noqa: E402  (--tick of `retalisc run`)

APP = (ROOT / "examples" / "nao" / "nao.rtl").read_text(encoding="utf-8")
GOAL = 0.05
TICK = 0.1                 # the longer tick of the second real-time case
WARMUP_S = 5.0
SPLIT_END = "% ---- A.2.4"
MARKERS_START = "% ---- markers:"
MARKERS_END = "% ---- A.3:"


def split_rules() -> str:
    """The split rules of the application (A.1 and the markers), nothing else."""
    return APP[:APP.index(SPLIT_END)] + APP[APP.index(MARKERS_START):APP.index(MARKERS_END)]


def with_memories(count: int, pattern: str, size: int, prefix: str) -> str:
    return split_rules() + "".join(f"memorize({pattern}, [], rec, {prefix}{k}, {size}).\n" for k in range(count))


def pair_memories(pairs) -> str:
    """The split rules with one memory a frame pair, each recording the pair's transforms."""
    def quoted(frame: str) -> str:
        return "'" + frame.replace("'", "\\'") + "'"

    return split_rules() + "".join(f"memorize(tf({quoted(p)}, {quoted(c)}, V, Q), [], tf(V, Q), pair{k}, 2500).\n"
                                   for k, (p, c) in enumerate(pairs))


def transforms_in(seconds: float) -> int:
    """How many transforms make_bag.py writes in a recording of SECONDS."""
    from make_bag import GROUPS

    return round(seconds * sum(rate * len(pairs) for rate, _, pairs in GROUPS))


PAIRS_TARGET = 1.5


def with_interpolations(k: int) -> str:
    """The application, each detection interpolating the whole chain K times."""
    extra = f"""
transform_marker_k(Rel, Time, Pose) :-
    forall(between(2, {k}, _), transform_marker(Rel, Time, _)),
    transform_marker(Rel, Time, Pose).
"""
    text = APP.replace("    transform_marker(RelPose, [Sec, NSec], [[P11", "    transform_marker_k(RelPose, [Sec, NSec], [[P11")
    assert text != APP
    return text + extra


def without_sync() -> str:
    """The world poses computed as soon as a detection arrives, without synchronization."""
    start = APP.index("syncronized(")
    end = APP.index("% ---- A.6")
    rule = """marker_pose(Name, geometry_msgs__0__PoseStamped(std_msgs__0__Header(Seq, [Sec, NSec], odom),
        geometry_msgs__0__Pose(geometry_msgs__0__Point(P11, P12, P13),
                               geometry_msgs__0__Quaternion(Q11, Q12, Q13, Q14))))
  <- ar_marker(Seq, Name, RelPose, Sec, NSec)
     where transform_marker(RelPose, [Sec, NSec], [[P11, P12, P13], [Q11, Q12, Q13, Q14]]).

"""
    return APP[:start] + rule + APP[end:]


def with_waiting_copies(copies: int, delay: float) -> str:
    """The application plus C synchronized rules whose conditions wait D s after the detection."""
    rules = []
    for c in range(copies):
        rules.append(f"""
syncronized(waited_{c}(Name, P), transform_marker(RelPose, [Sec, NSec], P),
            [[odom_base, Z], [base_torso, Z], [torso_neck, Z], [neck_head, Z], [head_cam, Z]])
  <- ar_marker(_, Name, RelPose, Sec, NSec) where (Z is Sec + NSec * 0.000000001 + {delay}).
""")
    return APP + "".join(rules)


# ---- one measurement, in its own process --------------------------------------------------------

def measure(spec: dict) -> dict:
    from retalisc.driver.bridge import Bridge
    from retalisc.driver.engine import Engine
    from retalisc.robot_io.replay import BagOptions, replay_bag

    for module in ("rosbags.rosbag1", "rosbags.typesys", "rosbags.interfaces", "rosbags.serde"):
        importlib.import_module(module)             # modules loaded before the clock starts
    Bridge.instance().run_in_calling_thread()       # as `retalisc run` runs it: Prolog in this thread
    engine = Engine.from_source(spec["source"], "nao_variant.rtl")
    engine.set_flag("echo_input", "false")
    samples: List[tuple] = []
    done = threading.Event()

    def sampler():
        while not done.wait(0.5):
            samples.append((time.perf_counter(), time.process_time()))

    dues: List[float] = []                          # with a rate: when each message falls due
    outputs: List[tuple] = []                       # (wall-clock time written, event text)
    if spec.get("rate"):
        paced = engine.feed_paced

        def feed_paced(events, item_dues, *rest, **options):
            dues.extend(item_dues)
            return paced(events, item_dues, *rest, **options)

        engine.feed_paced = feed_paced
        engine.on_output(lambda event: outputs.append((time.time(), event.text)))
    wall0, cpu0 = time.perf_counter(), time.process_time()
    thread = None
    if spec.get("rate"):
        thread = threading.Thread(target=sampler, daemon=True)
        thread.start()
    status = replay_bag(engine, spec["bag"], None, BagOptions(rate=spec.get("rate"), tick=spec.get("tick", DEFAULT_TICK)),
                        progress=False,
                        drop_pending=bool(spec.get("drop_pending")))
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    done.set()
    if thread:
        thread.join()
    series = []
    previous = (wall0, cpu0)
    for now in samples:
        series.append([now[0] - wall0, (now[1] - previous[1]) / (now[0] - previous[0])])
        previous = now
    # Steady state: after the warm-up (imports, the first messages of each type compiling
    # their deserializers, the memories filling), from the first sample past WARMUP_S (or
    # past a quarter of a short run) to the end.
    steady = None
    after = [x for x in samples if x[0] - wall0 >= min(WARMUP_S, wall / 4)]
    if after and wall0 + wall - after[0][0] > 0.5:
        steady = (cpu0 + cpu - after[0][1]) / (wall0 + wall - after[0][0])
    stats = engine.stats()
    latency = output_latency(spec["bag"], dues, outputs) if dues else None
    return {"status": status, "wall": wall, "cpu": cpu, "events": stats.get("events", 0),
            "derived": stats.get("derived", 0), "series": series, "steady": steady, "latency": latency}


# a world pose, marker_pose(Marker, PoseStamped) (not its delivery, a bare PoseStamped)
POSE = re.compile(r"marker_pose\('?\"?([^,\"')]+)\"?'?,geometry_msgs__0__PoseStamped\(std_msgs__0__Header\(\d+,\[(\d+),(\d+)\],")


def output_latency(bag_path: str, dues: List[float], outputs: List[tuple]) -> dict:
    """How late each world pose of a detection was written (seconds): its wall-clock time
    minus the moment it could first be computed, the due time of the last message it needs
    (the detection, and for each of the five memories the first transform after the
    detection's stamp: the synchronized rule waits for it)."""
    sys.path.insert(0, str(ROOT / "examples" / "nao"))
    from make_bag import CHAIN
    from retalisc.robot_io.bags import Recording

    pairs = set(CHAIN)
    detections: Dict[tuple, int] = {}           # (marker, sec, nsec) -> message index
    covering: Dict[tuple, List[tuple]] = {pair: [] for pair in pairs}   # pair -> (stamp ns, index)
    with Recording(bag_path) as bag:
        for index, record in enumerate(bag.records(None, None, None)):
            if record.topic == "/tf":
                for t in record.msg.transforms:
                    pair = (t.header.frame_id, t.child_frame_id)
                    if pair in pairs:
                        covering[pair].append((t.header.stamp.sec * 10**9 + t.header.stamp.nanosec, index))
            elif record.topic == "/ar_pose_marker":
                for m in record.msg.markers:
                    detections[(m.header.frame_id, m.header.stamp.sec, m.header.stamp.nanosec)] = index
    assert len(dues) == index + 1, (len(dues), index + 1)
    late, seen = [], set()
    for written, text in outputs:
        match = POSE.match(text)
        if not match or match.groups() in seen:     # (its copy to the marker's consumer)
            continue
        seen.add(match.groups())
        marker, sec, nsec = match.group(1), int(match.group(2)), int(match.group(3))
        stamp = sec * 10**9 + nsec
        needed = [detections[(marker, sec, nsec)]]
        needed += [min((i for ns, i in covering[pair] if ns > stamp), default=len(dues) - 1) for pair in pairs]
        late.append(written - max(dues[i] for i in needed))
    late.sort()
    return {"count": len(late), "min": late[0], "median": late[len(late) // 2],
            "p95": late[int(len(late) * 0.95)], "max": late[-1]} if late else {"count": 0}


def run_case(spec: dict, stream_seconds: float, root: Path = ROOT) -> dict:
    """One case in a fresh process, with the runtime of the tree ROOT (its benchmarks/nao.py measures)."""
    env = dict(os.environ, PYTHONPATH=str(root) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "nao.py"), "--measure"], input=json.dumps(spec), text=True,
                          capture_output=True, env=env, timeout=3600)
    if proc.returncode != 0:
        raise SystemExit(f"benchmark case failed:\n{proc.stderr[-3000:]}")
    result = json.loads(proc.stdout.splitlines()[-1])
    if result["status"] != 0:
        raise SystemExit(f"replay failed (status {result['status']})")
    result["share"] = result["cpu"] / stream_seconds
    return result


# ---- the figures -------------------------------------------------------------------------------------

def run_all(bag: Path, seconds: float, quick: bool, only: Optional[set], before: Optional[Path] = None) -> dict:
    def want(fig: str) -> bool:
        return only is None or fig in only

    def case(source: str, root: Path = ROOT, **extra) -> dict:
        spec = {"source": source, "bag": str(bag), **extra}
        result = run_case(spec, seconds, root)
        print(f"  {extra.get('label', '')}: {result['share'] * 100:.2f} % of a core "
              f"({result['cpu']:.2f} s CPU, {result['events']:,} events)", file=sys.stderr)
        return result

    res: Dict[str, object] = {"seconds": seconds, "quick": quick}
    if want("5.2"):
        print("Fig 5.2 ...", file=sys.stderr)
        res["app_realtime"] = case(APP, rate=1.0, tick=DEFAULT_TICK, label="application, real time")
        res["app_realtime_tick"] = case(APP, rate=1.0, tick=TICK, label=f"application, real time, --tick {TICK:g}")
        res["app_fast"] = case(APP, label="application, as fast as possible")
        res["input"] = case("", label="input pipeline (empty program)")
        res["split"] = case(split_rules(), label="split rules")
    counts = [0, 40] if quick else [0, 40, 160]
    if want("5.4"):
        print("Fig 5.4-5.8 ...", file=sys.stderr)
        res["irrelevant"] = [dict(n=n, **case(with_memories(n, "a(X, Y, Z, W)", 2500, "irr"), label=f"{n} x a(X,Y,Z,W)"))
                             for n in counts]
        res["all_tf"] = [dict(n=n, **case(with_memories(n, "tf(_, _, V, Q)", 2500, "all"), label=f"{n} x tf(_,_,V,Q)"))
                         for n in ([5, 10] if quick else [5, 10, 20])]
        res["all_tf_big"] = case(with_memories(5, "tf(_, _, V, Q)", 150000, "big"), label="5 x tf(_,_,V,Q) size 150,000")
        res["headcam"] = [dict(n=n, **case(with_memories(n, "tf('Head', 'CameraTop_frame', V, Q)", 2500, "hc"),
                                           label=f"{n} x head_cam"))
                          for n in ([5, 40] if quick else [5, 40, 160])]
    if want("5.9"):
        print("Fig 5.9-5.11 ...", file=sys.stderr)
        res["interpolations"] = [dict(k=k, **case(with_interpolations(k), label=f"{k} chain interpolations per detection"))
                                 for k in ([1, 8] if quick else [1, 4, 16])]
    if want("5.12"):
        print("Fig 5.12-5.13 ...", file=sys.stderr)
        res["no_sync"] = case(without_sync(), label="no synchronization")
        res["sync"] = case(APP, label="synchronized (A.5)", drop_pending=True)
        res["waiting"] = [dict(copies=c, delay=d, **case(with_waiting_copies(c, d), drop_pending=True,
                                                         label=f"{c} rules waiting {d} s"))
                          for c, d in ([(4, 2.0)] if quick else [(4, 2.0), (8, 4.0), (16, 8.0)])]
    if want("pairs"):
        print("pairs ...", file=sys.stderr)
        from make_bag import CHAIN, GROUPS

        every = [pair for _, _, pairs in GROUPS for pair in pairs]
        transforms = transforms_in(seconds)
        res["pairs"] = {"pairs": len(every), "torso": sum(1 for p, _ in every if p == "torso"), "transforms": transforms}
        trees = [("after", ROOT)] + ([("before", before)] if before else [])
        for name, root in trees:
            row = {}
            for key, pairs in (("five", CHAIN), ("all", every)):
                result = case(pair_memories(pairs), root, label=f"{name}: {len(pairs)} memories, one a pair")
                result["us_per_transform"] = result["cpu"] / transforms * 1e6
                row[key] = result
            res["pairs"][name] = row
    return res


def detections_per_second(bag: Path, seconds: float) -> float:
    truth = bag.with_name(bag.name[:-4] + ".truth.jsonl")
    return sum(1 for _ in truth.open()) / seconds


def report(res: dict, rate: float) -> None:
    print(f"NAO application, {res['seconds']:g} s recording, {rate:.1f} detections/s")
    if "app_realtime" in res:
        rt, fast = res["app_realtime"], res["app_fast"]
        print(f"  Fig 5.2 whole application, real time:       {rt['share'] * 100:6.2f} % of a core "
              f"({rt['cpu']:.2f} s CPU over {res['seconds']:g} s)")
        if "app_realtime_tick" in res:
            print(f"  Fig 5.2 whole application, real time, --tick {TICK:g}: "
                  f"{res['app_realtime_tick']['share'] * 100:6.2f} %")
        print(f"  Fig 5.2 whole application, as fast as possible: {fast['share'] * 100:6.2f} % "
              f"({res['seconds'] / fast['wall']:.1f}x real time)")
        print(f"  Fig 5.2 input pipeline alone: {res['input']['share'] * 100:.2f} %, split rules: "
              f"{res['split']['share'] * 100:.2f} %")
        for key, tick in (("app_realtime", DEFAULT_TICK), ("app_realtime_tick", TICK)):
            latency = res.get(key, {}).get("latency")
            if latency and latency.get("count"):
                print(f"  Fig 5.2 output latency, --tick {tick:g}: the {latency['count']} world poses written "
                      f"{latency['median'] * 1e3:.1f} ms (median), {latency['p95'] * 1e3:.1f} ms (95 %), "
                      f"{latency['max'] * 1e3:.1f} ms (max) after the last message they need fell due")
        steady = rt.get("steady")
        if steady is not None:
            print(f"  Fig 5.2 whole application, real time, steady state (after {WARMUP_S:g} s of warm-up): "
                  f"{steady * 100:.2f} %")
        print(f"target {'met' if rt['share'] < GOAL else 'MISSED':6} whole application under 5% of one core "
              f"in real time: {rt['share'] * 100:.2f} % (thesis: ~18 % of a 2012 core)")
        if steady is not None:
            print(f"target {'met' if steady < GOAL else 'MISSED':6} whole application under 5% of one core "
                  f"in real time, steady state: {steady * 100:.2f} %")
        if "app_realtime_tick" in res:
            share = res["app_realtime_tick"]["share"]
            print(f"target {'met' if share < GOAL else 'MISSED':6} whole application under 5% of one core "
                  f"in real time with --tick {TICK:g}: {share * 100:.2f} %")
        print(f"target {'met' if fast['share'] < GOAL else 'MISSED':6} whole application under 5% of one core "
              f"as fast as possible: {fast['share'] * 100:.2f} %")
        net = fast["share"] - res["input"]["share"]
        print(f"target {'met' if net < GOAL else 'MISSED':6} the application net of the input pipeline (bag "
              f"reading, message conversion, term parsing) under 5% of one core: {net * 100:.2f} %")
    if "irrelevant" in res:
        base = res["irrelevant"][0]["share"]
        for key, label in (("irrelevant", "Fig 5.4 a(X,Y,Z,W)"), ("all_tf", "Fig 5.6 tf(_,_,V,Q)"),
                           ("headcam", "Fig 5.7 head_cam")):
            row = ", ".join(f"{r['n']}: {(r['share'] - base) * 100:+.2f} %" for r in res[key])
            print(f"target figure  {label} instances, CPU over the split rules: {row}")
        small = next(r for r in res["all_tf"] if r["n"] == 5)
        print(f"target figure  Fig 5.5 5 x tf(_,_,V,Q) size 2,500 {small['share'] * 100:.2f} % vs size 150,000 "
              f"{res['all_tf_big']['share'] * 100:.2f} %")
    if "interpolations" in res:
        rows = res["interpolations"]
        lo, hi = rows[0], rows[-1]
        queries = (hi["k"] - lo["k"]) * 10 * rate
        per_query = (hi["cpu"] - lo["cpu"]) / (queries * res["seconds"]) if queries else 0.0
        print("target figure  Fig 5.9-5.11 " + ", ".join(f"{r['k'] * 10 * rate:.0f} queries/s: {r['share'] * 100:.2f} %"
                                                          for r in rows)
              + f"; {per_query * 1e6:.1f} us CPU per prev/next query")
    if "sync" in res:
        print(f"target figure  Fig 5.12 no synchronization {res['no_sync']['share'] * 100:.2f} %, synchronized "
              f"{res['sync']['share'] * 100:.2f} %")
        print("target figure  Fig 5.13 " + ", ".join(
            f"~{r['copies'] * r['delay'] * rate:.0f} waiting monitors: {r['share'] * 100:.2f} %" for r in res["waiting"]))
    if "pairs" in res:
        report_pairs(res["pairs"])


def report_pairs(pairs: dict) -> None:
    print(f"Memory instances per frame pair: {pairs['pairs']} pairs ({pairs['torso']} with parent torso), "
          f"{pairs['transforms']:,} transforms")
    for name in ("before", "after"):
        if name not in pairs:
            continue
        five, every = pairs[name]["five"]["us_per_transform"], pairs[name]["all"]["us_per_transform"]
        ratio = every / five
        label = "first-argument index (728a727)" if name == "before" else "index on every constant argument"
        print(f"  {name:6} {label}: {pairs['pairs']} memories {every:.1f} us per transform, 5 memories {five:.1f} us: "
              f"{ratio:.2f}x")
        if name == "after":
            print(f"target {'met' if ratio <= PAIRS_TARGET else 'MISSED':6} ingest with one memory per frame pair within "
                  f"{PAIRS_TARGET:g}x of the cost with 5: {ratio:.2f}x ({every:.1f} vs {five:.1f} us per transform)")


def plot(res: dict, rate: float, out_dir: Path, prefix: str) -> List[Path]:
    from plotting import pyplot

    plt = pyplot()
    if plt is None:
        return []
    paths = []

    def save(fig, name):
        path = out_dir / f"{prefix}_{name}.png"
        fig.tight_layout()
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)

    if "app_realtime" in res:
        fig, ax = plt.subplots(figsize=(7, 3.5))
        series = res["app_realtime"]["series"]
        ax.plot([t for t, _ in series], [s * 100 for _, s in series], label="whole application, real time")
        ax.axhline(res["app_realtime"]["share"] * 100, linestyle="--", color="C0", label="mean over the run")
        if "app_realtime_tick" in res:
            series = res["app_realtime_tick"]["series"]
            ax.plot([t for t, _ in series], [s * 100 for _, s in series], color="C1",
                    label=f"whole application, real time, --tick {TICK:g}")
            ax.axhline(res["app_realtime_tick"]["share"] * 100, linestyle="--", color="C1", label="its mean")
        ax.axhline(res["app_fast"]["share"] * 100, color="C2", linestyle="-.", label="as fast as possible")
        ax.axhline(GOAL * 100, color="red", linestyle=":", label="goal 5 %")
        ax.axhline(res["input"]["share"] * 100, color="gray", linestyle="-.", label="input pipeline alone (as fast as possible)")
        ax.set_xlabel("seconds of the recording")
        ax.set_ylabel("CPU, % of one core")
        ax.set_title("NAO application (Fig 5.2)")
        ax.legend(fontsize=8)
        save(fig, "application")
    if "irrelevant" in res:
        fig, ax = plt.subplots(figsize=(7, 3.5))
        for key, label in (("irrelevant", "a(X,Y,Z,W): reached by no event (5.4)"),
                           ("all_tf", "tf(_,_,V,Q): every transform, size 2,500 (5.6)"),
                           ("headcam", "Head->CameraTop_frame, size 2,500 (5.7)")):
            ax.plot([r["n"] for r in res[key]], [r["share"] * 100 for r in res[key]], marker="o", label=label)
        ax.plot([5], [res["all_tf_big"]["share"] * 100], marker="s", linestyle="", label="tf(_,_,V,Q) size 150,000 (5.5)")
        ax.set_xlabel("memory instances")
        ax.set_ylabel("CPU, % of one core")
        ax.set_title("Memory instances on the NAO stream (Fig 5.4-5.8)")
        ax.legend(fontsize=8)
        save(fig, "memories")
    if "interpolations" in res:
        fig, ax = plt.subplots(figsize=(7, 3.5))
        rows = res["interpolations"]
        ax.plot([r["k"] * 10 * rate for r in rows], [r["share"] * 100 for r in rows], marker="o")
        ax.set_xlabel("prev/next queries per second")
        ax.set_ylabel("CPU, % of one core")
        ax.set_title("prev/next on the five memories (Fig 5.9-5.11)")
        save(fig, "queries")
    if "sync" in res:
        fig, ax = plt.subplots(figsize=(7, 3.5))
        xs = [0, 0] + [r["copies"] * r["delay"] * rate for r in res["waiting"]]
        labels = ["no sync", "A.5"] + [f"{r['copies']}x{r['delay']:g}s" for r in res["waiting"]]
        ys = [res["no_sync"]["share"] * 100, res["sync"]["share"] * 100] + [r["share"] * 100 for r in res["waiting"]]
        ax.bar(range(len(ys)), ys, tick_label=labels)
        for i, (x, y) in enumerate(zip(xs, ys)):
            ax.text(i, y, f"~{x:.0f}", ha="center", va="bottom", fontsize=8)
        ax.set_ylabel("CPU, % of one core")
        ax.set_title("Synchronization (Fig 5.12-5.13); above: postponed monitors")
        save(fig, "sync")
    if "pairs" in res:
        pairs = res["pairs"]
        fig, ax = plt.subplots(figsize=(7, 3.5))
        names = [n for n in ("before", "after") if n in pairs]
        width = 0.38
        for i, (key, label) in enumerate((("five", "5 memories (the application's)"),
                                          ("all", f"{pairs['pairs']} memories, one a frame pair"))):
            ax.bar([j + (i - 0.5) * width for j in range(len(names))],
                   [pairs[n][key]["us_per_transform"] for n in names], width, label=label)
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels(["before: first argument" if n == "before" else "after: every constant" for n in names])
        ax.set_ylabel("CPU per transform (us)")
        ax.set_title(f"Memories over tf, found by their pattern (target: {PAIRS_TARGET:g}x of 5)")
        ax.legend(fontsize=8)
        save(fig, "pairs")
    return paths


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a 6 s recording and fewer cases")
    parser.add_argument("--seconds", type=float, help="length of the recording (default 60, quick 6)")
    parser.add_argument("--only", help="comma-separated figures: 5.2, 5.4 (5.4-5.8), 5.9 (5.9-5.11), 5.12 (5.12-5.13), pairs")
    parser.add_argument("--before", type=Path, help="a checkout of the runtime to compare in the pairs case "
                        "(e.g. `git worktree add --detach /tmp/idx_before 728a727`, C helpers built)")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--no-plot", action="store_true")
    parser.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.measure:
        print(json.dumps(measure(json.loads(sys.stdin.read()))))
        return 0
    seconds = args.seconds or (6.0 if args.quick else 60.0)
    only = set(args.only.split(",")) if args.only else None
    sys.path.insert(0, str(ROOT / "examples" / "nao"))
    import make_bag

    args.out_dir.mkdir(parents=True, exist_ok=True)
    prefix = "nao_quick" if args.quick else "nao"
    with tempfile.TemporaryDirectory(prefix="retalisc-nao-") as folder:
        bag, _ = make_bag.write(Path(folder) / "nao.bag", seconds=seconds, seed=1)
        rate = detections_per_second(bag, seconds)
        res = run_all(bag, seconds, args.quick, only, args.before)
    res["detections_per_s"] = rate
    report(res, rate)
    (args.out_dir / f"{prefix}.json").write_text(json.dumps(res, indent=1))
    if not args.no_plot:
        for path in plot(res, rate, args.out_dir, prefix):
            print(f"plot: {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
