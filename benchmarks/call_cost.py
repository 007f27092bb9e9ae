"""The fixed cost of a call from Python into the engine (issue 39, items 1 and 3).

For each call it measures the time the call takes from Python and the time the same work takes
inside Prolog (the same rtl_api predicate with the same arguments, called N times in a Prolog
loop): the difference is the call's fixed cost, what crossing the boundary costs whatever the
work (building the arguments, the handoff to the Prolog thread that owns the runtime's state,
reading the answer, making the Python objects).

Calls: a bridge call that does nothing (`rtl_api_clock`), `Engine.feed` of one event that
matches nothing, `Engine.query('true')`, `Engine.query('X = 1')`, a query through the query
service (`LiveNode.query`: a request handed to the node's consumer thread, as a ROS service
call is), and the query of `retalisc query` (one Engine.query in the command's process, which
runs Prolog in its own thread).

Each is measured on the two roads a process can take (docs/runtime.md, "Threads"), each in a
process of its own (the road is chosen before the first call):
  handoff        the default of an Engine made from Python: every call is handed to the
                 bridge's Prolog thread (two thread wake-ups), so that any Python thread may
                 call;
  calling thread Bridge.run_in_calling_thread(): the one calling thread is the owner (the
                 `retalisc` program), no handoff.

Targets (issue 39): the fixed cost of feeding one event that matches nothing and of answering
`true` at most 20 us. Costs are CPU time of the process (Python's process_time, Prolog's
process_cputime), which another process's load disturbs far less than the wall clock; the wall
time per call is printed beside them (on the handoff road it also holds the wake-ups' latency).
The figures are the best of --repeat runs of --calls calls (the load average is printed with
them).

Usage: python benchmarks/call_cost.py [--calls N] [--repeat R] [--out-dir DIR] [--quick]
Writes DIR/call_cost.json and DIR/call_cost.png.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

TARGET_US = 20.0
PROGRAM = "never(X) <- zzz_never(X).\n"
ROADS = ("handoff", "calling thread")

# name -> (the Prolog goal doing the call's work N times, with I the loop counter: the same
# predicate and arguments as the Python call)
INSIDE = {
    "bridge call (rtl_api_clock)": 'rtl_api:rtl_api_clock(_)',
    "Engine.feed (matches nothing)": 'rtl_api:rtl_api_feed_events([["add", "a(1)", I, ""]], _)',
    "Engine.query('true')": 'rtl_api:rtl_api_query("true", "inf", "first", _)',
    "Engine.query('X = 1')": 'rtl_api:rtl_api_query("X = 1", "inf", "first", _)',
    "query service (LiveNode.query)": 'rtl_api:rtl_api_query("X = 1", "inf", "first", _)',
    "retalisc query ('X = 1')": 'rtl_api:rtl_api_query("X = 1", "inf", "all", _)',
}
TARGETED = ("Engine.feed (matches nothing)", "Engine.query('true')")


def best_per_call(call, calls: int, repeat: int) -> tuple:
    """Microseconds per call, (CPU time of the process, wall-clock time): the best of `repeat`
    runs of `calls` calls."""
    for _ in range(min(200, calls)):
        call()
    cpu = wall = float("inf")
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        for _ in range(calls):
            call()
        cpu = min(cpu, (time.process_time() - start_cpu) / calls * 1e6)
        wall = min(wall, (time.perf_counter() - start) / calls * 1e6)
    return cpu, wall


def inside_prolog(bridge, goal: str, calls: int, repeat: int) -> float:
    """CPU microseconds per run of `goal` in a Prolog loop (the best of `repeat`). Trusted goal
    text written here, never built from values."""
    loop = (f"statistics(process_cputime, T0), forall(between(1, {calls}, _), (flag(call_cost_time, I0, I0 + 1), "
            f"I is I0 + 10000000, {goal})), statistics(process_cputime, T1), "
            f"U is (T1 - T0) / {calls} * 1000000")
    best = float("inf")
    for _ in range(repeat):
        best = min(best, float(bridge.once(loop, "U")))
    return best


def measure_road(road: str, calls: int, repeat: int) -> dict:
    """In this process: every call on `road` (run as a child process)."""
    from retalisc.driver.bridge import Bridge

    bridge = Bridge()
    if road == "calling thread" and not bridge.run_in_calling_thread():
        raise SystemExit("cannot run Prolog in the calling thread here")
    from retalisc.driver.engine import Engine

    engine = Engine.from_source(PROGRAM, "call_cost.rtl")
    clock = iter(range(1, 10**9))
    calls_of = {
        "bridge call (rtl_api_clock)": lambda: bridge.apply("rtl_api", "rtl_api_clock"),
        "Engine.feed (matches nothing)": lambda: engine.feed("a(1)", next(clock)),
        "Engine.query('true')": lambda: engine.query("true"),
        "Engine.query('X = 1')": lambda: engine.query("X = 1"),
        "retalisc query ('X = 1')": lambda: engine.query_all("X = 1"),
    }
    service = _service(engine) if road == "handoff" else None
    if service is not None:
        calls_of["query service (LiveNode.query)"] = lambda: service.query("X = 1")
    rows = {}
    for name, call in calls_of.items():
        python, wall = best_per_call(call, calls, repeat)
        inside = inside_prolog(bridge, INSIDE[name], calls, repeat)
        rows[name] = {"python_us": python, "wall_us": wall, "prolog_us": inside, "fixed_us": max(0.0, python - inside)}
    if service is not None:
        service.close()
    return rows


def _service(engine):
    """A LiveNode on an in-memory transport (its services run in its consumer thread, handed
    there as a ROS service call is); None when the live extras are not installed."""
    try:
        from retalisc.live.node import LiveNode, Transport
    except ImportError:
        return None

    class Quiet(Transport):
        wire = "cdr"
        name = "memory"

        def start(self, node):
            pass

        def subscribe(self, topic, msgtype):
            pass

        def unsubscribe(self, topic):
            return True

        def advertise(self, topic, msgtype):
            pass

        def publish(self, topic, msgtype, data):
            pass

    try:
        node = LiveNode(engine, Quiet(), log=lambda text: None)
    except Exception as error:          # rosbags missing: the node cannot read messages
        print(f"query service: not measured ({type(error).__name__}: {error})", file=sys.stderr)
        return None
    node.start()
    return node


def child(road: str, calls: int, repeat: int) -> dict:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, __file__, "--road", road, "--calls", str(calls), "--repeat", str(repeat)],
                          capture_output=True, text=True, env=env, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"road {road!r} failed:\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def report(results: dict) -> list:
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"load average {load:.2f} on {os.cpu_count()} cores")
    print("CPU time of the process per call (wall-clock time per call in brackets):")
    print(f"{'call':34} {'road':15} {'from Python':>12} {'(wall)':>10} {'in Prolog':>10} {'fixed cost':>11}")
    for road, rows in results.items():
        for name, row in rows.items():
            print(f"{name:34} {road:15} {row['python_us']:9.1f} us ({row['wall_us']:6.1f} us) "
                  f"{row['prolog_us']:7.1f} us {row['fixed_us']:8.1f} us")
    print("queries from outside = fixed cost + the query's own work (in Prolog):")
    for road, rows in results.items():
        for name in ("Engine.query('true')", "Engine.query('X = 1')", "query service (LiveNode.query)",
                     "retalisc query ('X = 1')"):
            if name in rows:
                row = rows[name]
                print(f"  {name:34} {road:15} {row['fixed_us']:7.1f} + {row['prolog_us']:6.1f} us")
    targets = []
    for road, rows in results.items():
        for name in TARGETED:
            fixed = rows[name]["fixed_us"]
            targets.append((fixed <= TARGET_US, f"{name} fixed cost on the {road} road: {fixed:.1f} us "
                                                f"(<= {TARGET_US:.0f} us)"))
    for met, text in targets:
        print(f"target {'met' if met else 'MISSED':6} {text}")
    return targets


def plot(results: dict, path: Path) -> None:
    from plotting import pyplot

    plt = pyplot()
    if plt is None:
        return
    names = list(next(iter(results.values())))
    fig, axes = plt.subplots(1, len(results), figsize=(11, 4), sharey=True)
    for ax, (road, rows) in zip(axes, results.items()):
        shown = [name for name in names if name in rows]
        inside = [rows[name]["prolog_us"] for name in shown]
        fixed = [rows[name]["fixed_us"] for name in shown]
        ax.barh(shown, inside, label="the work, in Prolog")
        ax.barh(shown, fixed, left=inside, label="fixed cost of the call")
        ax.axvline(TARGET_US, color="grey", linestyle="--", linewidth=1)
        ax.set_title(f"{road} road")
        ax.set_xlabel("microseconds per call")
    axes[0].invert_yaxis()
    axes[0].legend(loc="lower right")
    fig.suptitle(f"A call from Python into the engine (target: fixed cost <= {TARGET_US:.0f} us, dashed)")
    fig.tight_layout()
    fig.savefig(path)
    print(f"plot: {path}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=3000)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--quick", action="store_true", help="few calls (a smoke run)")
    parser.add_argument("--road", choices=ROADS, help=argparse.SUPPRESS)     # a child process
    args = parser.parse_args()
    if args.quick:
        args.calls, args.repeat = 200, 2
    if args.road:
        print(json.dumps(measure_road(args.road, args.calls, args.repeat)))
        return 0
    results = {road: child(road, args.calls, args.repeat) for road in ROADS}
    targets = report(results)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    (args.out_dir / "call_cost.json").write_text(json.dumps(
        {"results": results, "targets": [{"met": met, "text": text} for met, text in targets]}, indent=2))
    plot(results, args.out_dir / "call_cost.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
