"""The tf library (prolog_runtime/rtl_tf.pl, docs/tf.md) against tf2 in the same run: speed,
memory and answers.

Peers: tf2's C++ `tf2::BufferCore` (Debian's libtf2-dev; tf2_peer.cpp, built here with g++)
and its Python binding (`tf2_py.BufferCore`, python3-tf2, run by the system Python). The
set-up installs both with apt-get when it runs as root and they are missing; elsewhere the
peers that are missing are skipped with a message.

Recordings: the NAO recording (examples/nao/make_bag.py, 10 s: every transform of its 52
frame pairs, all kept in the 10 s buffer), and the evo and franka bags of the shared test
data (`--bags DIR`, default /work/shared/data/bags; skipped when absent). For each: the ingest
of every transform (CPU per transform), memory per kept transform (tf2: malloc's bytes in use;
the library: tf_bytes/1, the C store's allocations or the size of the Prolog store's clauses), lookups of a chain of 1 link and of the
longest chain up to 5 links at 2,000 stamps within the data (CPU per lookup), through the
Python API (`Engine.query`, 200 lookups each, and the fixed cost of one call) against tf2's
binding, and the answers: every
lookup against tf2 C++ (within 1e-9 m and 1e-6 degree, same stamps, same failures) and the
failures' reasons against tf2's on lookups outside the data and of unknown or unconnected
frames (tests/tf_scenarios.py; tf2's Python binding carries times as double seconds, so these
compare times within 1 us, and the latest common time is compared with tf2 C++ only).

The library is measured on both its roads (tf_add/6 and tf_lookup/6 called from Prolog,
benchmarks/tf_bench.pl): the C store (prolog_runtime/c/rtl_tfstore.c), which the targets are
for, and the Prolog store, the reference, printed beside it (its answers are checked too).
Without the C store built, the targets are measured on the Prolog road and say so.

Usage: python benchmarks/tf_lookup.py [--quick] [--bags DIR] [--out-dir DIR] [--no-plot]
Prints each figure with its ratio to the peer and `target met|MISSED` lines; writes
tf_lookup[_quick].json and tf_lookup[_quick].png.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List, Optional, Tuple

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests"))

from tf_scenarios import SYSTEM_PYTHON, differences, rotation_degrees, run_both  # noqa: E402

SECOND = 1_000_000_000
TARGETS = {"ingest": 5.0, "lookup": 5.0, "python": 2.0, "memory": 2.0}


# ---- set-up ---------------------------------------------------------------------------------

def have_tf2_python() -> bool:
    return subprocess.run([SYSTEM_PYTHON, "-c", "import tf2_py, rospy"], capture_output=True).returncode == 0


def have_tf2_cpp() -> bool:
    return Path("/usr/include/tf2/buffer_core.h").exists() and shutil.which("g++") is not None


def set_up() -> Tuple[bool, bool]:
    """(tf2 Python binding present, tf2 C++ library present), installing them when possible."""
    if not (have_tf2_python() and have_tf2_cpp()) and hasattr(os, "geteuid") and os.geteuid() == 0 \
            and shutil.which("apt-get"):
        print("set-up: apt-get install -y python3-tf2 libtf2-dev", file=sys.stderr)
        subprocess.run(["apt-get", "install", "-y", "-q", "python3-tf2", "libtf2-dev"],
                       stdout=subprocess.DEVNULL, env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"})
    python, cpp = have_tf2_python(), have_tf2_cpp()
    if not python:
        print("skipped: tf2's Python binding (python3-tf2) is not installed and cannot be installed here",
              file=sys.stderr)
    if not cpp:
        print("skipped: tf2's C++ library (libtf2-dev) or g++ is missing here", file=sys.stderr)
    return python, cpp


def build_peer(work: Path) -> Path:
    exe = work / "tf2_peer"
    subprocess.run(["g++", "-O2", "-o", str(exe), str(ROOT / "benchmarks" / "tf2_peer.cpp"),
                    "-ltf2", "-lrostime", "-lconsole_bridge"], check=True)
    return exe


# ---- the data -------------------------------------------------------------------------------

def strip(frame: str) -> str:
    return frame[1:] if frame.startswith("/") else frame


def bag_transforms(path: Path) -> List[tuple]:
    """(parent, child, stamp_ns, static, [x, y, z, qx, qy, qz, qw]) of every transform of
    /tf and /tf_static, in record order (frame ids without their leading slash, as tf2 keeps
    them)."""
    from retalisc.robot_io.bags import Recording

    found = []
    with Recording(path) as bag:
        topics = [t for t in bag.topics() if t.rstrip("/").rsplit("/", 1)[-1] in ("tf", "tf_static")]
        for record in bag.records(topics):
            if record.msg is None:
                continue
            static = record.topic.endswith("tf_static")
            for t in record.msg.transforms:
                tr, r = t.transform.translation, t.transform.rotation
                found.append((strip(t.header.frame_id), strip(t.child_frame_id),
                              t.header.stamp.sec * SECOND + t.header.stamp.nanosec, static,
                              [tr.x, tr.y, tr.z, r.x, r.y, r.z, r.w]))
    return found


def kept_ranges(transforms: List[tuple]) -> Dict[str, tuple]:
    """child -> (parent, first kept stamp, last stamp, static) after the ingest (10 s buffer)."""
    latest: Dict[str, int] = {}
    info: Dict[str, tuple] = {}
    for parent, child, stamp, static, _ in transforms:
        if static:
            info[child] = (parent, None, None, True)
        else:
            latest[child] = max(latest.get(child, stamp), stamp)
    for parent, child, stamp, static, _ in transforms:
        if not static and stamp + 10 * SECOND >= latest[child]:
            p, lo, hi, _ = info.get(child, (parent, stamp, stamp, False))
            info[child] = (parent, min(lo, stamp), max(hi, stamp), False)
    return info


def chains(info: Dict[str, tuple]) -> Dict[str, Tuple[str, str, int, int]]:
    """Two lookups: `chain1` (a dynamic link) and `chainN` (the longest chain to the root up to
    5 links, N its length): group -> (target, source, lo, hi), the interval every link of the
    chain has data in."""
    def path(frame):
        links = []
        while frame in info and len(links) < 5:
            links.append(frame)
            frame = info[frame][0]
        return links, frame

    def interval(links):
        dynamic = [info[f] for f in links if not info[f][3]]
        return max(d[1] for d in dynamic), min(d[2] for d in dynamic)

    found = {}
    one = max((f for f in info if not info[f][3]), key=lambda f: info[f][2] - info[f][1])
    lo, hi = interval([one])
    found["chain1"] = (info[one][0], one, lo, hi)
    best = max(info, key=lambda f: (len(path(f)[0]), f))
    links, top = path(best)
    if any(not info[f][3] for f in links):
        lo, hi = interval(links)
        found[f"chain{len(links)}"] = (top, best, lo, hi)
    return found


def lookups(groups: Dict[str, tuple], count: int, seed: int = 1) -> List[tuple]:
    rng = random.Random(seed)
    found = []
    for group, (target, source, lo, hi) in groups.items():
        found += [(group, target, source, rng.randint(lo, hi)) for _ in range(count)]
    # the latest common time, compared with tf2 C++ (whose stamps are exact integers)
    found += [("latest", t, s, 0) for target, source, _, _ in groups.values() for t, s in ((target, source), (source, target))]
    return found


def failing_lookups(info: Dict[str, tuple], groups: Dict[str, tuple], seed: int = 2) -> List[list]:
    rng = random.Random(seed)
    frames = sorted(info)
    ops = []
    for target, source, lo, hi in groups.values():
        ops += [["lookup", target, source, lo - rng.randint(1, 5 * SECOND)] for _ in range(20)]
        ops += [["lookup", target, source, hi + rng.randint(1, 5 * SECOND)] for _ in range(20)]
    ops += [["lookup", rng.choice(frames), "no_such_frame", 0], ["lookup", "no_such_frame", rng.choice(frames), 0]]
    ops += [["lookup", rng.choice(frames), rng.choice(frames), 0] for _ in range(20)]
    return ops


def scenario_text(transforms: List[tuple], looks: List[tuple]) -> str:
    lines = [f"a {p} {c} {s} {int(st)} " + " ".join(repr(float(v)) for v in values)
             for p, c, s, st, values in transforms]
    lines += [f"l {g} {t} {s} {n}" for g, t, s, n in looks]
    return "\n".join(lines) + "\n"


# ---- running the peers ------------------------------------------------------------------------

def parse_run(text: str) -> dict:
    answers, cpu, heap, kept = [], {}, None, None
    for line in text.splitlines():
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "cpu":
            cpu[fields[1]] = (float(fields[2]), int(fields[3]))
        elif fields[0] == "heap":
            heap = int(fields[1])
        elif fields[0] == "kept":
            kept = int(fields[1])
        elif fields[0] == "error":
            answers.append(None)
        else:
            answers.append([float(x) for x in fields[:7]] + [int(fields[7])])
    return {"answers": answers, "cpu": cpu, "heap": heap, "kept": kept}


def c_store_built() -> bool:
    return any((ROOT / "prolog_runtime" / "foreign").glob("rtl_tfstore.*"))


def run_library(text: str, road: str) -> dict:
    run = subprocess.run(["swipl", str(ROOT / "benchmarks" / "tf_bench.pl"), road], input=text, capture_output=True,
                         text=True, check=True)
    return parse_run(run.stdout)


def run_cpp(exe: Path, text: str) -> dict:
    return parse_run(subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True).stdout)


def run_tf2_python(text: str) -> dict:
    run = subprocess.run([SYSTEM_PYTHON, str(ROOT / "benchmarks" / "tf2_py_peer.py")], input=text,
                         capture_output=True, text=True, check=True)
    return parse_run(run.stdout)


def tf_message_event(parent: str, child: str, stamp: int, static: bool, values: list) -> str:
    x, y, z, qx, qy, qz, qw = (repr(float(v)) for v in values)
    message = ("tf2_msgs__0__TFMessage([geometry_msgs__0__TransformStamped("
               f"std_msgs__0__Header([{stamp // SECOND},{stamp % SECOND}],'{parent}'),'{child}',"
               f"geometry_msgs__0__Transform(geometry_msgs__0__Vector3({x},{y},{z}),"
               f"geometry_msgs__0__Quaternion({qx},{qy},{qz},{qw})))])")
    return f"tf_static({message})" if static else message


def run_python_api(transforms: List[tuple], looks: List[tuple]) -> dict:
    """The library through `Engine.query` and through the typed `Engine.tf_lookup` (arguments as
    data, no goal text): CPU per lookup; the events fed as tf messages. On the calling-thread road
    (this process makes every call from one thread), as a tf2 binding user's process calls."""
    from retalisc.driver.bridge import Bridge
    from retalisc.driver.engine import Engine, TfLookupError

    road = "calling thread" if Bridge().run_in_calling_thread() else "handoff"
    engine = Engine.from_source("tf_bench_unused(X) <- tf_bench_input(X).\n")
    events = [(tf_message_event(*t), t[2] / SECOND) for t in transforms]
    t0 = time.process_time()
    for start in range(0, len(events), 2000):
        engine.feed_batch(events[start:start + 2000])
    feed = time.process_time() - t0
    cpu = {"ingest_events": (feed, len(events))}
    groups: Dict[str, list] = {}
    for g, target, source, n in looks:
        groups.setdefault(g, []).append((target, source, n))
    for g, items in groups.items():
        t0 = time.process_time()
        for target, source, n in items:
            engine.query(f"tf_lookup('{target}', '{source}', ns({n}), P, S, R)")
        cpu[g] = (time.process_time() - t0, len(items))
        best = float("inf")
        for _ in range(5):      # best of 5: the machine may be loaded
            t0 = time.process_time()
            for target, source, n in items:
                try:
                    engine.tf_lookup(target, source, ("ns", n))
                except TfLookupError:
                    pass
            best = min(best, time.process_time() - t0)
        cpu[f"typed {g}"] = (best, len(items))
    # the fixed cost of one Engine.query (a goal that does nothing but bind its variable)
    t0 = time.process_time()
    for _ in range(400):
        engine.query("X = 1")
    cpu["query_fixed"] = (time.process_time() - t0, 400)
    engine.close(run_pending=False)
    return {"cpu": cpu, "road": road}


# ---- the comparison ---------------------------------------------------------------------------

def accuracy(ours: list, theirs: list) -> dict:
    worst_m, worst_deg, mismatched = 0.0, 0.0, 0
    for a, b in zip(ours, theirs):
        if (a is None) != (b is None) or (a is not None and a[7] != b[7]):
            mismatched += 1
            continue
        if a is None:
            continue
        worst_m = max(worst_m, max(abs(x - y) for x, y in zip(a[:3], b[:3])))
        worst_deg = max(worst_deg, rotation_degrees(a[3:7], b[3:7]))
    return {"max_m": worst_m, "max_degree": worst_deg, "mismatched": mismatched + abs(len(ours) - len(theirs)),
            "compared": min(len(ours), len(theirs))}


def per_op(cpu: dict, group: str) -> Optional[float]:
    if group not in cpu or not cpu[group][1]:
        return None
    seconds, count = cpu[group]
    return seconds / count


def measure(name: str, transforms: List[tuple], quick: bool, exe: Optional[Path], python: bool) -> dict:
    info = kept_ranges(transforms)
    groups = chains(info)
    looks = lookups(groups, 200 if quick else 2000)
    text = scenario_text(transforms, looks)
    res: dict = {"name": name, "transforms": len(transforms), "groups": {g: list(v[:2]) for g, v in groups.items()}}
    road = "c" if c_store_built() else "prolog"
    ours = run_library(text, road)
    res["road"] = road
    res["library"] = {"cpu": ours["cpu"], "heap": ours["heap"], "kept": ours["kept"]}
    reference = run_library(text, "prolog") if road == "c" else ours
    res["prolog_road"] = {"cpu": reference["cpu"], "heap": reference["heap"], "kept": reference["kept"]}
    res["roads_agree"] = accuracy(ours["answers"], reference["answers"])
    if exe is not None:
        cpp = run_cpp(exe, text)
        res["cpp"] = {"cpu": cpp["cpu"], "heap": cpp["heap"]}
        res["accuracy"] = accuracy(ours["answers"], cpp["answers"])
        res["prolog_accuracy"] = accuracy(reference["answers"], cpp["answers"])
    if python:
        res["tf2_python"] = {"cpu": run_tf2_python(text)["cpu"]}
        api_looks = [x for g in groups for x in [look for look in looks if look[0] == g][:200]]
        res["python_api"] = run_python_api(transforms, api_looks)
        ops = [["add", p, c, s, v[:3], v[3:], st] for p, c, s, st, v in transforms] + failing_lookups(info, groups)
        a, b = run_both(ops)
        queries = [op for op in ops if op[0] == "lookup"]
        # the failures only: the poses are compared with tf2 C++ above
        kept = [(q, x, y) for q, x, y in zip(queries, a, b) if not ("pose" in x and "pose" in y)]
        res["reasons"] = {"compared": len(kept), "failed": sum("error" in y for _, _, y in kept),
                          "differences": differences([x for _, x, _ in kept], [y for _, _, y in kept],
                                                     [q for q, _, _ in kept])[:5]}
    return res


def report(results: List[dict]) -> List[str]:
    lines = []

    def target(label: str, ratio: Optional[float], limit: float) -> None:
        if ratio is None:
            lines.append(f"target skipped: {label} (no peer)")
        else:
            lines.append(f"target {'met' if ratio <= limit else 'MISSED'}: {label} {ratio:.1f}x (target <= {limit:g}x)")

    for res in results:
        name = res["name"]
        lib, cpp, ref = res["library"], res.get("cpp"), res["prolog_road"]
        road = res.get("road", "prolog")
        print(f"== {name}: {res['transforms']:,} transforms, kept {lib['kept']:,}; lookups "
              + ", ".join(f"{g} {t} <- {s}" for g, (t, s) in res["groups"].items())
              + f"; targets on the {road} road")

        def ratio_text(mine: Optional[float], other: Optional[float]) -> str:
            return f" ({mine / other:.1f}x)" if mine and other else ""

        ingest = per_op(lib["cpu"], "ingest")
        peer = per_op(cpp["cpu"], "ingest") if cpp else None
        slow = per_op(ref["cpu"], "ingest")
        print(f"ingest: library {road} {ingest * 1e6:.2f} us/transform"
              + (f", tf2 C++ {peer * 1e6:.3f} us{ratio_text(ingest, peer)}" if peer else "")
              + f"; Prolog road {slow * 1e6:.2f} us{ratio_text(slow, peer)}")
        target(f"{name} ingest in rules vs tf2 C++", ingest / peer if peer else None, TARGETS["ingest"])
        if cpp and cpp["heap"]:
            ours_b, theirs_b, ref_b = lib["heap"] / lib["kept"], cpp["heap"] / lib["kept"], ref["heap"] / ref["kept"]
            print(f"memory: library {road} {ours_b:.0f} B/kept transform, tf2 C++ {theirs_b:.0f} B "
                  f"({ours_b / theirs_b:.1f}x); Prolog road {ref_b:.0f} B ({ref_b / theirs_b:.1f}x)")
            target(f"{name} memory per transform vs tf2", ours_b / theirs_b, TARGETS["memory"])
        for g in res["groups"]:
            mine = per_op(lib["cpu"], g)
            other = per_op(cpp["cpu"], g) if cpp else None
            slow = per_op(ref["cpu"], g)
            print(f"lookup {g}: library {road} {mine * 1e6:.2f} us"
                  + (f", tf2 C++ {other * 1e6:.3f} us{ratio_text(mine, other)}" if other else "")
                  + f"; Prolog road {slow * 1e6:.2f} us{ratio_text(slow, other)}")
            target(f"{name} lookup {g} in rules vs tf2 C++", mine / other if other else None, TARGETS["lookup"])
            if "python_api" in res:
                api, binding = per_op(res["python_api"]["cpu"], g), per_op(res["tf2_python"]["cpu"], g)
                typed = per_op(res["python_api"]["cpu"], f"typed {g}")
                print(f"lookup {g} through Python ({res['python_api'].get('road', 'handoff')} road): "
                      f"Engine.tf_lookup {typed * 1e6:.1f} us ({typed / binding:.1f}x), "
                      f"Engine.query {api * 1e6:.1f} us ({api / binding:.1f}x), tf2 binding {binding * 1e6:.2f} us")
                target(f"{name} lookup {g} through the Python API (Engine.tf_lookup) vs tf2's binding",
                       typed / binding, TARGETS["python"])
        if "python_api" in res:
            fixed = per_op(res["python_api"]["cpu"], "query_fixed")
            if fixed is not None:
                print(f"the fixed cost of one Engine.query (X = 1): {fixed * 1e6:.1f} us "
                      f"(the Python bridge's, not the tf library's)")
            fed = per_op(res["python_api"]["cpu"], "ingest_events")
            print(f"ingest as tf message events through Engine.feed_batch: {fed * 1e6:.1f} us/transform")
        if "accuracy" in res:
            acc = res["accuracy"]
            print(f"answers vs tf2 C++: {acc['compared']:,} lookups, max {acc['max_m']:.2e} m, "
                  f"{acc['max_degree']:.2e} degree, {acc['mismatched']} with another stamp or failure")
            ok = acc["max_m"] <= 1e-9 and acc["max_degree"] <= 1e-6 and acc["mismatched"] == 0
            lines.append(f"target {'met' if ok else 'MISSED'}: {name} answers equal to tf2 (1e-9 m, 1e-6 degree)")
        if "prolog_accuracy" in res:
            acc = res["prolog_accuracy"]
            print(f"answers of the Prolog road vs tf2 C++: max {acc['max_m']:.2e} m, {acc['max_degree']:.2e} degree, "
                  f"{acc['mismatched']} with another stamp or failure")
        agree = res["roads_agree"]
        print(f"the two roads: {agree['compared']:,} lookups, max {agree['max_m']:.2e} m, "
              f"{agree['max_degree']:.2e} degree apart, {agree['mismatched']} with another stamp or failure")
        if "reasons" in res:
            rs = res["reasons"]
            print(f"failures vs tf2's binding: {rs['failed']} lookups failed there, {len(rs['differences'])} differ "
                  f"{rs['differences'][:2]}")
            lines.append(f"target {'met' if not rs['differences'] else 'MISSED'}: {name} same failures, same reasons as tf2")
    for line in lines:
        print(line)
    return lines


def plot(results: List[dict], path: Path) -> Optional[Path]:
    from plotting import pyplot

    plt = pyplot()
    if plt is None:
        return None
    labels, ours, prolog, cpp, api, binding = [], [], [], [], [], []
    for res in results:
        for g in ["ingest", *res["groups"]]:
            labels.append(f"{res['name']}\n{g}")
            ours.append(per_op(res["library"]["cpu"], g) * 1e6)
            prolog.append(per_op(res["prolog_road"]["cpu"], g) * 1e6)
            cpp.append((per_op(res["cpp"]["cpu"], g) or 0) * 1e6 if "cpp" in res else 0)
            api.append((per_op(res["python_api"]["cpu"], f"typed {g}") or 0) * 1e6 if "python_api" in res and g != "ingest" else 0)
            binding.append((per_op(res["tf2_python"]["cpu"], g) or 0) * 1e6 if "tf2_python" in res else 0)
    fig, ax = plt.subplots(figsize=(max(8, 1.3 * len(labels)), 4.5))
    width = 0.16
    xs = range(len(labels))
    road = results[0].get("road", "prolog") if results else "prolog"
    for k, (values, label) in enumerate([(ours, f"tf library ({'C' if road == 'c' else 'Prolog'} store, in rules)"),
                                         (prolog, "tf library (Prolog store, in rules)"), (cpp, "tf2 C++"),
                                         (api, "tf library via Engine.tf_lookup"), (binding, "tf2 Python binding")]):
        ax.bar([x + (k - 2) * width for x in xs], [v or float("nan") for v in values], width, label=label)
    ax.set_yscale("log")
    ax.set_ylabel("CPU per operation (us)")
    ax.set_xticks(list(xs))
    ax.set_xticklabels(labels, fontsize=8)
    ax.legend(fontsize=8)
    ax.set_title("tf: ingest per transform and lookup per chain, against tf2 in the same run")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="200 lookups per chain instead of 2,000")
    parser.add_argument("--bags", default="/work/shared/data/bags", help="the folder of the evo and franka bags")
    parser.add_argument("--out-dir", default=str(ROOT / "benchmarks" / "results"))
    parser.add_argument("--no-plot", action="store_true")
    args = parser.parse_args(argv)
    python, cpp = set_up()
    out_dir = Path(args.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        exe = build_peer(work) if cpp else None
        nao = work / "nao.bag"
        subprocess.run([sys.executable, str(ROOT / "examples" / "nao" / "make_bag.py"), str(nao), "--seconds", "10"],
                       check=True, capture_output=True)
        data = [("nao", nao)]
        for name, file in [("evo", "evo_tf_example.bag"), ("franka", "tf_bag_franka.bag")]:
            if (Path(args.bags) / file).exists():
                data.append((name, Path(args.bags) / file))
            else:
                print(f"skipped: {name} ({Path(args.bags) / file} is not here)", file=sys.stderr)
        results = [measure(name, bag_transforms(path), args.quick, exe, python) for name, path in data]
    lines = report(results)
    suffix = "_quick" if args.quick else ""
    (out_dir / f"tf_lookup{suffix}.json").write_text(json.dumps({"results": results, "targets": lines}, indent=1))
    if not args.no_plot:
        made = plot(results, out_dir / f"tf_lookup{suffix}.png")
        if made:
            print(f"plot: {made}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
