"""Snapshots of the runtime state (prolog_runtime/rtl_state.pl, Engine.save_state/restore_state):
the state after a restore equals the state saved, and a run stopped at any point, saved and
restored goes on exactly as a run that never stopped."""
import random
import re

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from retalisc.driver.engine import Engine
from retalisc.driver.recovery import StateError

SEQ = "c(X) <- (a(X) seq b(X)).2.\n"
NEGATION = "d(X) <- (not(n(X)).[a(X), b(X)]).3.\n"
SLR = """c_mem(tf, tf(_)-[], 5, inf).
e(X, V) <- b(X) where prev(tf, tf(V)^T, inf).
f(X, V) <- a(X) where (prev(tf, tf(V)^T1, inf), \\+ next(tf, tf(_)^T2, T1, inf)).
"""
SYNC = """memorize(tf(odom, base, V), [], tf(V), odom_base, 100).
memorize(tf(base, cam, V), [], tf(V), base_cam, 100).
at(Id, T, V) :- prev(Id, tf(V1)^T1, T), ( next(Id, tf(V2)^T2, T, inf) -> time_fraction(T1, T2, T, F), V is V1 + F * (V2 - V1) ; V = V1 ).
place(Rel, T, X) :- at(odom_base, T, A), at(base_cam, T, B), X is A + B + Rel.
syncronized(pose(Name, X), place(Rel, T, X), [[odom_base, T], [base_cam, T]]) <- marker(Name, Rel)^T.
"""


def _abn_stream(n, seed):
    rng = random.Random(seed)
    t, out = 0.0, []
    for _ in range(n):
        t = round(t + rng.choice([0.1, 0.5, 1.0, 1.5]), 1)
        out.append((f"{rng.choice('abn')}({rng.randint(0, 3)})", t))
    return out


RECENT_SEQ = ":- set_etalis_flag(event_consumption_policy, recent).\nc(X, Y) <- (a(X, Y) seq b(X)).3.\n"


def _policy_stream(n, seed):
    """Events of a policy step and deletions of some of them: a deletion rewinds the step to
    the arrival number of the deleted instance (rtl_next_seq/1), which the snapshot keeps."""
    rng = random.Random(seed)
    t, out, added = 0.0, [], []
    for _ in range(n):
        t = round(t + rng.choice([0.1, 0.5, 1.0]), 1)
        if added and rng.random() < 0.15:
            event, when = added.pop(rng.randrange(len(added)))
            out.append((event, when, when, "retract"))
        else:
            event = f"a({rng.randint(0, 2)}, {rng.randint(0, 3)})" if rng.random() < 0.6 else f"b({rng.randint(0, 2)})"
            added.append((event, t))
            out.append((event, t))
    return out


def _slr_stream(n, seed):
    rng = random.Random(seed)
    t, out = 0.0, []
    for _ in range(n):
        t = round(t + rng.choice([0.1, 0.5, 1.0]), 1)
        kind = rng.choice(["a", "b", "tf"])
        out.append((f"{kind}({rng.randint(0, 3)})", t))
    return out


def _sync_stream(n, seed):
    rng = random.Random(seed)
    t, out = 0.0, []
    for i in range(n):
        t = round(t + rng.choice([0.1, 0.2, 0.5]), 1)
        kind = rng.choice(["ob", "bc", "m"])
        if kind == "ob":
            out.append((f"tf(odom, base, {rng.randint(0, 9)})", t))
        elif kind == "bc":
            out.append((f"tf(base, cam, {rng.randint(0, 9)})", t))
        else:
            out.append((f"marker(m{i}, {rng.randint(0, 9)})", round(t - rng.choice([0.0, 0.3]), 1)))
    return out


CASES = {
    "seq": (SEQ, _abn_stream(160, 1)),
    "negation": (NEGATION, _abn_stream(160, 2)),
    "slr_prev_next": (SLR, _slr_stream(160, 3)),
    "synchronized": (SYNC, _sync_stream(120, 4)),
    "policy_deletions": (RECENT_SEQ, _policy_stream(160, 5)),
}


def _lines(produced):
    return [o.line for o in produced]


class _Case:
    """One loaded program, its uninterrupted output and its state right after loading."""

    def __init__(self, name, tmp):
        program, self.events = CASES[name]
        self.engine = Engine.from_source(program, name=f"{name}.rtl")
        self.initial = tmp / f"{name}-initial.state"
        self.engine.save_state(self.initial)
        self.full = _lines(self.engine.feed_batch(self.events)) + _lines(self.engine.end_of_input())
        assert self.full, "the case must produce output"


@pytest.fixture(scope="module")
def cases(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("state")
    return tmp, {}


def _case(cases, name):
    tmp, loaded = cases
    if name not in loaded:
        loaded[name] = _Case(name, tmp)
    case = loaded[name]
    case.engine.activate()
    case.engine.restore_state(case.initial)
    return tmp, case


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(sorted(CASES)), fraction=st.floats(0.0, 1.0))
def test_stopping_anywhere_changes_nothing(cases, name, fraction):
    tmp, case = _case(cases, name)
    engine, events = case.engine, case.events
    split = int(fraction * len(events))
    before = _lines(engine.feed_batch(events[:split]))
    digest = engine.state_digest()
    path = tmp / f"{name}-{split}.state"
    engine.save_state(path)
    engine.feed_batch(events[split:])               # the state moves on, then comes back
    assert engine.state_digest() != digest or split == len(events)
    engine.restore_state(path)
    assert engine.state_digest() == digest
    after = _lines(engine.feed_batch(events[split:])) + _lines(engine.end_of_input())
    assert before + after == case.full


def test_restore_into_another_engine_of_the_same_program(tmp_path):
    program, events = CASES["slr_prev_next"]
    full_engine = Engine.from_source(program)
    full = _lines(full_engine.feed_batch(events)) + _lines(full_engine.end_of_input())
    first = Engine.from_source(program)
    before = _lines(first.feed_batch(events[:70]))
    digest = first.state_digest()
    first.save_state(tmp_path / "s.state")
    second = Engine.from_source(program)            # another module name: renamed on restore
    assert second.module != first.module
    second.restore_state(tmp_path / "s.state")
    assert second.state_digest() == digest
    after = _lines(second.feed_batch(events[70:])) + _lines(second.end_of_input())
    assert before + after == full
    assert second.stats()["events"] == len(events)


def test_snapshot_of_another_program_is_refused_and_changes_nothing(tmp_path):
    seq = Engine.from_source(SEQ)
    seq.feed_batch(_abn_stream(40, 5))
    seq.save_state(tmp_path / "seq.state")
    negation = Engine.from_source(NEGATION)
    negation.feed_batch(_abn_stream(40, 6))
    digest = negation.state_digest()
    with pytest.raises(StateError, match="another program or runtime version"):
        negation.restore_state(tmp_path / "seq.state")
    assert negation.state_digest() == digest


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty"])
def test_damaged_snapshot_is_refused_and_changes_nothing(tmp_path, damage):
    engine = Engine.from_source(SEQ)
    engine.feed_batch(_abn_stream(60, 7))
    path = tmp_path / "s.state"
    engine.save_state(path)
    data = path.read_bytes()
    path.write_bytes({"truncated": data[: len(data) * 2 // 3], "garbage": b"\x00\x17junk" * 50,
                      "empty": b""}[damage])
    engine.feed_batch(_abn_stream(10, 8))
    digest = engine.state_digest()
    with pytest.raises(StateError):
        engine.restore_state(path)
    assert engine.state_digest() == digest


def test_save_is_atomic_and_leaves_no_temporary_file(tmp_path):
    engine = Engine.from_source(SEQ)
    engine.feed_batch(_abn_stream(30, 9))
    engine.save_state(tmp_path / "s.state")
    assert [p.name for p in tmp_path.iterdir()] == ["s.state"]


def test_tries_are_rebuilt_with_their_entries_and_stay_shared(tmp_path):
    engine = Engine.from_source(SEQ)
    bridge = engine.bridge
    # an answer table as rtl_aq.pl keeps it: a trie held by a clause and by a global (of a family
    # the runtime declares as state: rtl_state.pl's global_family/2)
    assert bridge.once("trie_new(T), trie_insert(T, ans(1, X), r1), trie_insert(T, ans(2, b), r2), "
                       "assertz(rtl_aq:aq_tab(t1, g(_), T, root, k)), nb_setval('rtl_detected test_table', T)")
    try:
        digest = engine.state_digest()
        engine.save_state(tmp_path / "s.state")
        assert bridge.once("nb_getval('rtl_detected test_table', T), trie_insert(T, ans(3, c), r3)")
        assert engine.state_digest() != digest
        engine.restore_state(tmp_path / "s.state")
        assert engine.state_digest() == digest
        entries = bridge.call_text("rtl_aq:aq_tab(t1, _, T, _, _), nb_getval('rtl_detected test_table', T2), T == T2, "
                                   "blob(T, trie), findall(K-V, trie_gen(T, K, V), L0), msort(L0, L), "
                                   "format(string(Out), '~q', [L])")
        assert re.sub(r"_[0-9]+", "_", entries) == "[ans(1,_)-r1,ans(2,b)-r2]"
    finally:
        bridge.once("retractall(rtl_aq:aq_tab(t1, _, _, _, _)), nb_delete('rtl_detected test_table')")


def test_a_clause_holding_a_stream_makes_the_save_fail_cleanly(tmp_path):
    from retalisc.driver.bridge import PrologError
    engine = Engine.from_source(SEQ)
    engine.bridge.once("stream_property(S, alias(user_input)), assertz(rtl_ele:type_output_hook(x, S))")
    try:
        with pytest.raises(PrologError, match="type_output_hook/2 holds <stream>"):
            engine.save_state(tmp_path / "s.state")
        assert list(tmp_path.iterdir()) == []           # no partial file left behind
    finally:
        engine.bridge.once("retractall(rtl_ele:type_output_hook(x, _))")


def test_rules_added_and_deleted_at_run_time_are_restored_into_a_new_load(tmp_path):
    """A snapshot keeps the rules added at run time as their compiled clauses (installed again,
    after the rule check, into a new load of the program) and the rules of the program file
    deleted since (deleted again): the restored engine goes on as the one that never stopped."""
    program = "r1 'rule:' c(X) <- (a(X) seq b(X)).3.\nr2 'rule:' d(X) <- b(X) seq a(X).\n"
    events = _abn_stream(120, 11)

    def changed(engine):
        engine.add_rules("r3 'rule:' g(X) <- a(X) seq n(X) where X > 1.\n")
        engine.remove_rule("r2")

    whole = Engine.from_source(program)
    changed(whole)
    full = _lines(whole.feed_batch(events)) + _lines(whole.end_of_input())
    assert any(line.startswith('{"event": "g(') for line in full)
    first = Engine.from_source(program)
    changed(first)
    before = _lines(first.feed_batch(events[:60]))
    digest = first.state_digest()
    first.save_state(tmp_path / "s.state")
    second = Engine.from_source(program)
    second.restore_state(tmp_path / "s.state")
    assert second.state_digest() == digest
    after = _lines(second.feed_batch(events[60:])) + _lines(second.end_of_input())
    assert before + after == full
    with pytest.raises(Exception, match="r2"):
        second.remove_rule("r2")                    # deleted, as in the snapshot
