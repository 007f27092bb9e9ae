"""Active-query benchmark: the Tabled Optimized transformation (and Naive/Optimized where they
terminate) beside SWI-Prolog 9's own tabling (`table`, `as incremental`, `as monotonic`,
`as subsumptive`), measured in the same run, with ratios.

    python benchmarks/active_queries.py [--quick] [--png out.png]

Every figure is CPU seconds inside one fresh `swipl` process per (scenario, system); the
`recompute` baseline is `abolish_all_tables` + re-evaluation after the update.
"""
from __future__ import annotations

import argparse
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retalisc.backends.prolog.aq_backend import compile_active_queries  # noqa: E402

RIGHT = "path(X, Y) :- edge(X, Z), path(Z, Y).\npath(X, Y) :- edge(X, Y).\n"
LEFT = "path(X, Y) :- path(X, Z), edge(Z, Y).\npath(X, Y) :- edge(X, Y).\n"
NOTIFY = """notify(User, Artist, Price, [LX, LY]) :-
    show(Artist, Price, [LX, LY]),
    likes(User, Artist, MaxPrice, MaxDistance),
    Price < MaxPrice,
    loc(User, [Lx, Ly]),
    sqrt((LX - Lx) * (LX - Lx) + (LY - Ly) * (LY - Ly)) < MaxDistance.
"""

TIMER = """
t(G, T) :- garbage_collect, statistics(cputime, T0), ( call(G) -> true ; true ), statistics(cputime, T1), T is T1 - T0.
report(Name, T) :- format("~w ~6f~n", [Name, T]), flush_output.
"""


def chain(n):
    return [f"edge({i}, {i + 1})." for i in range(n)]


def random_graph(nodes, edges, seed=7):
    rng = random.Random(seed)
    out = set()
    while len(out) < edges:
        a, b = rng.randrange(nodes), rng.randrange(nodes)
        out.add(f"edge({a}, {b}).")
    return sorted(out)


def program6(seed=42):
    rng = random.Random(seed)
    facts = []
    for artist in range(1, 101):
        spots = set()
        while len(spots) < 30:
            spots.add((rng.randint(0, 10), rng.randint(0, 10)))
        for x, y in sorted(spots):
            facts.append(f"show({artist}, {rng.randint(1, 10)}, [{x}, {y}]).")
    for user in range(1, 501):
        facts.append(f"loc({user}, [{rng.randint(0, 10)}, {rng.randint(0, 10)}]).")
        for artist in rng.sample(range(1, 101), 30):
            facts.append(f"likes({user}, {artist}, {rng.randint(1, 10)}, {rng.randint(1, 15)}).")
    return facts


def run_swipl(text: str, timeout=3600):
    with tempfile.TemporaryDirectory(prefix="aqbench_") as tmp:
        path = Path(tmp) / "bench.pl"
        path.write_text(text)
        proc = subprocess.run(["swipl", "--no-tty", "-q", "--stack-limit=8g", "--table-space=8g", "-g", "main",
                               "-t", "halt", str(path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, timeout=timeout)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr[-3000:])
    out = {}
    for line in proc.stdout.splitlines():
        name, value = line.split()
        out[name] = float(value)
    return out


def ours(rules, facts, goal, add, delete, mode="tabled", extra_goals=()):
    gen = compile_active_queries(rules + "\n".join(facts) + "\n", "bench.pl", mode=mode)
    main = [
        f"main :- t(aq_register(q, {goal}, _), T1), report(initial, T1),",
        f"    t(aq_assert({add}), T2), report(add, T2),",
        f"    t(aq_retract({delete}), T3), report(delete, T3),",
        "    statistics(globalused, _), garbage_collect, statistics(memory, _),",
        "    t(aq_reset, T4), report(unregister, T4),",
    ]
    for n, g in enumerate(extra_goals):
        main.append(f"    t(aq_register(p{n}, {g}, _), T{5 + n}), report(point{n}, T{5 + n}),")
    main.append("    true.")
    return run_swipl(gen + TIMER + "\n".join(main) + "\n")


def swi(rules, facts, goal, add, delete, how, preds):
    """how: table | incremental | monotonic | subsumptive."""
    decls = []
    dyn = preds["dynamic"]
    tabled = preds["tabled"]
    if how == "table":
        decls += [f":- table {p}." for p in tabled] + [f":- dynamic {p}." for p in dyn]
    elif how == "subsumptive":
        decls += [f":- table {p} as subsumptive." for p in tabled] + [f":- dynamic {p}." for p in dyn]
    elif how == "incremental":
        decls += [f":- table {p} as incremental." for p in tabled] + [f":- dynamic {p} as incremental." for p in dyn]
    elif how == "monotonic":
        decls += [f":- table {p} as monotonic." for p in tabled] + [f":- dynamic {p} as monotonic." for p in dyn]
    update = how in ("incremental", "monotonic")
    if update:
        add_g = f"(assertz({add}), findall(x, {goal}, _))"
        del_g = f"(retract({delete}), findall(x, {goal}, _))"
    else:
        add_g = f"(assertz({add}), abolish_all_tables, findall(x, {goal}, _))"
        del_g = f"(retract({delete}), abolish_all_tables, findall(x, {goal}, _))"
    main = (f"main :- t(findall(x, {goal}, _), T1), report(initial, T1),\n"
            f"    t({add_g}, T2), report(add, T2),\n    t({del_g}, T3), report(delete, T3),\n"
            f"    statistics(table_space_used, S), report(table_space, S).\n")
    return run_swipl("\n".join(decls) + "\n" + rules + "\n".join(facts) + "\n" + TIMER + main)


def scenario(name, rules, facts, goal, add, delete, preds, systems, rows, progress):
    progress(f"{name}: ours")
    rows.append((name, "tabled (ours)", ours(rules, facts, goal, add, delete)))
    for how in systems:
        progress(f"{name}: SWI {how}")
        try:
            rows.append((name, f"SWI {how}", swi(rules, facts, goal, add, delete, how, preds)))
        except Exception as exc:  # a baseline that fails is reported, not hidden
            rows.append((name, f"SWI {how}", {"error": str(exc).splitlines()[-1][:60]}))


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="smaller sizes (smoke run)")
    ap.add_argument("--png", default="benchmarks/active_queries.png")
    args = ap.parse_args(argv)
    t0 = time.time()

    def progress(msg):
        print(f"[{time.time() - t0:7.1f}s] {msg}", file=sys.stderr, flush=True)

    rows = []
    path_preds = {"dynamic": ["edge/2"], "tabled": ["path/2"]}
    systems = ["table", "incremental", "monotonic", "subsumptive"]
    n = 200 if args.quick else 1000
    scenario("chain-right", RIGHT, chain(n), "path(0, _)", f"edge({n}, {n + 1})", f"edge({n // 2}, {n // 2 + 1})",
             path_preds, systems, rows, progress)
    big = 10000 if args.quick else 100000
    scenario("chain-left-100k" if not args.quick else "chain-left-10k", LEFT, chain(big), "path(0, _)",
             f"edge({big}, {big + 1})", f"edge({big // 2}, {big // 2 + 1})", path_preds,
             ["table", "incremental", "monotonic"], rows, progress)
    scenario("random-graph", LEFT, random_graph(2000, 6000), "path(0, _)", "edge(1, 2)", "edge(0, 1)" if False else
             random_graph(2000, 6000)[0][:-1], path_preds, ["table", "incremental", "monotonic"], rows, progress)
    if not args.quick:
        facts6 = program6()
        victim = next(f for f in facts6 if f.startswith("likes(1,"))[:-1]
        scenario("program6", NOTIFY, facts6, "notify(_, _, _, _)", "loc(1, [2, 3])", victim,
                 {"dynamic": ["loc/2", "show/3", "likes/4"], "tabled": ["notify/4"]},
                 ["table", "incremental", "monotonic"], rows, progress)
    print_table(rows)
    plot(rows, args.png)


def print_table(rows):
    by = {}
    for scen, system, res in rows:
        by.setdefault(scen, {})[system] = res
    print(f"{'scenario':<16} {'system':<18} {'initial':>9} {'add':>9} {'delete':>9}   ratios ours/system (init, add, del)")
    for scen, systems in by.items():
        mine = systems.get("tabled (ours)", {})
        for system, res in systems.items():
            if "error" in res:
                print(f"{scen:<16} {system:<18} {'error: ' + res['error']}")
                continue
            cells = " ".join(f"{res.get(k, float('nan')):9.4f}" for k in ("initial", "add", "delete"))
            ratio = ""
            if system != "tabled (ours)":
                ratio = "  " + ", ".join(
                    f"{mine.get(k, float('nan')) / res[k]:.3g}" if res.get(k) else "-" for k in ("initial", "add", "delete"))
            print(f"{scen:<16} {system:<18} {cells}{ratio}")


def plot(rows, png):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    scen = sorted({r[0] for r in rows})
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for ax, key in zip(axes, ("initial", "add", "delete")):
        labels, values = [], []
        for s, system, res in rows:
            if key in res:
                labels.append(f"{s}\n{system}")
                values.append(max(res[key], 1e-6))
        ax.barh(range(len(values)), values)
        ax.set_yticks(range(len(values)))
        ax.set_yticklabels(labels, fontsize=6)
        ax.set_xscale("log")
        ax.set_title(f"{key} (CPU s, log)")
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == "__main__":
    main()
