"""The `edbc` pass's operator families (retalisc/passes/edbc/), each on its own: the step
kinds `steps.family` gives to each, what each family's function alone adds to a rule's code
(handlers, stores and the clauses its runtime support calls), and what a program using it
detects on a small stream."""
from __future__ import annotations

from itertools import count

import pytest

from retalisc.compiler import compile_source
from retalisc.driver.engine import Engine
from retalisc.frontend.program import parse_program
from retalisc.passes import edbc
from retalisc.passes.edbc import (absence, aggregates, alarms, first, fnot, joins, negation, outputs, policies,
                                  sliding, steps)
from retalisc.passes.edbc.generator import RuleGenerator
from retalisc.passes.pipeline import EVENT_PIPELINE
from retalisc.passes.unit import Unit

_MODULES = count()

FEEDS_A_POLICY = "\nr9([property(consumption_policy, recent)]) 'rule:' q(X, N) <- h(X, N) seq d(X)."

#: family -> (program, its function, the step's handlers and helpers it defines, the roles of
#: the stores and records it makes, events, the h events detected)
FAMILIES = {
    "joins": ("h(X) <- a(X) seq b(X).", joins.join_clauses,
              {"e_r1_1_left", "e_r1_1_right", "e_r1_1_left_retract", "e_r1_1_right_retract"}, {"lefts", "rights"},
              [("b(1)", 1), ("a(1)", 2), ("b(1)", 3), ("b(2)", 4)], [("h(1)", 2, 3)]),
    "joins (or)": ("h(X) <- a(X) or b(X).", joins.forward_clauses,
                   {"e_r1_1_left", "e_r1_1_right", "e_r1_1_left_retract", "e_r1_1_right_retract"}, set(),
                   [("a(1)", 1), ("b(2)", 2)], [("h(1)", 1, 1), ("h(2)", 2, 2)]),
    "first": ("r1([property(consumption_policy, first)]) 'rule:' h(X, Y) <- a(X) seq b(X, Y).",
              first.first_join_clauses, {"e_r1_1_left", "e_r1_1_right"}, {"lefts", "rights", "first"},
              [("a(1)", 1), ("b(1, 1)", 2), ("b(1, 2)", 3)], [("h(1,1)", 1, 2)]),
    "policies (recent)": ("r1([property(consumption_policy, recent)]) 'rule:' h(X, Y) <- a(X, Y) seq b(X).",
                          joins.join_clauses, {"e_r1_1_left", "e_r1_1_left_at", "e_r1_1_right_at", "e_r1_1_policy"},
                          {"lefts", "rights", "matched", "dropped"},
                          [("a(1, 1)", 1), ("a(1, 2)", 2), ("b(1)", 3), ("b(1)", 4)],
                          [("h(1,2)", 2, 3), ("h(1,1)", 1, 4)]),
    "policies (chronological)": (
        "r1([property(consumption_policy, chronological)]) 'rule:' h(X, Y) <- a(X, Y) seq b(X).",
        joins.join_clauses, {"e_r1_1_left_at", "e_r1_1_policy"}, {"lefts", "rights", "matched"},
        [("a(1, 1)", 1), ("a(1, 2)", 2), ("b(1)", 3), ("b(1)", 4)], [("h(1,1)", 1, 3), ("h(1,2)", 2, 4)]),
    "negation": ("h(X) <- not(c(X)).[a(X), b(X)].", negation.negation_clauses,
                 {"e_r1_1_left", "e_r1_1_right", "e_r1_1_negated", "e_r1_1_negated_retract", "e_r1_1_blocked",
                  "ele_forget_blockers"}, {"lefts", "rights", "negs"},
                 [("a(1)", 1), ("a(2)", 2), ("c(1)", 3), ("b(1)", 4), ("b(2)", 5)], [("h(2)", 2, 5)]),
    "fnot": ("h(X) <- a(X) fnot c(X).", fnot.fnot_clauses,
             {"e_r1_1_left", "e_r1_1_negated", "e_r1_1_blocked"}, {"lefts", "negs"},
             [("c(1)", 1), ("a(1)", 2), ("a(2)", 3)], [("h(2)", 3, 3)]),
    "absence": ("h(X) <- not(c(X)).[a(X), 2].", absence.absence_clauses,
                {"e_r1_1_left", "e_r1_1_decide", "e_r1_1_negated", "e_r1_1_blocked", "e_r1_1_blocked_late"},
                {"decided", "negs"}, [("a(1)", 1), ("a(2)", 2), ("c(2)", 3), ("z", 10)], [("h(1)", 1, 3)]),
    "sliding": ("h(X, N) <- sliding(count, a(X), X, 5, N).", sliding.sliding_clauses,
                {"e_r1_1_left", "e_r1_1_refresh", "e_r1_1_show", "e_r1_1_unshow", "e_r1_1_matches"},
                {"slid", "changes"}, [("a(1)", 1), ("a(1)", 2), ("z", 20)],
                [("h(1,1)", 1, 1), ("h(1,2)", 2, 2), ("h(1,1)", 6, 6), ("h(1,0)", 7, 7)]),
    "sliding (numbered)": ("h(X, N) <- sliding(count, a(X), X, 5, N)." + FEEDS_A_POLICY,
                           sliding.numbered_sliding_clauses, {"e_r1_1_reach", "e_r1_1_reached_at", "e_r1_1_refresh"},
                           {"slid", "changes", "reached"}, [("a(1)", 1), ("d(1)", 2), ("z", 20)],
                           [("h(1,1)", 1, 1), ("h(1,0)", 6, 6)]),
    "aggregates": ("h(S) <- a(X) seq aggregate(sum(Y), b(X, Y), S).", aggregates.aggregate_clauses,
                   {"e_r1_1_left", "e_r1_1_right", "e_r1_1_redo", "e_r1_1_left_retract"}, {"lefts", "rights"},
                   [("a(1)", 1), ("b(1, 2)", 2), ("b(1, 3)", 3), ("b(2, 5)", 4)],
                   [("h(0)", 1, 1), ("h(2)", 1, 2), ("h(5)", 1, 3)]),
    "alarms": ("alarm(h(X), 2) <- a(X).", outputs.output_clauses, {"e_r1_1", "e_r1_1_retract", "e_r1_1_alarm"},
               {"alarms"}, [("a(1)", 1), ("z", 10)], [("h(1)", 1, 3)]),
    "outputs": ("h(X) <- a(X) where X > 1.", outputs.output_clauses, {"e_r1_1", "e_r1_1_retract"}, set(),
                [("a(1)", 1), ("a(2)", 2)], [("h(2)", 2, 2)]),
}


def _binarized(program: str):
    unit = Unit(parse_program(program, "families.rtl"), "rtl_prog_families")
    for compiler_pass in EVENT_PIPELINE:
        if compiler_pass is edbc:
            return unit
        unit = compiler_pass.run(unit)
    raise AssertionError("no edbc pass")


def _alone(program: str, function):
    """A generator for the program's first rule, after only `function` ran on its last step
    (with the preparation steps.generate does first)."""
    unit = _binarized(program)
    rule = unit.rules[0]
    policy = edbc.rule_policy(unit, rule)
    consumed = edbc.policy_inputs(unit.rules, [edbc.rule_policy(unit, r) for r in unit.rules])
    g = RuleGenerator(rule, policy, provenance=policy not in ("recent", "chronological")
                      and edbc.signature(rule.rule.head) in consumed)
    g.consumers = {}
    function(g, rule.steps[-1])
    return g


def _defined(g: RuleGenerator) -> set:
    heads = set()
    for clause_ in g.clauses + g.triggers:
        head = clause_.args[0] if getattr(clause_, "name", None) == ":-" and clause_.arity == 2 else clause_
        heads.add(head.name)
    return heads


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_a_family_alone_defines_its_handlers_and_stores(family):
    program, function, defined, roles, _events, _detected = FAMILIES[family]
    g = _alone(program, function)
    assert defined <= _defined(g), sorted(_defined(g))
    assert {role for _step, role in g.roles.values()} == roles


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_a_program_of_each_family_detects_what_it_means(family):
    program, _function, _defined_, _roles, events, detected = FAMILIES[family]
    engine = Engine.from_compiled(compile_source(program + "\n", f"families_{next(_MODULES)}.rtl"))
    engine.set_flag("max_delay", "1.0")
    produced, _ = engine.feed_lines("\n".join(f'{{"event": "{event}", "t": {t}}}' for event, t in events))
    produced += engine.end_of_input()
    assert [(o.event, o.start, o.end) for o in produced if o.op == "add" and o.event.startswith("h(")] == detected


@pytest.mark.parametrize("program, function", [
    ("h(X) <- a(X) seq b(X).", joins.join_clauses),
    ("h(X) <- a(X) during b(X).", joins.join_clauses),
    ("r1([property(consumption_policy, first)]) 'rule:' h(X) <- a(X) seq b(X).", joins.join_clauses),
    ("h(X) <- a(X) or b(X).", joins.forward_clauses),
    ("h(X) <- (a(X)).3.", joins.forward_clauses),
    ("h(X) <- not(c(X)).[a(X), b(X)].", negation.negation_clauses),
    ("h(X) <- (a(X) seq b(X)) cnot c(X).", negation.negation_clauses),
    ("h(X) <- a(X) fnot c(X).", fnot.fnot_clauses),
    ("h(X) <- not(c(X)).[a(X), 2].", absence.absence_clauses),
    ("h(S) <- a(X) seq aggregate(count, b(X), S).", aggregates.aggregate_clauses),
    ("h(X, N) <- sliding(count, a(X), X, 5, N).", sliding.sliding_clauses),
    ("h(X, N) <- sliding(count, a(X), X, 5, N)." + FEEDS_A_POLICY, sliding.numbered_sliding_clauses),
])
def test_each_step_goes_to_its_family(program, function):
    unit = _binarized(program)
    rule = unit.rules[0]
    g = RuleGenerator(rule, edbc.rule_policy(unit, rule),
                      provenance=edbc.signature(rule.rule.head) in edbc.policy_inputs(
                          unit.rules, [edbc.rule_policy(unit, r) for r in unit.rules]))
    assert steps.family(g, rule.steps[-1]) is function


def test_the_family_table_names_functions_of_the_family_modules():
    for op, function in steps.FAMILIES.items():
        assert function.__module__.startswith("retalisc.passes.edbc."), op
    assert alarms.alarm_head is edbc.alarm_head and policies.consuming_join.__module__.endswith("policies")
