"""2APL shopping usecases 1-6 (thesis section 6.4.1.3) for active queries, in deliberation cycles
per second: scratch re-evaluation, a cache invalidated on relevant change, our three active-query
transformations (tabled, optimized, naive) and SWI-Prolog 9's monotonic and incremental tabling,
both for all answers of a goal and for a goal that is never available.

    python benchmarks/aq_2apl.py [--quick] [--png benchmarks/results/aq_2apl.png]

Scenario.  The belief base holds the rule

    accessible(O, S) :- seller(S, T), has(T, O), offers(S, O, P).

K seller types with 100 object types each (has(T, O) with O = T*1000 + i, i = 1..100), 100
sellers s1..s100, seller i of type ((i-1) mod K) + 1, M offers per seller (distinct objects, price
1..100): exactly 80 % of a seller's offers are objects of its own type (they make accessible/2
true), 20 % objects of other types (never accessible through that seller).  Random seed fixed.
Object 1100 (type 1) is the goal that is *never available*: has(1, 1100) holds but no offer,
initial or added, is ever for it.  O* is the type-1 object offered by the most sellers initially.

    UC1  K=10, M=10, no updates        UC2  K=50, M=50, no updates
    UC3  K=10, M=10, each cycle one new seller (next index, type by the same rule) with one offer
    UC4  K=50, M=50, as UC3
    UC5  K=10, M=10 ("similar to usecase 3" in the thesis), no new sellers; each cycle deletes the
         10 oldest offers (FIFO over a shuffled initial order, then the added ones) and adds 10
    UC6  as UC5 with 30 deletions and 30 additions per cycle

Query variants (our interpretation of "both for all answers and for a goal that is never
available"):

    all    the cycle's belief query asks for the sorted set of all answers of accessible(O, S).
           UC1/2: the goal need(O) is new every cycle (the thesis setting: the agent drops an
           achieved goal and gets a new one): O runs through every accessible object in a fixed
           shuffled order, so each query succeeds on its first attempt.  The order is repeated in
           rounds to get enough cycles; at the start of each round the cache and SWI's tables are
           emptied, so a repeated goal is never answered from memory of an earlier round (with
           no updates at all that would measure a hash lookup, not query evaluation).  Active
           queries register the query for the goal and unregister it when the goal is dropped.
           UC3-6: one goal need(O*) kept for the whole run (a query that stays registered), whose
           answers exist and change: in UC3/4 every 5th new seller of type 1 offers O* (the others
           follow the 80/20 rule); in UC5/6 the first added offer of every cycle is O*, by one
           type-1 seller for 50 cycles, then by the next one (FIFO deletion later takes them
           away: sellers gain and lose O*).
    never  the goal need(1100), never available, kept for the whole run, the same query every
           cycle (thesis UC3-6).  In UC1/2 there are no updates: a static belief base.

A deliberation cycle applies the cycle's updates (deletions first), then evaluates the query:

    scratch      retract/assertz plain dynamic facts; findall + sort.
    cache        as scratch, plus one cached answer list per goal, invalid once a fact of a
                 relevant predicate (seller/has/offers) was asserted or retracted since.
    tabled, optimized, naive
                 our active queries (retalisc.backends.prolog.aq_backend): aq_retract_all /
                 aq_assert_all; new goal: aq_register + aq_unregister; kept goal: registered in
                 the first cycle, then aq_events (drain the queue) + aq_answers.
    SWI monotonic, SWI incremental
                 `:- table accessible/2 as monotonic|incremental` over dynamic facts declared the
                 same way; retract/assertz; findall + sort.

Each (usecase, variant, approach) runs in one fresh `swipl` process; the figure is CPU time
(statistics(process_cputime): includes SWI's clause-GC thread, busy after many retracts) of the
cycle loop only, loading excluded, first registration / table creation included; the full run
repeats every process twice and keeps the faster (the machine is shared).  UC3-6 run the same
fixed number of cycles in every approach (the belief base grows or churns with the cycles, so the
ratios depend on it: scratch costs O(sellers) per cycle in UC3/4, the active queries O(1)); UC1/2
(stationary) run up to a CPU-time budget (see FULL / QUICK below).  The active-query runs load
the runtime from the working tree (prolog_runtime/, or $RETALIS_RUNTIME).

Checks, so that no approach can silently measure less work (a failed check is printed as WRONG
and makes the exit status 1): every run reports the sum over its cycles of the number of answers
and the number of seller + offers facts at the end, both compared with an independent Python
model of the market; and after the loop the Prolog main compares the approach's answers for the
last goal with a plain Prolog evaluation over the final facts.
"""
from __future__ import annotations

import argparse
import functools
import random
import subprocess
import sys
import time
from collections import Counter, deque
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from retalisc.compiler import AqOptions, compile_source  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import swipl_run  # noqa: E402

SEED = 2013
RULE = "accessible(O, S) :- seller(S, T), has(T, O), offers(S, O, P).\n"
NEVER = 1100
APPROACHES = ["scratch", "cache", "tabled", "optimized", "naive", "SWI monotonic", "SWI incremental"]
USECASES = {
    1: dict(K=10, M=10, kind="static"),
    2: dict(K=50, M=50, kind="static"),
    3: dict(K=10, M=10, kind="sellers"),
    4: dict(K=50, M=50, kind="sellers"),
    5: dict(K=10, M=10, kind="churn", churn=10),
    6: dict(K=10, M=10, kind="churn", churn=30),
}
# cycles of the UC3-6 runs, and the CPU budget (s) and cycle cap of the stationary UC1/2 runs
# and how many times each run is repeated (the fastest counts: the machine is shared)
FULL = dict(cycles={3: 5000, 4: 5000, 5: 5000, 6: 4000}, budget=1.0, static_cap=1000000, repeats=2)
QUICK = dict(cycles={3: 300, 4: 300, 5: 200, 6: 100}, budget=0.2, static_cap=50000, repeats=1)


# --------------------------------------------------------------------------- the market model

class Market:
    """The facts, and the answers of accessible(O, _) as a Python model (the oracle)."""

    def __init__(self, K, M, rng):
        self.K, self.rng = K, rng
        self.type = {}                 # seller -> type
        self.offers = set()            # (S, O, P)
        self.count = Counter()         # (S, O) -> number of offers
        for i in range(1, 101):
            s, t = f"s{i}", (i - 1) % K + 1
            self.type[s] = t
            n_own = round(0.8 * M)
            own = rng.sample(range(1, 100), n_own)          # i = 100 (object T*1000+100) is never offered
            objs = [t * 1000 + j for j in own]
            others = set()
            while len(others) < M - n_own:
                others.add(self.other_object(t))
            for o in objs + sorted(others):
                self.add_offer((s, o, rng.randint(1, 100)))

    def other_object(self, t):
        if self.K == 1:
            raise ValueError("need two seller types")
        while True:
            u = self.rng.randint(1, self.K)
            if u != t:
                return u * 1000 + self.rng.randint(1, 99)

    def random_object(self, t):
        return t * 1000 + self.rng.randint(1, 99) if self.rng.random() < 0.8 else self.other_object(t)

    def add_offer(self, f):
        assert f not in self.offers and f[1] != NEVER
        self.offers.add(f)
        self.count[f[:2]] += 1

    def del_offer(self, f):
        self.offers.remove(f)
        self.count[f[:2]] -= 1

    def fresh_offer(self, s, o):
        while True:
            f = (s, o, self.rng.randint(1, 100))
            if f not in self.offers:
                return f

    def answers(self, o):
        t = o // 1000
        return sum(1 for s, ts in self.type.items() if ts == t and self.count[(s, o)] > 0)

    def facts(self):
        out = [f"seller({s}, {t})." for s, t in self.type.items()]
        out += [f"has({t}, {t * 1000 + i})." for t in range(1, self.K + 1) for i in range(1, 101)]
        out += [f"offers({s}, {o}, {p})." for s, o, p in sorted(self.offers, key=lambda f: (int(f[0][1:]), f[1], f[2]))]
        return out


def fact(f):
    if len(f) == 2:
        return f"seller({f[0]}, {f[1]})"
    return f"offers({f[0]}, {f[1]}, {f[2]})"


def scenario(uc, variant, conf):
    """The facts, the per-cycle goal/updates and the expected answer counts of one run."""
    spec = USECASES[uc]
    rng = random.Random(SEED * 10 + uc)
    market = Market(spec["K"], spec["M"], rng)
    facts = market.facts()
    type1 = [s for s, t in market.type.items() if t == 1]
    o_star = max(range(1001, 1100), key=lambda o: (market.answers(o), -o))
    sc = dict(uc=uc, variant=variant, facts=facts, updates={}, goals=None, query=None)
    if spec["kind"] == "static":
        sc["budget"], sc["cycles"] = conf["budget"], conf["static_cap"]
        if variant == "all":
            goals = [o for t in range(1, spec["K"] + 1) for o in range(t * 1000 + 1, t * 1000 + 101)
                     if market.answers(o) > 0]
            rng.shuffle(goals)
            sc["goals"] = goals
            counts = [market.answers(o) for o in goals]
            sc["expected"] = lambda n: (n // len(goals)) * sum(counts) + sum(counts[:n % len(goals)])
        else:
            sc["query"] = NEVER
            sc["expected"] = lambda n: 0
        sc["facts_at_end"] = len(market.type) + len(market.offers)
        return sc
    n = conf["cycles"][uc]
    sc["budget"], sc["cycles"] = 0, n
    sc["query"] = o_star if variant == "all" else NEVER
    expected = []
    if spec["kind"] == "sellers":
        for c in range(1, n + 1):
            i = 100 + c
            s, t = f"s{i}", (i - 1) % spec["K"] + 1
            market.type[s] = t
            hot = t == 1 and (i - 1) // spec["K"] % 5 == 0      # every 5th new type-1 seller
            f = market.fresh_offer(s, o_star if hot else market.random_object(t))
            market.add_offer(f)
            sc["updates"][c] = ([(s, t), f], [])
            expected.append(market.answers(sc["query"]))
    else:
        k = spec["churn"]
        queue = deque(sorted(market.offers))
        rng.shuffle(queue)
        sellers = list(market.type)
        for c in range(1, n + 1):
            dels = [queue.popleft() for _ in range(k)]
            for f in dels:
                market.del_offer(f)
            adds = [market.fresh_offer(type1[c // 50 % len(type1)], o_star)]   # 50 cycles per seller
            market.add_offer(adds[0])
            while len(adds) < k:
                s = rng.choice(sellers)
                f = market.fresh_offer(s, market.random_object(market.type[s]))
                market.add_offer(f)
                adds.append(f)
            queue.extend(adds)
            sc["updates"][c] = (adds, dels)
            expected.append(market.answers(sc["query"]))
    sc["expected"] = lambda m: sum(expected[:m])
    sc["facts_at_end"] = len(market.type) + len(market.offers)
    return sc


# --------------------------------------------------------------------------- Prolog programs

DRIVER = r"""
b_ref_accessible(O, S) :- seller(S, T), has(T, O), offers(S, O, _).
b_scratch(O, As) :- findall(accessible(O, S), b_ref_accessible(O, S), L), sort(L, As).

b_goal_for(C, O) :-
    (   b_query(O0)
    ->  O = O0
    ;   b_goal_len(L), I is (C - 1) mod L, b_goal_at(I, O),
        ( I =:= 0 -> b_round_reset ; true )
    ).

b_cycle(C, As) :-
    ( b_upd(C, Adds, Dels) -> b_apply(Adds, Dels) ; true ),
    b_goal_for(C, O),
    b_answers(O, As).

b_loop(C, N, Dl, S0, S, E0, E, Done) :-
    (   C > N
    ->  S = S0, E = E0, Done = N
    ;   C /\ 31 =:= 0, statistics(process_cputime, Now), Now > Dl
    ->  S = S0, E = E0, Done is C - 1
    ;   b_cycle(C, As),
        length(As, Len),
        S1 is S0 + Len,
        ( Len > 0 -> E1 is E0 + 1 ; E1 = E0 ),
        C1 is C + 1,
        b_loop(C1, N, Dl, S1, S, E1, E, Done)
    ).

main :-
    b_setup,
    b_cycles(N), b_budget(B),
    garbage_collect,
    statistics(process_cputime, T0),
    ( B > 0 -> Dl is T0 + B ; Dl = 1.0e18 ),
    b_loop(1, N, Dl, 0, Sum, 0, NE, Done),
    statistics(process_cputime, T1),
    T is T1 - T0,
    ( Done > 0 -> b_goal_for(Done, O), b_answers(O, As), b_scratch(O, R) ; As = [], R = [] ),
    ( As == R -> Check = ok ; Check = mismatch ),
    length(R, NR),
    aggregate_all(count, seller(_, _), NS),
    aggregate_all(count, offers(_, _, _), NO),
    format("cycles ~d~nseconds ~6f~nsum ~d~nnonempty ~d~ncheck ~w~nlast ~d~nfacts ~d~n",
           [Done, T, Sum, NE, Check, NR, NS + NO]).
"""

PLAIN_UPD = r"""
b_apply(Adds, Dels) :-
    forall(member(F, Dels), retract(F)),
    forall(member(F, Adds), assertz(F)).
"""

HOOKS = {
    "scratch": PLAIN_UPD + r"""
b_setup.
b_round_reset.
b_answers(O, As) :- b_scratch(O, As).
""",
    "cache": r"""
:- dynamic b_cache/3.
b_setup :- nb_setval(b_gen, 0).
b_round_reset :- retractall(b_cache(_, _, _)).
b_relevant(seller(_, _)).
b_relevant(has(_, _)).
b_relevant(offers(_, _, _)).
b_apply(Adds, Dels) :-
    forall(member(F, Dels), retract(F)),
    forall(member(F, Adds), assertz(F)),
    (   ( member(F, Dels) ; member(F, Adds) ), b_relevant(F)
    ->  nb_getval(b_gen, G), G1 is G + 1, nb_setval(b_gen, G1)
    ;   true
    ).
b_answers(O, As) :-
    nb_getval(b_gen, G),
    (   b_cache(O, G, As0)
    ->  As = As0
    ;   b_scratch(O, As),
        retractall(b_cache(O, _, _)),
        assertz(b_cache(O, G, As))
    ).
""",
    "aq": r"""
b_setup :- nb_setval(b_registered, false).
b_round_reset.
b_apply(Adds, Dels) :-
    ( Dels == [] -> true ; aq_retract_all(Dels) ),
    ( Adds == [] -> true ; aq_assert_all(Adds) ).
b_answers(O, As) :-
    (   b_query(_)
    ->  (   nb_getval(b_registered, true)
        ->  true
        ;   aq_register(q, accessible(O, _), _), nb_setval(b_registered, true)
        ),
        aq_events(_),
        aq_answers(q, As)
    ;   aq_register(g, accessible(O, _), As),
        aq_unregister(g)
    ).
""",
    "swi": PLAIN_UPD + r"""
b_setup.
b_round_reset :- abolish_all_tables.
b_answers(O, As) :- findall(accessible(O, S), accessible(O, S), L), sort(L, As).
""",
}


def data_text(sc):
    out = [f"b_cycles({sc['cycles']}).", f"b_budget({sc['budget']})."]
    if sc["query"] is not None:
        out.append(f"b_query({sc['query']}).")
    else:
        out += [":- dynamic b_query/1.", f"b_goal_len({len(sc['goals'])})."]
        out += [f"b_goal_at({i}, {o})." for i, o in enumerate(sc["goals"])]
    if sc["updates"]:
        for c, (adds, dels) in sorted(sc["updates"].items()):
            out.append(f"b_upd({c}, [{', '.join(map(fact, adds))}], [{', '.join(map(fact, dels))}]).")
    else:
        out.append(":- dynamic b_upd/3.")
    return "\n".join(out) + "\n"


DYNAMIC = ":- dynamic seller/2.\n:- dynamic has/2.\n:- dynamic offers/3.\n"


@functools.lru_cache(maxsize=None)
def aq_head(mode):
    """The generated program for the rule; the facts are appended to it (the declarations make
    the predicates dynamic, so this is the same program as with the facts in the source, without
    compiling 10,000 facts through the front end for every run)."""
    return compile_source(DYNAMIC + RULE, "shop.pl", active_queries=AqOptions(mode)).prolog


def program(sc, approach):
    facts = "\n".join(sc["facts"]) + "\n"
    if approach in ("tabled", "optimized", "naive"):
        return aq_head(approach) + "\n" + facts + DRIVER + HOOKS["aq"] + data_text(sc)
    if approach.startswith("SWI"):
        how = approach.split()[1]
        decls = [f":- table accessible/2 as {how}."]
        # one declaration per predicate: SWI 9.0.4 silently ignores `as` on the list form
        decls += [f":- dynamic {p} as {how}." for p in ("seller/2", "has/2", "offers/3")]
        return "\n".join(decls) + "\n" + RULE + facts + DRIVER + HOOKS["swi"] + data_text(sc)
    return DYNAMIC + facts + DRIVER + HOOKS[approach] + data_text(sc)


def run_swipl(text, timeout):
    return swipl_run.run_swipl(text, timeout)


def run(quick: bool = False, progress=lambda msg: None, usecases=None, approaches=None, timeout=300):
    """All (usecase, variant, approach) runs; one dict per row."""
    conf = QUICK if quick else FULL
    rows = []
    for uc in usecases or sorted(USECASES):
        for variant in ("all", "never"):
            sc = scenario(uc, variant, conf)
            for approach in approaches or APPROACHES:
                progress(f"UC{uc} {variant}: {approach}")
                text = program(sc, approach)
                best = None
                for _ in range(conf["repeats"]):
                    row = measure(text, sc, timeout)
                    row.update(usecase=uc, variant=variant, approach=approach)
                    if row["error"]:
                        best = row
                        break
                    if best is None or row["cps"] > best["cps"]:
                        best = row
                rows.append(best)
    return rows


def measure(text, sc, timeout):
    row = dict(cycles=0, seconds=0.0, cps=None, error=None)
    try:
        res = run_swipl(text, timeout)
    except subprocess.TimeoutExpired:
        row["error"] = f"timeout {timeout}s"
    except Exception as exc:  # a failing approach is reported, not hidden
        row["error"] = str(exc).strip().splitlines()[-1][:80] if str(exc).strip() else repr(exc)
    else:
        n, secs = int(res["cycles"]), float(res["seconds"])
        row.update(cycles=n, seconds=secs, cps=n / secs if secs > 0 else float("inf"),
                   answers=int(res["sum"]), expected=sc["expected"](n), nonempty=int(res["nonempty"]),
                   last=int(res["last"]))
        if int(res["facts"]) != sc["facts_at_end"]:
            row["error"] = f"WRONG: {res['facts']} seller+offers facts at the end, expected {sc['facts_at_end']}"
        elif res["check"] != "ok":
            row["error"] = "WRONG: last answers differ from plain evaluation"
        elif row["answers"] != row["expected"]:
            row["error"] = f"WRONG: {row['answers']} answers over the cycles, expected {row['expected']}"
    return row


# --------------------------------------------------------------------------- report

def cps_of(rows, uc, variant, approach):
    for r in rows:
        if (r["usecase"], r["variant"], r["approach"]) == (uc, variant, approach) and not r["error"]:
            return r["cps"]
    return None


def print_table(rows, out=sys.stdout):
    print(f"{'uc':<4}{'variant':<8}{'approach':<17}{'cycles':>8}{'cpu s':>9}{'cycles/s':>12}"
          f"{'vs scratch':>12}{'vs monot.':>11}  answers/cycle", file=out)
    for r in rows:
        head = f"UC{r['usecase']:<2}{r['variant']:<8}{r['approach']:<17}"
        if r["error"] and r["cps"] is None:
            print(f"{head}error: {r['error']}", file=out)
            continue
        base = cps_of(rows, r["usecase"], r["variant"], "scratch")
        mono = cps_of(rows, r["usecase"], r["variant"], "SWI monotonic")
        vs_s = f"{r['cps'] / base:.3g}x" if base else "-"
        vs_m = f"{r['cps'] / mono:.3g}x" if mono else "-"
        apc = r["answers"] / r["cycles"] if r["cycles"] else 0
        line = (f"{head}{r['cycles']:>8}{r['seconds']:>9.3f}{r['cps']:>12.0f}{vs_s:>12}{vs_m:>11}  {apc:.2f}")
        if r["error"]:
            line += f"   {r['error']}"
        print(line, file=out)


def targets(rows):
    """(text, met) for the stated targets; None for met when a figure is missing."""
    out = []
    for uc in (3, 4):
        for variant in ("all", "never"):
            t, s, m = (cps_of(rows, uc, variant, a) for a in ("tabled", "scratch", "SWI monotonic"))
            if None in (t, s, m):
                out.append((f"UC{uc} {variant}: tabled >= SWI monotonic and >= 5x scratch", None))
                continue
            out.append((f"UC{uc} {variant}: tabled >= SWI monotonic ({t / m:.2f}x)", t >= m))
            out.append((f"UC{uc} {variant}: tabled >= 5x scratch ({t / s:.2f}x)", t >= 5 * s))
    for uc in (5, 6):
        for variant in ("all", "never"):
            t, s = cps_of(rows, uc, variant, "tabled"), cps_of(rows, uc, variant, "scratch")
            if None in (t, s):
                out.append((f"UC{uc} {variant}: tabled never slower than scratch", None))
                continue
            out.append((f"UC{uc} {variant}: tabled never slower than scratch ({t / s:.2f}x)", t >= s))
    return out


def plot(rows, png):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    groups = sorted({(r["usecase"], r["variant"]) for r in rows}, key=lambda g: (g[1], g[0]))
    approaches = [a for a in APPROACHES if any(r["approach"] == a for r in rows)]
    fig, axes = plt.subplots(1, 2, figsize=(15, 5), sharey=True)
    width = 0.8 / max(len(approaches), 1)
    for ax, variant in zip(axes, ("all", "never")):
        gs = [g for g in groups if g[1] == variant]
        for k, a in enumerate(approaches):
            xs, ys = [], []
            for n, (uc, v) in enumerate(gs):
                c = cps_of(rows, uc, v, a)
                if c:
                    xs.append(n + (k - (len(approaches) - 1) / 2) * width)
                    ys.append(c)
            ax.bar(xs, ys, width, label=a)
        ax.set_xticks(range(len(gs)))
        ax.set_xticklabels([f"UC{uc}" for uc, _ in gs])
        ax.set_yscale("log")
        ax.set_title(f"goal: {'all answers' if variant == 'all' else 'never available'}")
        ax.set_ylabel("deliberation cycles / s (CPU, log)")
    axes[0].legend(fontsize=8)
    fig.suptitle("2APL shopping usecases: active queries vs scratch, cache and SWI tabling")
    fig.tight_layout()
    Path(png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=120)
    return True


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer cycles (smoke run, < 1 min)")
    ap.add_argument("--png", default="benchmarks/results/aq_2apl.png")
    ap.add_argument("--usecases", type=int, nargs="*", help="subset of 1..6")
    ap.add_argument("--approaches", nargs="*", choices=APPROACHES, help="subset of the approaches")
    args = ap.parse_args(argv)
    t0 = time.time()

    def progress(msg):
        print(f"[{time.time() - t0:7.1f}s] {msg}", file=sys.stderr, flush=True)

    rows = run(args.quick, progress, args.usecases, args.approaches)
    print_table(rows)
    print()
    if args.quick:
        print("(--quick: few cycles, the ratios are noise; the targets refer to the full run)")
    for text, met in targets(rows):
        print(f"target {'met   ' if met else 'MISSED' if met is False else 'n/a   '} {text}")
    bad = [r for r in rows if r["error"]]
    if bad:
        print(f"\n{len(bad)} run(s) failed or wrong: " + ", ".join(f"UC{r['usecase']} {r['variant']} {r['approach']}"
                                                            for r in bad))
    if args.png and plot(rows, args.png):
        print(f"plot: {args.png}")
    progress("done")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
