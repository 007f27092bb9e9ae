"""Code from outside the program file passes the sandbox: rules added at
run time (Python, control lines, ins_event_rule), queries, subscription and memory
conditions. The program file itself is trusted."""
from __future__ import annotations

import glob
import json
import re
import subprocess
from pathlib import Path

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.bridge import PrologError
from retalisc.driver.engine import Engine, QueryError
from retalisc.frontend.program import parse_program

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = """
located(s1, kitchen).
located(s2, kitchen).
nearby(A, B) :- located(A, R), located(B, R).
cleanup(X) :- shell(X).
:- dynamic counter/1.
bump :- retract(counter(N)), N1 is N + 1, assertz(counter(N1)).
counter(0).
r1 : fire(S) <- smoke(S) seq heat(S).
"""


@pytest.fixture
def engine():
    e = Engine.from_source(PROGRAM, "sandbox.rtl")
    e.set_flag("max_delay", "inf")
    e.set_flag("echo_input", "false")
    return e


def snapshot(engine: Engine):
    """The program module's predicates and trigger clauses: what installing a rule changes."""
    m = engine.module
    preds = engine.bridge.all(f"current_predicate({m}:N/A)", "N/A")
    triggers = engine.bridge.once(f"aggregate_all(count, clause({m}:ele_trigger(_, _, _), _), N)", "N")
    return sorted(preds), triggers


UNSAFE_RULES = [
    ("null do shell('touch {m}') <- trig.", "unsafe goal: shell/1"),
    ("alarm <- trig where shell('touch {m}').", "unsafe goal: shell/1"),
    ("alarm(X) <- trig(X) where cleanup('touch {m}').", r"unsafe goal: shell/1 \(reached from .*cleanup/1\)"),
    ("null do (open('{m}', write, S), close(S)) <- trig.", "unsafe goal: open/3"),
    ("null do halt <- trig.", "unsafe goal: halt/0"),
    ("alarm <- trig where retractall(ele_trigger(_, _, _)).", "unsafe goal: retractall/1 changes .*ele_trigger/3"),
    ("null do assertz(located(s9, garage)) <- trig.", "unsafe goal: assertz/1 changes .*located/2"),
    ("null do bump <- trig.", "unsafe goal: retract/1 changes .*counter/1"),
    ("alarm(X) <- trig(X) where ele_trigger(smoke(X), 1, 1).", "unsafe goal: assertz/1 changes .*e_r1_1_lefts/3"),
    ("null do del_event_rule(r1) <- trig.", "unsafe goal: del_event_rule/1"),
    ("null do ins_event_rule(\"x <- y.\") <- trig.", "unsafe goal: ins_event_rule/1"),
    ("null do set_prolog_flag(double_quotes, atom) <- trig.", "unsafe goal: set_prolog_flag/2"),
    ("alarm(G) <- trig(G) where call(G).", "unsafe goal: call/1 with a goal that is only known when it runs"),
    ("null do format('~@', [shell('touch {m}')]) <- trig.", "unsafe goal: format/2 with the directive ~@"),
    ("null do c_mem(m, trig(_)-[shell('touch {m}')], 1, inf) <- trig.", "unsafe goal: shell/1"),
    ("null do sub(1, c, trig(X)-[shell('touch {m}')], X, 0) <- trig.", "unsafe goal: shell/1"),
    ("null do sub(1, c, Q, x, 0) <- trig(Q).", "only known when it runs"),       # conditions from data
    ("null do c_mem(m, Q, 1, inf) <- trig(Q).", "only known when it runs"),
    ("null do memorize(x(_), C, x, m, 1) <- trig(C).", "only known when it runs"),
    # runtime globals, the policy steps' replay position among them (compiled code reads it
    # through rtl_policy:rtl_position/2), are not for added rules to read
    ("alarm(X) <- trig where nb_getval(rtl_replay_position, X).", "unsafe goal: nb_getval/2"),
]


@pytest.mark.parametrize("rule, message", UNSAFE_RULES)
def test_an_unsafe_added_rule_is_refused_and_nothing_of_it_is_installed(engine, tmp_path, rule, message):
    marker = tmp_path / "hacked"
    before = snapshot(engine)
    with pytest.raises(PrologError, match=message):
        engine.add_rules(rule.format(m=marker))
    assert snapshot(engine) == before
    out = engine.feed_batch([("trig", 1), ("trig(x)", 2), ("smoke(s1)", 3), ("heat(s1)", 4)])
    assert [o.event for o in out] == ["fire(s1)"]           # the program's rule r1 still works
    assert not marker.exists()


def test_one_unsafe_rule_refuses_the_whole_text(engine, tmp_path):
    marker = tmp_path / "hacked"
    before = snapshot(engine)
    with pytest.raises(PrologError, match="unsafe goal: shell/1"):
        engine.add_rules(f"ok1 : good(X) <- trig(X).\nbad1 : null do shell('touch {marker}') <- trig(_).")
    assert snapshot(engine) == before
    assert engine.add_rules("ok1 : good(X) <- trig(X).") == ["ok1"]       # the label is still free
    assert [o.event for o in engine.feed("trig(1)", 1)] == ["good(1)"]


@pytest.mark.parametrize("clauses, message", [
    ("'$rtl_rule'(zz, [store(counter, 1, none)]).\n", "not a store of the rule's own"),
    ("'$rtl_rule'(zz, []).\nlocated(s9, garage).\n", "may only define its triggers and its own predicates, not located/2"),
    ("'$rtl_rule'(zz, []).\n:- shell('touch {m}').\n", "a directive"),
    ("'$rtl_rule'(zz, []).\nele_trigger(go, _, _) :- shell('touch {m}').\n", "unsafe goal: shell/1"),
    ("'$rtl_rule'(zz, [store(e_zz_1_lefts, 1, none)]).\n"
     "ele_trigger(go, _, _) :- rtl_policy:rtl_policy_delete(e_r1_1, left, [], e_zz_1_lefts(_)).\n",
     "the step e_r1_1 is not one of the added rule's own"),
])
def test_compiled_rule_text_is_checked_whatever_its_source(engine, tmp_path, clauses, message):
    """rtl_install_rules/3 checks the clauses themselves, not only what the compiler makes."""
    marker = tmp_path / "hacked"
    before = snapshot(engine)
    with pytest.raises(PrologError, match=message):
        engine.bridge.apply("rtl_api", "rtl_api_install_rules", engine.module, clauses.format(m=marker))
    assert snapshot(engine) == before
    engine.feed("go", 1)
    assert not marker.exists()


SAFE_RULES = [
    "near(A, B) <- smoke(A) and heat(B) where nearby(A, B).",
    "null do (write(hello), nl) <- trig.",
    "loud(X) <- trig(X) where (format(atom(T), '~w!', [X]), atom_length(T, N), N > 1).",
    "count(N) <- trig(_) where aggregate_all(count, located(_, _), N).",
    "null do new_event(echoed(X)) <- trig(X).",
    "span(X, D) <- (trig(X)^T1 seq heat(X)^T2) where D is T2 - T1.",
    "kitchen(X) <- trig(X) where forall(member(Y, [X]), located(Y, kitchen)).",
    "m(L) <- trig(X) where findall(Y, nearby(X, Y), L).",
]


@pytest.mark.parametrize("rule", SAFE_RULES)
def test_safe_added_rules_are_accepted(engine, rule):
    assert len(engine.add_rules(rule)) == 1


def test_every_rule_of_the_examples_passes_when_added_at_run_time():
    """Each event rule of the golden programs and examples, added again (under a new label)
    to its own running program, passes the check: the sandbox refuses no real rule."""
    checked = 0
    for path in sorted(glob.glob(str(ROOT / "tests/golden*/*/program.rtl")) + glob.glob(str(ROOT / "examples/*/*.rtl"))):
        text = Path(path).read_text(encoding="utf-8")
        engine = Engine.from_source(text, path)
        rules = []
        for rule in parse_program(text, path).event_rules:
            source = rule.source.strip()
            if re.search(r"\b(ins|del)_(event|static)_rule\(", source):
                continue        # a rule added at run time may not change the rules (refused on purpose)
            if rule.label:      # a fresh label, the rest (properties, operators) as written
                source = re.sub(r"^\s*" + re.escape(rule.label), "again_" + rule.label, source, count=1)
            rules.append(source)
        if rules:
            engine.add_rules("\n".join(rules))
            checked += len(rules)
    assert checked >= 60


def test_a_rule_added_under_a_policy_reads_its_position_through_the_runtime():
    """A step under a consumption policy asks rtl_position/2 for the position of each
    instance; the code compiled for an added rule reads no runtime global, and passes."""
    policy = ":- set_etalis_flag(event_consumption_policy, recent).\nr1 : ab(X, Y) <- a(X) seq b(Y).\n"
    added = "r2([property(consumption_policy, recent)]) 'rule:' ba(X, Y) <- b(X) seq a(Y)."
    prolog = compile_source(policy + added + "\n", "policy.rtl").prolog
    assert "rtl_position(" in prolog and "nb_getval" not in prolog
    engine = Engine.from_source(policy, "policy.rtl")
    assert engine.add_rules(added) == ["r2"]
    events = [("a(1)", 1), ("b(2)", 2), ("a(3)", 3), ("a(4)", 4), ("b(5)", 5), ("b(6)", 6), ("a(7)", 7)]
    out = [o.event for o in engine.feed_batch(events)]
    written = Engine.from_source(policy + added + "\n", "written.rtl")      # the oracle: the rule in the file
    assert out == [o.event for o in written.feed_batch(events)]
    assert "ab(1,2)" in out and any(e.startswith("ba(") for e in out)


def test_control_lines_reach_the_same_check(engine, tmp_path):
    marker = tmp_path / "hacked"
    control = json.dumps({"op": "add_rule", "rule": f"null do shell('touch {marker}') <- trig."})
    out, rejected = engine.feed_lines(control + '\n{"event": "trig", "t": 1}\n')
    assert out == []
    assert len(rejected) == 1 and rejected[0].line == 1
    assert "unsafe goal: shell/1" in rejected[0].reason or "control lines are disabled" in rejected[0].reason
    assert not marker.exists()


def test_standalone_swipl_ins_event_rule_is_checked(tmp_path, swipl):
    """A trusted program that adds rule text it receives in an event: the text is checked."""
    marker = tmp_path / "hacked"
    program = tmp_path / "p.pl"
    program.write_text(compile_source("null do ins_event_rule(R) <- install(R).\n", "p.rtl").prolog)
    events = tmp_path / "e.jsonl"
    rule = f"null do shell('touch {marker}') <- trig."
    events.write_text(json.dumps({"event": f"install({json.dumps(rule)})", "t": 1}) + "\n"
                      + '{"event": "trig", "t": 2}\n', encoding="utf-8")
    run = subprocess.run([swipl, str(program), str(events)], capture_output=True, text=True, timeout=120)
    assert "unsafe goal: shell/1" in run.stderr
    assert not marker.exists()


def test_the_program_file_itself_is_trusted(tmp_path):
    marker = tmp_path / "trusted"
    engine = Engine.from_source(f"null do shell('touch {marker}') <- go.\n", "trusted.rtl")
    engine.feed("go", 1)
    assert marker.exists()


# ---- queries, subscriptions, memories -----------------------------------------------------

@pytest.mark.parametrize("goal, message", [
    ("shell('touch {m}')", "unsafe goal: shell/1"),
    ("cleanup('touch {m}')", r"unsafe goal: shell/1 \(reached from cleanup/1\)"),
    ("{module}:retractall(ele_trigger(_, _, _))", "retractall/1 changes .*ele_trigger/3"),
    ("system:retractall({module}:located(_, _))", "retractall/1 changes .*located/2"),
    ("bump", "retract/1 changes .*counter/1"),
    ("ele_trigger(smoke(s1), 1, 1)", "unsafe goal: (assertz/1|rtl_derived/3|rtl_detected/1)"),
    ("rtl_clear", "unsafe goal: rtl_clear/0"),
    ("new_event(x)", "unsafe goal: new_event/1"),
    ("set_prolog_flag(occurs_check, error)", "unsafe goal: set_prolog_flag/2"),
    ("abort", "unsafe goal: abort/0"),
    ("G = shell('touch {m}'), call(G)", "only known when it runs"),
    ("system:'$set_source_module'(_)", "not exported by its module"),
    ("sandbox:verify_safe_declaration(x)", "not exported by its module"),
])
def test_queries_that_would_change_or_escape_the_program_are_refused(engine, tmp_path, goal, message):
    marker = tmp_path / "hacked"
    before = snapshot(engine)
    with pytest.raises(QueryError, match=message) as refused:
        engine.query(goal.format(m=marker, module=engine.module))
    assert refused.value.kind == "unsafe"
    assert snapshot(engine) == before
    assert engine.query("located(s1, R)") == {"R": "kitchen"}
    assert [o.event for o in engine.feed_batch([("smoke(s1)", 1), ("heat(s1)", 2)])] == ["fire(s1)"]
    assert not marker.exists()


def test_safe_queries_still_run(engine):
    assert engine.query_all("nearby(s1, X)") == [{"X": "s1"}, {"X": "s2"}]
    assert engine.query("findall(X, located(X, kitchen), L), length(L, N)")["N"] == "2"
    assert engine.query("aggregate_all(count, located(_, _), N)") == {"N": "2"}
    assert engine.query("assertz(scratch(1)), retract(scratch(1))") == {}      # the query's own module
    assert engine.query("retract(counter(_))") is None          # unqualified: only its own module
    assert engine.query("counter(N)") == {"N": "0"}


def test_subscription_conditions_are_checked(engine, tmp_path):
    marker = tmp_path / "hacked"
    with pytest.raises(PrologError, match="unsafe goal: shell/1"):
        engine.subscribe("ops", "smoke(X)", conditions_text=f"[cleanup('touch {marker}')]")
    with pytest.raises(PrologError, match="unsafe goal: shell/1"):
        engine.subscribe_query("ops", f"smoke(X)-[shell('touch {marker}')]")
    out = engine.feed("smoke(s1)", 1)
    assert [o for o in out if o.consumer] == []                    # nothing was registered
    engine.subscribe("ops", "smoke(X)", conditions_text="[nearby(X, s2)]")
    assert [o.event for o in engine.feed("smoke(s1)", 2) if o.consumer] == ["smoke(s1)"]
    assert not marker.exists()


def test_memory_conditions_are_checked(engine, tmp_path):
    marker = tmp_path / "hacked"
    for request in (f"c_mem(m, smoke(_)-[shell('touch {marker}')], 5, inf)",
                    f"c_mem(m, smoke(_)-shell('touch {marker}'), 5, inf)",
                    "memorize(smoke(X), [cleanup(X)], X, m, 5)"):
        with pytest.raises(QueryError) as refused:
            engine.memory(request)
        assert refused.value.kind == "unsafe"
    assert engine.query("exist_mem(m)") is None
    engine.feed("smoke(s1)", 1)
    assert not marker.exists()
