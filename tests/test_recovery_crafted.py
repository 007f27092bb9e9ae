"""A crafted snapshot (docs/recovery.md, "What a snapshot holds"): a snapshot is data, the facts
and globals the runtime declares as state (prolog_runtime/rtl_state.pl). One that holds a clause
with a body, a fact of an undeclared predicate or module, an undeclared global, a goal that the
untrusted-goal check refuses, or a rule added at run time that rtl_check_rule/4 refuses is
refused whole: the state is unchanged and nothing in it runs (a canary file stays absent), on
the Python API and on `retalisc run --state` with its checksum recomputed."""
import hashlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

from retalisc.driver.engine import Engine
from retalisc.driver.recovery import StateError

ROOT = Path(__file__).resolve().parent.parent
PROGRAM = "c(X) <- (a(X) seq b(X)).2.\nc_mem(v, v(_)-[], 5, inf).\n"


def crafted_terms(module: str, canary: Path):
    """name -> the terms (text) a crafted snapshot adds, each of which runs the shell."""
    shell = f'shell("touch {canary}")'
    return {
        "message_hook": f"clause(user, message_hook(_, _, _), {shell}).",
        "message_hook_fact": "fact(user, message_hook(_, _, _)).",
        "ele_trigger_clause": f"clause({module}, ele_trigger(a(_), _, _), {shell}).",
        "ele_trigger_fact": f"fact({module}, ele_trigger(a(1), 0, 0)).",
        "undeclared_global": "global(rtl_program, user).",
        "unknown_global": "global(my_global, 1).",
        "other_module": "fact(lists, append(_, _, _)).",
        "timer_goal": f"fact(rtl_timers, timer(0, 1, alarm, {module}:{shell})).",
        "output_hook": "fact(rtl_ele, output_hook(user:shell)).",
        "subscription_condition": f"fact(rtl_subscriptions, subscription({module}, 9, me, a(_), [{shell}], a(_), -inf, inf)).",
        "wrong_shape": "fact(rtl_slr, id_handle(user, v, x)).",
        "directive": f"(:- {shell}).",
        "added_rule": f"rules([rule(rx_1, [], [(ele_trigger(a(_), _, _) :- {shell})])], []).",
        # deeper than the reader's C stack in the bridge's thread (it crashed the process)
        "deep_term": "fact(rtl_slr, need(" + "f(" * 30_000 + "x" + ")" * 30_000 + ", 1)).",
        "deep_over_lines": "fact(rtl_slr, need(" + "f(\n" * 30_000 + "x" + ")" * 30_000 + ", 1)).",
        "two_terms_on_a_line": f"global(events, 1). clause(user, message_hook(_, _, _), {shell}).",
    }


def craft(path: Path, term: str) -> None:
    """Add `term` to the snapshot at `path` (before its trailer, whose count is made right; a
    `rules/2` term replaces the snapshot's)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[-1].startswith("end(")
    body = lines[1:-1]
    if term.startswith("rules("):
        body = [term if line.startswith("rules(") else line for line in body]
    else:
        body.append(term)
    path.write_text("\n".join([lines[0]] + body + [f"end({len(body)})."]) + "\n", encoding="utf-8")


@pytest.fixture(scope="module")
def engine_and_snapshot(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("crafted")
    engine = Engine.from_source(PROGRAM, "crafted.rtl")
    engine.feed_batch([("a(1)", 1), ("v(1)", 1.5)])
    genuine = tmp / "genuine.state"
    engine.save_state(genuine)
    return tmp, engine, genuine


@pytest.mark.parametrize("name", sorted(crafted_terms("m", Path("c"))))
def test_a_crafted_snapshot_is_refused_changes_nothing_and_runs_nothing(engine_and_snapshot, name):
    tmp, engine, genuine = engine_and_snapshot
    canary = tmp / f"canary-{name}"
    path = tmp / f"{name}.state"
    path.write_bytes(genuine.read_bytes())
    craft(path, crafted_terms(engine.module, canary)[name])
    engine.feed_batch([("a(2)", 2)])
    digest = engine.state_digest()
    with pytest.raises(StateError) as refused:
        engine.restore_state(path)
    assert "\n" not in str(refused.value) and str(path) in str(refused.value)
    assert engine.state_digest() == digest
    engine.feed_batch([("b(1)", 3), ("a(3)", 4), ("b(3)", 4.5)])     # what it would have hooked
    engine.bridge.call_text("print_message(informational, format(\"x\", [])), R = \"\"", "R")
    assert not canary.exists()
    engine.restore_state(genuine)                                   # the genuine one restores


def test_a_genuine_snapshot_is_text_read_as_data(engine_and_snapshot):
    _, engine, genuine = engine_and_snapshot
    lines = genuine.read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("rtl_state(2,") and lines[-1] == f"end({len(lines) - 2})."
    assert all(line.split("(", 1)[0] in {"modules", "rules", "trie", "fact", "global", "flag"}
               for line in lines[1:-1])


def _run(args, **kwargs):
    return subprocess.run([sys.executable, "-m", "retalisc", "run", *args], capture_output=True, timeout=300,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, **kwargs)


@pytest.mark.parametrize("name", ["ele_trigger_clause", "message_hook", "timer_goal"])
def test_run_state_refuses_a_crafted_snapshot_with_a_recomputed_checksum(tmp_path, name):
    program, events, out, state = (tmp_path / "p.rtl", tmp_path / "e.jsonl", tmp_path / "out.jsonl",
                                   tmp_path / "state")
    program.write_text(PROGRAM, encoding="utf-8")
    events.write_text("".join(json.dumps({"event": e, "t": t}) + "\n"
                              for e, t in [("a(1)", 1), ("b(1)", 2), ("a(2)", 3)]), encoding="utf-8")
    first = _run([str(program), "--events", str(events), "--out", str(out), "--state", str(state)])
    assert first.returncode == 0, first.stderr.decode()
    manifest_path = sorted(state.glob("snapshot-*.json"))[-1]
    manifest = json.loads(manifest_path.read_text())
    snapshot = manifest_path.with_suffix(".state")
    module = snapshot.read_text(encoding="utf-8").split("\n", 1)[0].rsplit(",", 1)[1].rstrip(").")
    canary = tmp_path / "canary"
    craft(snapshot, crafted_terms(module, canary)[name])
    manifest.update(sha256=hashlib.sha256(snapshot.read_bytes()).hexdigest(), state_bytes=snapshot.stat().st_size)
    manifest_path.write_text(json.dumps(manifest))
    before = out.read_bytes()
    again = _run([str(program), "--events", str(events), "--out", str(out), "--state", str(state)])
    message = again.stderr.decode()
    assert again.returncode == 2, message
    assert message.count("\n") == 1 and str(snapshot) in message and "refused" in message, message
    assert "Traceback" not in message
    assert out.read_bytes() == before and not canary.exists()


AQ_PROGRAM = "path(X, Y) :- edge(X, Y).\npath(X, Y) :- edge(X, Z), path(Z, Y).\nedge(1, 2).\nedge(2, 3).\n"


def aq_crafted_terms(canary: Path):
    shell = f'shell("touch {canary}")'
    return {
        "rule_code": f"clause(user, '$aq_go'(path(_, _), _, _), {shell}).",
        "final_condition": f"clause(user, '$aq_final'(path(A, B), C, s9(C, A, B), fact, edge(A, B), {shell}), true).",
        "fact_with_body": f"clause(user, edge(7, 8), {shell}).",
        "rule_record": f"fact(rtl_aq, aq_rule(99, (path(_, _) :- {shell}), [])).",
        "other_module": f"clause(lists, append(_, _, _), {shell}).",
    }


@pytest.mark.parametrize("name", sorted(aq_crafted_terms(Path("c"))))
def test_a_crafted_active_query_snapshot_is_refused_and_runs_nothing(tmp_path, name):
    from retalisc.driver.active_queries import ActiveQueries

    aq = ActiveQueries.from_source(AQ_PROGRAM)
    aq.register("q", "path(X, Y)")
    aq.add_rule("path(X, Y) :- edge(Y, X)")
    genuine, path, canary = tmp_path / "genuine.state", tmp_path / "crafted.state", tmp_path / "canary"
    aq.save_state(genuine)
    path.write_bytes(genuine.read_bytes())
    craft(path, aq_crafted_terms(canary)[name])
    aq.assert_fact("edge(3, 4)")
    digest = aq.state_digest()
    with pytest.raises(StateError):
        aq.restore_state(path)
    assert aq.state_digest() == digest
    aq.assert_fact("edge(4, 5)")
    aq.register("q2", "path(1, Y)")
    assert not canary.exists()
    aq.restore_state(genuine)
    assert "path(2,1)" in [answer.replace(" ", "") for answer in aq.answers("q")]


def test_run_state_whose_snapshots_are_all_changed_does_not_start_from_the_beginning(tmp_path):
    """Snapshots changed without their checksum made again are corrupt: one is passed over for
    the previous, but a directory with none left is refused (exit status 2) rather than run again
    from the first event, which would rewrite the output file."""
    program, events, out, state = (tmp_path / "p.rtl", tmp_path / "e.jsonl", tmp_path / "out.jsonl",
                                   tmp_path / "state")
    program.write_text(PROGRAM, encoding="utf-8")
    events.write_text("".join(json.dumps({"event": e, "t": t}) + "\n"
                              for e, t in [("a(1)", 1), ("b(1)", 2), ("a(2)", 3)]), encoding="utf-8")
    assert _run([str(program), "--events", str(events), "--out", str(out), "--state", str(state)]).returncode == 0
    for snapshot in state.glob("snapshot-*.state"):
        craft(snapshot, crafted_terms("m", tmp_path / "canary")["message_hook"])
    again = _run([str(program), "--events", str(events), "--out", str(out), "--state", str(state)])
    message = again.stderr.decode()
    assert again.returncode == 2, message
    assert "corrupt" in message and "none of its snapshots can be used" in message
    assert "Traceback" not in message


def test_guarded_goals_restore_and_a_crafted_unguarded_one_is_refused(tmp_path):
    """Conditions and rules from outside are kept in the form the untrusted-goal check leaves
    them (a catch-all catcher guarded by rtl_guard): a genuine snapshot of them restores into a
    new load and gives the same deliveries; the same snapshot with the guard taken off (a
    catch/3 that would catch the runtime's limits) is refused."""
    program = "c(X) <- a(X) seq b(X).\n"
    first = Engine.from_source(program, "guarded.rtl")
    first.subscribe("me", "a(X)", conditions_text="[catch(X > 0, _, fail)]")
    first.add_rules("g : d(X) <- a(X) where catch(X > 1, _, fail).")
    first.feed_batch([("a(1)", 1)])
    genuine = tmp_path / "guarded.state"
    first.save_state(genuine)
    guard = ":(rtl_guard,rtl_catch("
    assert genuine.read_text(encoding="utf-8").count(guard) >= 2   # the condition and the rule
    expected = [str(e) for e in first.feed_batch([("a(2)", 2), ("b(2)", 3)])]

    second = Engine.from_source(program, "guarded.rtl")
    second.restore_state(genuine)
    assert [str(e) for e in second.feed_batch([("a(2)", 2), ("b(2)", 3)])] == expected

    for kept in ("fact(rtl_subscriptions", "rules("):      # the condition; the rule's clauses
        unguarded = tmp_path / "unguarded.state"
        unguarded.write_text("".join(line.replace(guard, ":(system,catch(") if line.startswith(kept) else line
                                     for line in genuine.read_text(encoding="utf-8").splitlines(True)),
                             encoding="utf-8")
        third = Engine.from_source(program, "guarded.rtl")
        with pytest.raises(StateError):
            third.restore_state(unguarded)
