"""Active-query benchmark: the Tabled Optimized transformation (and Naive/Optimized where they
terminate) beside SWI-Prolog 9's own tabling (`table`, `as incremental`, `as monotonic`,
`as subsumptive`), measured in the same run, with ratios.

    python benchmarks/active_queries.py [--quick] [--skip-2apl] [--repeats N] [--png out.png]

Every figure is CPU seconds inside one fresh `swipl` process per (scenario, system), the least
of --repeats such processes (the machine is shared and noisy: +-30 % between runs); the
`recompute` baseline is `abolish_all_tables` + re-evaluation after the update; `point` is a
fresh evaluation of path(0, N) after the updates; `peak MB` is the process's peak resident memory
(VmHWM) after the initial query, the add and the delete.  Both sides collect the answers in
a list without sorting them: SWI's side `findall(x, Goal, _)`, ours `aq_register/4` with
`answers(unsorted)` (the answers in the order of their table; aq_register/3 sorts them, 0.03 s
more for the 100k answers of the left chain).  After the table, every target
is printed with its ratio and met/MISSED; then the 2APL usecases (benchmarks/aq_2apl.py).
"""
from __future__ import annotations

import argparse
import functools
import random
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retalisc.compiler import AqOptions, compile_source  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import swipl_run  # noqa: E402

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
report_peak :- read_file_to_string('/proc/self/status', S, []), split_string(S, "\\n", "", Ls),
    ( member(L, Ls), sub_string(L, 0, _, _, "VmHWM:") -> split_string(L, " \\t", " \\t", Ps),
      include([X]>>(X \\== ""), Ps, [_, Kb|_]), number_string(K, Kb), M is K / 1024, report(peak_mb, M)
    ; true ).
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


def program6(seed=42, users=500):
    rng = random.Random(seed)
    facts = []
    for artist in range(1, 101):
        spots = set()
        while len(spots) < 30:
            spots.add((rng.randint(0, 10), rng.randint(0, 10)))
        for x, y in sorted(spots):
            facts.append(f"show({artist}, {rng.randint(1, 10)}, [{x}, {y}]).")
    for user in range(1, users + 1):
        facts.append(f"loc({user}, [{rng.randint(0, 10)}, {rng.randint(0, 10)}]).")
        for artist in rng.sample(range(1, 101), 30):
            facts.append(f"likes({user}, {artist}, {rng.randint(1, 10)}, {rng.randint(1, 15)}).")
    return facts


def run_swipl(text: str, timeout=3600):
    return {key: float(value) for key, value in swipl_run.run_swipl(text, timeout).items()}


@functools.lru_cache(maxsize=2)
def compiled(source, mode):
    """The generated program (compiling 100k facts takes the front end a minute: once per mode)."""
    return compile_source(source, "bench.pl", active_queries=AqOptions(mode)).prolog


def ours(rules, facts, goals, add, delete, mode="tabled", point=None):
    """goals: one goal, or a list of goals registered as separate queries.  mode: a
    transformation, optionally with a DRed variant (`tabled:basic`; the default is primary)."""
    goals = [goals] if isinstance(goals, str) else goals
    mode, _, dred = mode.partition(":")
    gen = compiled(rules + "\n".join(facts) + "\n", mode)
    gen += f":- aq_configure([dred({dred or 'primary'})]).\n"
    register = ", ".join(f"aq_register(q{n}, {g}, _, [answers(unsorted)])" for n, g in enumerate(goals))
    main = [
        f"main :- t(({register}), T1), report(initial, T1),",
        f"    t(aq_assert({add}), T2), report(add, T2),",
        f"    t(aq_retract({delete}), T3), report(delete, T3), report_peak,",
        "    t(aq_reset, T4), report(unregister, T4),",
    ]
    if point:
        main.append(f"    t(aq_register(p, {point}, _, [answers(unsorted)]), T5), report(point, T5),")
    main.append("    true.")
    return run_swipl(gen + TIMER + "\n".join(main) + "\n")


def swi(rules, facts, goals, add, delete, how, preds, point=None):
    """how: table | incremental | monotonic | subsumptive."""
    goals = [goals] if isinstance(goals, str) else goals
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
    evaluate = ", ".join(f"findall(x, {g}, _)" for g in goals)
    if how in ("incremental", "monotonic"):
        add_g = f"(assertz({add}), {evaluate})"
        del_g = f"(retract({delete}), {evaluate})"
    else:
        add_g = f"(assertz({add}), abolish_all_tables, {evaluate})"
        del_g = f"(retract({delete}), abolish_all_tables, {evaluate})"
    main = (f"main :- t(({evaluate}), T1), report(initial, T1),\n"
            f"    t({add_g}, T2), report(add, T2),\n    t({del_g}, T3), report(delete, T3), report_peak,\n"
            f"    statistics(table_space_used, S), report(table_space, S)")
    if point:
        main += f",\n    abolish_all_tables, t(findall(x, {point}, _), T5), report(point, T5)"
    return run_swipl("\n".join(decls) + "\n" + rules + "\n".join(facts) + "\n" + TIMER + main + ".\n")


REPEATS = 1   # every (scenario, system) process runs this many times; each figure is the least


def scenario(name, rules, facts, goals, add, delete, preds, systems, rows, progress, modes=("tabled",),
             point=None):
    def measure(system, run):
        progress(f"{name}: {system}")
        try:
            runs = [run() for _ in range(REPEATS)]
            rows.append((name, system, {k: min(r[k] for r in runs) for k in runs[0]}))
        except Exception as exc:  # a run that fails is reported, not hidden
            rows.append((name, system, {"error": str(exc).strip().splitlines()[-1][:60]}))

    for mode in modes:
        label = mode.replace(":basic", ", basic DRed")
        measure(f"{label} (ours)", lambda: ours(rules, facts, goals, add, delete, mode, point))
    for how in systems:
        measure(f"SWI {how}", lambda: swi(rules, facts, goals, add, delete, how, preds, point))


def reachable(edges, start):
    succ = {}
    for a, b in edges:
        succ.setdefault(a, []).append(b)
    seen, todo = {start}, [start]
    while todo:
        for b in succ.get(todo.pop(), []):
            if b not in seen:
                seen.add(b)
                todo.append(b)
    return seen


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="smaller sizes (smoke run)")
    ap.add_argument("--png", default="benchmarks/results/active_queries.png")
    ap.add_argument("--skip-2apl", action="store_true", help="leave out the 2APL usecases")
    ap.add_argument("--repeats", type=int, default=None,
                    help="runs per (scenario, system), keeping the least of each figure (default 2, --quick 1)")
    args = ap.parse_args(argv)
    global REPEATS
    REPEATS = args.repeats or (1 if args.quick else 2)
    t0 = time.time()

    def progress(msg):
        print(f"[{time.time() - t0:7.1f}s] {msg}", file=sys.stderr, flush=True)

    rows = []
    path_preds = {"dynamic": ["edge/2"], "tabled": ["path/2"]}
    n = 200 if args.quick else 1000
    scenario(f"chain-right-{n}", RIGHT, chain(n), "path(0, _)", f"edge({n}, {n + 1})",
             f"edge({n // 2}, {n // 2 + 1})", path_preds, ["table", "incremental", "monotonic", "subsumptive"],
             rows, progress, modes=("tabled", "tabled:basic", "optimized", "naive"), point=f"path(0, {n})")
    big = 10000 if args.quick else 100000
    scenario(f"chain-left-{big // 1000}k", LEFT, chain(big), "path(0, _)", f"edge({big}, {big + 1})",
             f"edge({big // 2}, {big // 2 + 1})", path_preds, ["table", "incremental", "monotonic"], rows, progress,
             modes=("tabled", "tabled:basic"), point=f"path(0, {big})")
    nodes, n_edges = (300, 900) if args.quick else (1000, 3000)
    rng = random.Random(7)
    edges = set()
    while len(edges) < n_edges:
        edges.add((rng.randrange(nodes), rng.randrange(nodes)))
    edges = sorted(edges)
    reach = reachable(edges, 0)
    # an edge that changes no answer: from 0 to a node 0 already reaches
    useless = next(b for b in sorted(reach) if b != 0 and (0, b) not in edges)
    victim = edges[len(edges) // 2]
    scenario(f"random-{nodes}x{n_edges}", RIGHT, [f"edge({a}, {b})." for a, b in edges], "path(0, _)",
             f"edge(0, {useless})", f"edge({victim[0]}, {victim[1]})", path_preds, ["table", "incremental", "monotonic"],
             rows, progress, modes=("tabled", "tabled:basic"))
    facts6 = program6(users=50 if args.quick else 500)
    victim6 = next(f for f in facts6 if f.startswith("likes(1,"))[:-1]
    preds6 = {"dynamic": ["loc/2", "show/3", "likes/4"], "tabled": ["notify/4"]}
    scenario("program6", NOTIFY, facts6, "notify(_, _, _, _)", "loc(1, [2, 3])", victim6, preds6,
             ["table", "incremental", "monotonic"], rows, progress, modes=("tabled", "tabled:basic", "optimized"))
    users = 50 if args.quick else 500
    scenario(f"program6-{users}q", NOTIFY, facts6, [f"notify({u}, _, _, _)" for u in range(1, users + 1)],
             "loc(1, [2, 3])", victim6, preds6, ["table", "incremental", "monotonic"], rows, progress)
    print_table(rows)
    print()
    checks = print_targets(rows, n, big, nodes, n_edges, users)
    plot_targets(checks, str(Path(args.png).with_name("active_queries_targets.png")))
    print()
    print_dred(rows)
    apl_rows = []
    if not args.skip_2apl:
        import aq_2apl
        print()
        apl_rows = aq_2apl.run(quick=args.quick, progress=progress)
        aq_2apl.print_table(apl_rows)
        for text, met in aq_2apl.targets(apl_rows):
            print(f"  target {text}: {'met' if met else 'MISSED' if met is not None else 'no figure'}")
        aq_2apl.plot(apl_rows, str(Path(args.png).with_name("aq_2apl.png")))
    plot(rows, args.png)
    progress(f"done; plots in {Path(args.png).parent}")


def figure(rows, scen, system, key):
    for s, sy, res in rows:
        if s == scen and sy == system and "error" not in res:
            return res.get(key)
    return None


def print_targets(rows, n, big, nodes, n_edges, users):
    ours = "tabled (ours)"

    def ratio(scen, system, key):
        a, b = figure(rows, scen, ours, key), figure(rows, scen, system, key)
        return None if a is None or not b else a / b

    checks = []
    chain_r, chain_l, rand = f"chain-right-{n}", f"chain-left-{big // 1000}k", f"random-{nodes}x{n_edges}"
    checks.append(("chain-right add <= 0.1x incremental", ratio(chain_r, "SWI incremental", "add"), 0.1))
    checks.append(("chain-right add <= 1x monotonic", ratio(chain_r, "SWI monotonic", "add"), 1.0))
    checks.append((f"{chain_l} add <= 0.1x incremental", ratio(chain_l, "SWI incremental", "add"), 0.1))
    checks.append((f"{rand} add <= 0.01x incremental", ratio(rand, "SWI incremental", "add"), 0.01))
    for scen in (chain_r, chain_l, rand):
        checks.append((f"{scen} delete <= 0.5x recompute (table)", ratio(scen, "SWI table", "delete"), 0.5))
        checks.append((f"{scen} delete <= 0.25x monotonic", ratio(scen, "SWI monotonic", "delete"), 0.25))
    for scen in ("program6", f"program6-{users}q"):
        checks.append((f"{scen} retract <= 0.1x incremental", ratio(scen, "SWI incremental", "delete"), 0.1))
        checks.append((f"{scen} add <= 0.05x incremental", ratio(scen, "SWI incremental", "add"), 0.05))
        checks.append((f"{scen} delete <= 0.5x recompute (table)", ratio(scen, "SWI table", "delete"), 0.5))
        checks.append((f"{scen} delete <= 0.25x monotonic", ratio(scen, "SWI monotonic", "delete"), 0.25))
    # targets: initial evaluation and peak memory within 1.5x `table` everywhere
    for scen in (chain_r, chain_l, rand, "program6", f"program6-{users}q"):
        checks.append((f"{scen} initial <= 1.5x table", ratio(scen, "SWI table", "initial"), 1.5))
        checks.append((f"{scen} peak memory <= 1.5x table", ratio(scen, "SWI table", "peak_mb"), 1.5))
    checks.append((f"{chain_r} initial <= 1x table", ratio(chain_r, "SWI table", "initial"), 1.0))
    checks.append((f"{chain_r} point query path(0,{n}) <= 1x table", ratio(chain_r, "SWI table", "point"), 1.0))
    checks.append((f"{chain_l} point query path(0,{big}) <= 1x table", ratio(chain_l, "SWI table", "point"), 1.0))
    print("targets (ratio ours / SWI in this run):")
    for text, value, limit in checks:
        verdict = "no figure" if value is None else ("met" if value <= limit else "MISSED")
        shown = "-" if value is None else f"{value:.3g}"
        print(f"  {text:<52} {shown:>8}  {verdict}")
    return checks


def plot_targets(checks, png):
    """Every target's ratio against its limit (log scale): green met, red MISSED."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    shown = [(text, value, limit) for text, value, limit in checks if value is not None]
    if not shown:
        return
    fig, ax = plt.subplots(figsize=(10, 0.3 * len(shown) + 1))
    ys = range(len(shown))
    ax.barh(ys, [max(v / limit, 1e-4) for _, v, limit in shown],
            color=["tab:green" if v <= limit else "tab:red" for _, v, limit in shown])
    ax.axvline(1.0, color="black", linewidth=1)
    ax.set_yticks(list(ys))
    ax.set_yticklabels([t for t, _, _ in shown], fontsize=6)
    ax.set_xscale("log")
    ax.set_title("ratio / target (< 1: met), ours vs SWI-Prolog in the same run")
    fig.tight_layout()
    Path(png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=120)


def print_dred(rows):
    """The two DRed variants side by side (both compute ranks: only deletion differs)."""
    print("DRed variants (tabled): primary = over-delete an answer only along a derivation that may have"
          " created it; basic = along every derivation")
    print(f"  {'scenario':<18} {'delete primary':>15} {'delete basic':>13} {'basic/primary':>14}")
    for scen in dict.fromkeys(r[0] for r in rows):
        p, b = figure(rows, scen, "tabled (ours)", "delete"), figure(rows, scen, "tabled, basic DRed (ours)", "delete")
        if p is not None and b is not None:
            print(f"  {scen:<18} {p:15.4f} {b:13.4f} {b / max(p, 1e-9):14.3g}")


def print_table(rows):
    by = {}
    for scen, system, res in rows:
        by.setdefault(scen, {})[system] = res
    keys = ("initial", "add", "delete", "point", "peak_mb")
    print(f"{'scenario':<18} {'system':<18} {'initial':>9} {'add':>9} {'delete':>9} {'point':>9} {'peak MB':>8}"
          f"   ours(tabled)/system: initial, add, delete, point, peak")
    for scen, systems in by.items():
        mine = systems.get("tabled (ours)", {})
        for system, res in systems.items():
            if "error" in res:
                print(f"{scen:<18} {system:<18} error: {res['error']}")
                continue
            cells = " ".join(f"{res[k]:9.4f}" if k in res else f"{'-':>9}" for k in keys[:4])
            cells += f" {res['peak_mb']:8.0f}" if "peak_mb" in res else f" {'-':>8}"
            ratio = ""
            if system != "tabled (ours)":
                ratio = "   " + ", ".join(
                    f"{mine[k] / res[k]:.3g}" if res.get(k) and k in mine else "-" for k in keys)
            print(f"{scen:<18} {system:<18} {cells}{ratio}")


def plot(rows, png):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
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
    Path(png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=120)


if __name__ == "__main__":
    main()
