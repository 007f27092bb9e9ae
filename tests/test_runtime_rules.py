"""Event rules added and removed while events flow (ETALIS ins_event_rule/del_event_rule)."""
import json
import subprocess

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.bridge import PrologError
from retalisc.driver.engine import Engine
from retalisc.frontend.errors import RetalisError
from retalisc.runtime_rules import compile_rules

BASE = "r1 : base(X) <- (a(X) and b(X)).10.\n"


def load(source):
    engine = Engine.from_source(source)
    engine.set_flag("echo_input", "false")
    return engine


def derived(output):
    return [(o.event, o.start, o.end) for o in output if o.consumer is None]


def store_preds(engine, prefix):
    return engine.bridge.all(f"current_predicate({engine.module}:N/A), sub_atom(N, 0, _, _, '{prefix}')", "N/A")


def test_a_rule_added_mid_stream_only_sees_later_events():
    engine = load(BASE)
    engine.feed_batch([("a(1)", 1), ("b(1)", 2), ("a(2)", 3)])
    assert engine.add_rules("late : pair(X) <- a(X) seq b(X).") == ["late"]
    out = engine.feed_batch([("b(2)", 4), ("a(3)", 5), ("b(3)", 6)])
    # a(2) came before the rule: no pair(2); the program's own rule still sees everything
    assert derived(out) == [("base(2)", 3, 4), ("base(3)", 5, 6), ("pair(3)", 5, 6)]


def test_a_removed_rule_derives_nothing_and_its_stores_are_gone():
    engine = load(BASE)
    engine.add_rules("late : pair(X) <- (a(X) seq b(X)).100.")
    engine.feed_batch([("a(1)", 1), ("a(2)", 2)])
    size_with_rule = engine.store_size()
    engine.remove_rule("late")
    assert engine.store_size() == size_with_rule - 2           # the two stored a's of `late`
    assert store_preds(engine, "e_late_") == []
    assert engine.bridge.all(f"{engine.module}:ele_partial_store(N, _), sub_atom(N, 0, _, _, e_late_)", "N") == []
    out = engine.feed_batch([("b(1)", 3), ("a(4)", 4), ("b(4)", 5)])
    assert derived(out) == [("base(1)", 1, 3), ("base(4)", 4, 5)]


def test_a_program_rule_can_be_removed_too():
    engine = load(BASE + "r2 : other(X) <- c(X).\n")
    engine.remove_rule("r1")
    out = engine.feed_batch([("a(1)", 1), ("b(1)", 2), ("c(1)", 3)])
    assert derived(out) == [("other(1)", 3, 3)]
    assert engine.store_size() == 0


def test_unlabelled_rules_get_fresh_ids_and_labels_must_be_free():
    engine = load(BASE)
    first = engine.add_rules("x1(X) <- a(X).\nx2(X) <- b(X).")
    second = engine.add_rules("x3(X) <- a(X).")
    assert len(set(first + second)) == 3
    with pytest.raises(PrologError, match="r1"):
        engine.add_rules("r1 : clash(X) <- a(X).")                 # the program's own rule r1
    engine.add_rules("mine : m(X) <- a(X).")
    with pytest.raises(PrologError, match="mine"):
        engine.add_rules("mine : m2(X) <- b(X).")
    out = engine.feed_batch([("a(7)", 1)])
    assert sorted(e for e, _, _ in derived(out)) == ["m(7)", "x1(7)", "x3(7)"]   # no clash(7), no m2


def test_an_added_windowed_rule_is_garbage_collected():
    engine = load("never <- zzz.\n")                              # no windowed store in the program
    engine.set_flag("max_delay", "1.0")                             # flags are per process
    engine.add_rules("w : p(X) <- (a(X) seq b(X)).1.")
    engine.feed_batch([(f"a({i})", float(i)) for i in range(200)])
    assert engine.store_size() < 20                                 # (window + max_delay) worth of a's


def test_rules_that_do_not_compile_raise_with_a_location():
    engine = load(BASE)
    with pytest.raises(RetalisError, match="does not occur in the pattern"):
        engine.add_rules("bad(Y) <- a(X).")
    with pytest.raises(RetalisError, match="only event rules"):
        engine.add_rules("static_fact(1).")
    with pytest.raises(PrologError, match="does not exist"):
        engine.remove_rule("no_such_rule")


def test_compile_rules_output_names_the_rules_and_their_stores():
    result = compile_rules("k : p(X) <- (a(X) seq b(X)).2.\nq(X) <- c(X).", "m", "rt5")
    assert result.rule_ids == ["k", "rt5_1"]
    assert ("'$rtl_rule'(k, [store(e_k_1_lefts, 3, 2), store(e_k_1_rights, 3, 2), "
            "kept(e_k_1_lefts, 3, e_k_1_lefts_kept_a, e_k_1_lefts_kept_b, oldest_first), "
            "kept(e_k_1_rights, 3, e_k_1_rights_kept_a, e_k_1_rights_kept_b, oldest_first)])."
            in result.text)
    assert "'$rtl_rule'(rt5_1, [])." in result.text


def test_compile_rules_cli(retalisc_cmd):
    run = subprocess.run(retalisc_cmd + ["compile-rules", "--module", "m", "--rule-prefix", "rt9"],
                         input="p(X) <- a(X).\n", capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "'$rtl_rule'(rt9_1, [])." in run.stdout and "ele_trigger(a(X)" in run.stdout
    bad = subprocess.run(retalisc_cmd + ["compile-rules", "--module", "m"], input="p(Y) <- a(X).\n",
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "<rules>:1:" in bad.stderr


def test_standalone_ins_event_rule_and_del_event_rule(tmp_path, swipl):
    source = """
        null do ins_event_rule("late : pair(X) <- a(X) seq b(X)") <- start.
        null do ins_event_rule(\"\"\"(both(X) <- (a(X) and b(X)).5)\"\"\") <- start2.
        null do del_event_rule(late) <- stop.
        null do ins_event_rule("broken(Y) <- a(X)") <- bad.
    """.replace('\"\"\"', '"')
    program = tmp_path / "p.pl"
    program.write_text(compile_source(source, "p.rtl").prolog)
    lines = [("a(1)", 1), ("start", 2), ("b(1)", 3), ("a(2)", 4), ("b(2)", 5), ("start2", 6), ("a(3)", 7),
             ("b(3)", 8), ("stop", 9), ("a(4)", 10), ("b(4)", 11), ("bad", 12), ("a(5)", 13)]
    events = tmp_path / "events.jsonl"
    events.write_text("".join(json.dumps({"event": e, "t": t}) + "\n" for e, t in lines))
    run = subprocess.run([swipl, str(program), str(events)], capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert [(d["event"], d["start"], d["end"]) for d in map(json.loads, run.stdout.splitlines())] == [
        ("pair(2)", 4, 5), ("pair(3)", 7, 8), ("both(3)", 7, 8), ("both(4)", 10, 11)]
    assert "does not occur in the pattern" in run.stderr                  # the bad rule's message
