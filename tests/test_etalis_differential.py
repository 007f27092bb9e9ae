"""Differential test against the original ETALIS engine.

Seeded random rules built from `seq`, `and`, `or` and `where`, with named and anonymous
variables, over events with one or two keys, run by ETALIS (`../shared/peers/etalis`, in its
own `swipl --traditional` process through tests/etalis_driver.pl) and by retalisc under
`recent` and `chronological`, on seeded random in-order streams; the detections (head and
interval, as multisets) must be equal for every stream and rule.

The documented differences (docs/compatibility.md) are left out by construction: no `cnot`,
no `unrestricted` policy, unique values (so no two events are twins), `where` only directly
around an event atom (a condition after a join consumes the partners in ETALIS before it
fails), an event atom as the right operand of `seq` (ETALIS takes a waiting partner out
before it checks the order of a sequence, and puts it back first when the check fails), and
`or` only where its results are not stored by another operator (ETALIS's twin replacement
unifies partial matches, and one from a branch of an `or` has unbound variables). Size: RETALISC_DIFF_STREAMS streams (default 60) and RETALISC_DIFF_RULES
rules (default 20) per family (one key, two keys) and policy, RETALISC_DIFF_SEED another
seed; RETALISC_ETALIS points to another copy of ETALIS.
"""
import os
import random
import subprocess
from collections import Counter, defaultdict
from pathlib import Path

import pytest

from retalisc.driver.engine import Engine

ROOT = Path(__file__).resolve().parent.parent
ETALIS = Path(os.environ.get("RETALISC_ETALIS", ROOT.parent / "shared" / "peers" / "etalis"))
DRIVER = Path(__file__).with_name("etalis_driver.pl")
STREAMS = int(os.environ.get("RETALISC_DIFF_STREAMS", "60"))
RULES = int(os.environ.get("RETALISC_DIFF_RULES", "20"))
SEED = os.environ.get("RETALISC_DIFF_SEED", "etalis")
TYPES = ["a", "b", "c", "d"]

pytestmark = pytest.mark.skipif(not (ETALIS / "src" / "etalis.P").is_file(),
                                reason=f"the original ETALIS is not at {ETALIS} (../shared/peers/etalis "
                                       "next to the repository, or RETALISC_ETALIS)")


class RuleMaker:
    """Random rules over events `t(K, V)` (one key) or `t(K, L, V)` (two keys)."""

    def __init__(self, rng: random.Random, keys: int, values: int):
        self.rng, self.keys, self.values = rng, keys, values
        self.count = 0

    def atom(self, kind):
        """(text, variables bound in every match, named variables)."""
        rng = self.rng
        self.count += 1
        value = f"X{self.count}" if rng.random() < 0.6 else "_"
        key_args = ["K"] + (["L" if rng.random() < 0.7 else "_"] if self.keys == 2 else [])
        text = f"{kind}({', '.join(key_args + [value])})"
        named = {v for v in key_args + [value] if v != "_"}
        if value != "_" and rng.random() < 0.35:
            op = rng.choice(["<", ">", "=<", ">="])
            text = f"({text} where ({value} {op} {rng.randint(1, self.values)}))"
        return text, named, named

    def pattern(self, kinds, top=True):
        if len(kinds) == 1:
            return self.atom(kinds[0])
        # `or` only where its results are not stored (at the top, or under another `or`): a
        # partial match from one branch leaves the other branch's variables unbound, and
        # ETALIS's twin replacement unifies it with one from the other branch
        op = self.rng.choice(["seq", "seq", "and", "or"] if top else ["seq", "seq", "and"])
        # the right operand of a sequence is an event atom: ETALIS takes a waiting partner out
        # before it checks the order and puts it back first (docs/compatibility.md)
        split = len(kinds) - 1 if op == "seq" else self.rng.randint(1, len(kinds) - 1)
        below_top = op == "or" and top
        left, right = self.pattern(kinds[:split], below_top), self.pattern(kinds[split:], below_top)
        bound = left[1] & right[1] if op == "or" else left[1] | right[1]
        return f"({left[0]} {op} {right[0]})", bound, left[2] | right[2]

    def rule(self, index):
        kinds = self.rng.sample(TYPES, self.rng.choice([2, 2, 3]))
        text, bound, _ = self.pattern(kinds)
        values = sorted(v for v in bound if v.startswith("X"))
        head_args = [k for k in ("K", "L") if k in bound] + self.rng.sample(values, min(len(values), 2))
        return f"r{index}({', '.join(head_args)}) <- {text}."


def make_stream(rng: random.Random, keys: int, length: int):
    """In order, one event per second, unique values."""
    values = rng.sample(range(1, 4 * length), length)
    events = []
    for t, value in enumerate(values, start=1):
        key_args = [str(rng.randint(1, 2)) for _ in range(keys)]
        events.append((f"{rng.choice(TYPES)}({', '.join(key_args + [str(value)])})", t))
    return events


def run_etalis(tmp_path: Path, policy: str, rules: str, streams):
    rule_file = tmp_path / f"rules_{policy}.event"
    rule_file.write_text(rules)
    stream_file = tmp_path / f"streams_{policy}.pl"
    stream_file.write_text("".join(
        f"stream({n}, [{', '.join(f'ev({e}, {t})' for e, t in events)}]).\n" for n, events in enumerate(streams)))
    run = subprocess.run(["swipl", "--traditional", "-q", str(DRIVER), str(ETALIS), policy, str(rule_file),
                          str(stream_file)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    found = defaultdict(Counter)
    for line in run.stdout.splitlines():
        n, head, start, end = line.split("\t")
        found[int(n)][(head, int(start), int(end))] += 1
    return found


def run_retalisc(policy: str, rules: str, streams):
    engine = Engine.from_source(f":- set_etalis_flag(event_consumption_policy, {policy}).\n{rules}", "diff.rtl")
    found = defaultdict(Counter)
    for n, events in enumerate(streams):
        engine.clear()
        for o in engine.feed_batch(events):
            found[n][(o.event, o.start, o.end)] += 1
    return found


@pytest.mark.parametrize("keys", [1, 2])
@pytest.mark.parametrize("policy", ["recent", "chronological"])
def test_retalisc_detects_what_etalis_detects(tmp_path, policy, keys):
    rng = random.Random(f"{SEED}-{keys}")               # the same rules and streams for both policies
    maker = RuleMaker(rng, keys, values=80)
    rules = "\n".join(maker.rule(i) for i in range(1, RULES + 1)) + "\n"
    streams = [make_stream(rng, keys, rng.randint(8, 24)) for _ in range(STREAMS)]
    etalis = run_etalis(tmp_path, policy, rules, streams)
    ours = run_retalisc(policy, rules, streams)
    detections = sum(sum(c.values()) for c in etalis.values())
    assert detections > STREAMS                         # the rules do fire
    mismatches = [(n, streams[n], sorted((etalis[n] - ours[n]).elements()), sorted((ours[n] - etalis[n]).elements()))
                  for n in range(len(streams)) if etalis[n] != ours[n]]
    assert not mismatches, f"{len(mismatches)} of {len(streams)} streams differ; rules:\n{rules}\nfirst: " \
                           f"stream {mismatches[0][1]}\nonly ETALIS: {mismatches[0][2]}\nonly retalisc: {mismatches[0][3]}"



# ETALIS forms whose meaning retalisc shares (docs/compatibility.md): the operators spelled
# 'SEQ', 'Seq', 'AND', 'WHERE', ...; the aggregates count and sum, which give 0 when the
# start event opens them (min and max are left out: ETALIS gives -100000 / 100000 there);
# timestamp, event_multiply over db/1 facts, star_times.
ETALIS_FORMS = """r1(X) <- a(X) 'SEQ' b(X).
r2(X) <- a(X) 'AND' b(X) 'WHERE' X > 1.
r3(X) <- a(X) 'OR' d(X) 'Seq' b(X).
r4(X, Y) <- a(X) 'And' d(Y) 'Where' X < Y.
r5(S, N) <- start(S) seq aggregate(count, price(_), N).
r6(S, T) <- start(S) 'SEQ' aggregate(sum(P), price(P), T).
db(route(lab, door)).
db(route(lab, window)).
r7(X, D) <- (a(X) seq b(X)) timestamp (t1(T1), t2(T2), D is T2 - T1, D > 2).
r8(P, To) <- move(P, From) 'event_multiply' route(From, To).
r9(X) <- start(X) seq b(X) 'star_times'.
"""


def test_etalis_forms_as_etalis(tmp_path):
    """Both engines read the same rules and detect the same (under `unrestricted`: under
    `recent` a new start event takes an open aggregate's place in ETALIS, docs/compatibility.md)."""
    streams = [[("a(1)", 1), ("b(1)", 2), ("g(2)", 3), ("a(2)", 4), ("b(2)", 6), ("d(3)", 7), ("b(3)", 8)],
               [("price(100)", 1), ("start(x)", 2), ("price(5)", 3), ("price(9)", 4), ("start(y)", 5),
                ("price(2)", 6)],
               [("move(p1, lab)", 1), ("start(1)", 2), ("a(1)", 2), ("start(2)", 3), ("b(1)", 4), ("a(2)", 7),
                ("b(2)", 8), ("b(1)", 9), ("move(p2, lab)", 10)]]
    etalis = run_etalis(tmp_path, "unrestricted", ETALIS_FORMS, streams)
    ours = run_retalisc("unrestricted", ETALIS_FORMS, streams)
    assert sum(etalis[0].values()) >= 7 and etalis[1][("r5(x,0)", 2, 2)] == 1
    assert etalis[2][("r8(p2,window)", 10, 10)] == 1 and etalis[2][("r9(1)", 2, 9)] == 1
    assert ours == etalis
