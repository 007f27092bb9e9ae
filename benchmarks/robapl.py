"""RobAPL executor costs (issue 43, item 8): the cost of a macro step against the number of plan
nodes and of monitored conditions (100 to 10,000), and the reaction time from an event to the
transition it enables.

Agents are generated: plans of 100 external nodes each. In the "monitored" series every node is
Waiting with a start condition `event(fire(I))`, so each macro step evaluates every one of them;
in the "idle" series only 100 nodes monitor a condition and the others have finished (their
plans stay, held by an end condition that never holds), which measures what idle nodes cost.
A macro step of an event that enables nothing is one micro step that evaluates the monitored
conditions; the reaction time is the wall time from the start of the macro step of `fire(I)` to
the application of node I's Waiting -> Executing transition. The peer is the same executor at
100 nodes (the ratio says how the cost grows: conditions are evaluated by resolution on every
node in every micro step in this slice; compiled to ELE rules of an IEC, a later slice, only the
nodes whose events arrive would be evaluated).

The "iec" series runs the monitored agent with an IEC in step (retalisc/robapl/iec.py): each
macro step's event and node status changes are fed to a Retalis program, and node I's condition
`event(fire(I))` is enabled by the ELE rule `fire(I) <- alarm(I).` of the IEC: its reaction is
from the start of the macro step of `alarm(I)` to node I's transition, in the macro step of the
derived `fire(I)` (the rule is written by hand: conditions are not compiled to ELE rules yet).
Its peer is the "monitored" row of the same size, measured in the same run.

Targets: at 1,000 monitored conditions a macro step <= 10 ms and the reaction <= 20 ms (a robot
deliberating at 50 Hz or more).

Usage: python benchmarks/robapl.py [--sizes 100,300,...] [--repeat R] [--out-dir DIR] [--quick]
Writes DIR/robapl.json and DIR/robapl.png.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from retalisc.robapl.executor import EXECUTING, Actions, Executor  # noqa: E402
from retalisc.robapl.iec import SteppedIEC  # noqa: E402
from retalisc.robapl.syntax import parse_agent  # noqa: E402
from retalisc.robapl.terms import Atom, Compound  # noqa: E402

PLAN_SIZE = 100
TARGET_MACRO_MS = 10.0
TARGET_REACTION_MS = 20.0
TARGET_AT = 1000


def agent_text(nodes: int, monitored: int) -> str:
    rules = []
    for plan in range(max(1, nodes // PLAN_SIZE)):
        children = []
        for index in range(plan * PLAN_SIZE, (plan + 1) * PLAN_SIZE):
            start = f" [start: event(fire({index}))]" if index < monitored else ""
            children.append(f"    external n{index}: act({index}){start}")
        rules.append(f"  make({plan}) <- true | list p{plan} [end: event(never)] {{\n" + "\n".join(children) + "\n  }")
    return "rules {\n" + "\n".join(rules) + "\n}\n"


class TimedExecutor(Executor):
    def apply(self, transitions):
        super().apply(transitions)
        for transition in transitions:
            if transition.to == EXECUTING and transition.node.spec.name == self.watch:
                self.reacted = time.perf_counter()


IEC_PROGRAM = "fire(I) <- alarm(I).\n"


def measure(nodes: int, monitored: int, repeat: int, iec: bool = False) -> dict:
    actions = Actions()
    actions.register("act", lambda *args, context: "done")
    stepped = SteppedIEC.from_source(IEC_PROGRAM, "bench_iec.rtl") if iec else None
    try:
        return _measure(nodes, monitored, repeat, actions, stepped)
    finally:
        if stepped is not None:
            assert stepped.problems == [], stepped.problems
            stepped.close()


def _measure(nodes: int, monitored: int, repeat: int, actions: Actions, iec) -> dict:
    executor = TimedExecutor(parse_agent(agent_text(nodes, monitored)), actions, iec=iec)
    executor.watch = None
    for plan in range(max(1, nodes // PLAN_SIZE)):
        executor.post(Compound("make", (plan,)), 0.0)
    while executor._queue:
        executor.macro_step()
    macro, reaction = [], []
    for step in range(repeat):
        executor.post(Atom("noise"), 1.0 + step)
        began = time.perf_counter()
        executor.macro_step()
        macro.append(time.perf_counter() - began)
        target = monitored - 1 - step
        executor.watch = f"n{target}"
        executor.post(Compound("alarm" if iec else "fire", (target,)), 1.5 + step)
        executor.reacted = None
        began = time.perf_counter()
        executor.macro_step()
        if iec is not None:             # the derived fire(I): the next macro step
            executor.macro_step()
        assert executor.reacted is not None, "the event did not enable its node"
        reaction.append(executor.reacted - began)
    return {"nodes": nodes, "monitored": monitored, "macro_ms": 1000 * min(macro), "reaction_ms": 1000 * min(reaction)}


def report(series: dict) -> list:
    for name, rows in series.items():
        base = rows[0]
        if name == "iec":
            print("iec series (conditions through an IEC in step; x peer: the monitored row of the same size)")
            for row, peer in zip(rows, series["monitored"]):
                print(f"  {row['nodes']:7,} {row['monitored']:9,} {row['macro_ms']:9.2f} ms {row['reaction_ms']:7.2f} ms "
                      f"{row['macro_ms'] / peer['macro_ms']:7.1f}x")
            continue
        print(f"{name} series (peer: the same executor at {base['nodes']} nodes)")
        print(f"  {'nodes':>7} {'monitored':>9} {'macro step':>12} {'reaction':>10} {'x peer':>8}")
        for row in rows:
            print(f"  {row['nodes']:7,} {row['monitored']:9,} {row['macro_ms']:9.2f} ms {row['reaction_ms']:7.2f} ms "
                  f"{row['macro_ms'] / base['macro_ms']:7.1f}x")
    targets = []
    at = [row for row in series["monitored"] if row["monitored"] == TARGET_AT]
    if at:
        row = at[0]
        targets.append((row["macro_ms"] <= TARGET_MACRO_MS, f"macro step at {TARGET_AT:,} monitored conditions: "
                        f"{row['macro_ms']:.2f} ms (<= {TARGET_MACRO_MS:.0f} ms)"))
        targets.append((row["reaction_ms"] <= TARGET_REACTION_MS, f"reaction at {TARGET_AT:,} monitored conditions: "
                        f"{row['reaction_ms']:.2f} ms (<= {TARGET_REACTION_MS:.0f} ms)"))
    for met, text in targets:
        print(f"target {'met' if met else 'MISSED':6} {text}")
    return targets


def plot(series: dict, path: Path) -> None:
    from plotting import pyplot

    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for name, rows in series.items():
        sizes = [row["nodes"] for row in rows]
        axes[0].loglog(sizes, [row["macro_ms"] for row in rows], marker="o", label=f"{name}")
        axes[1].loglog(sizes, [row["reaction_ms"] for row in rows], marker="o", label=f"{name}")
    axes[0].axhline(TARGET_MACRO_MS, color="grey", linestyle="--", linewidth=1)
    axes[1].axhline(TARGET_REACTION_MS, color="grey", linestyle="--", linewidth=1)
    axes[0].set_title("macro step of an event that enables nothing")
    axes[1].set_title("reaction: event to the transition it enables")
    for ax in axes:
        ax.set_xlabel("plan nodes")
        ax.set_ylabel("ms")
        ax.legend()
    fig.suptitle("RobAPL executor (monitored: every node has a start condition; idle: 100 do, the rest finished)")
    fig.tight_layout()
    fig.savefig(path)
    print(f"plot: {path}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,300,1000,3000,10000")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--quick", action="store_true", help="100 and 1,000 nodes, 2 repeats (a smoke run)")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    if args.quick:
        sizes, args.repeat = [100, 1000], 2
    series = {"monitored": [measure(n, n, args.repeat) for n in sizes],
              "idle": [measure(n, PLAN_SIZE, args.repeat) for n in sizes],
              "iec": [measure(n, n, args.repeat, iec=True) for n in sizes]}
    targets = report(series)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    (args.out_dir / "robapl.json").write_text(json.dumps(
        {"series": series, "targets": [{"met": met, "text": text} for met, text in targets]}, indent=2))
    plot(series, args.out_dir / "robapl.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
