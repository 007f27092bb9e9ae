"""Each pass on its own: what it changes in the compilation unit."""
import pytest

import ast
from pathlib import Path

from retalisc.backends.prolog.dump import dump_binary_rule
from retalisc.compiler import AQ_MODES, AqOptions, compile_source, pass_names
from retalisc.frontend.errors import RetalisSemanticError
from retalisc.frontend.program import Binary, Where, Window, parse_program, pattern_text
from retalisc.frontend.writer import write_term
from retalisc.passes import apply_rule_windows, binarize, collect_settings, edbc, push_conditions, validate
from retalisc.passes.pipeline import (ACTIVE_QUERY_PIPELINE, EVENT_PIPELINE, active_query_passes,
                                      run_pipeline)
from retalisc.passes.unit import Unit


def unit_of(text):
    return Unit(parse_program(text, "t.rtl"), "rtl_prog_t")


def through(text, last):
    unit = unit_of(text)
    for compiler_pass in EVENT_PIPELINE:
        unit = compiler_pass.run(unit)
        if compiler_pass is last:
            return unit
    raise AssertionError(last)


# ---- validate ------------------------------------------------------------------------------

@pytest.mark.parametrize("text, message", [
    ("h(X, Y) <- a(X).", "variable Y of the rule head does not occur in the pattern"),
    ("h(X) <- a(X) where b(X).\nb(1) <- c.", "b/1 is an event predicate"),
    ("h(X) <- a(X).\nh(1).", "h/1 is derived by event rules"),
    ("h(X) <- a(X).\ng(X) <- h(X, Y).", "wrong arity: h/2 is used here, but the rules derive h/1"),
    ("memorize(a, [], a, m).", "wrong arity: memorize/4"),
])
def test_validate_rejects(text, message):
    with pytest.raises(RetalisSemanticError) as info:
        validate.run(unit_of(text))
    assert message in info.value.message
    assert info.value.span.file == "t.rtl"


def test_validate_accepts_head_variables_bound_by_conditions():
    validate.run(unit_of("h(L) <- a(X) where pos(X, L).\npos(X, X)."))


# ---- collect_settings and apply_rule_windows ----------------------------------------------

def test_settings_from_directives_and_facts():
    unit = through(":- set_etalis_flag(event_consumption_policy, recent).\nprint_trigger(h/1).\n"
                   "event_rule_property(r1, event_rule_window, 4).\nr1 : h(X) <- a(X) seq b(X).",
                   collect_settings)
    assert unit.settings.consumption_policy == "recent"
    assert unit.settings.printed == [("functor", "h", 1)]
    assert unit.settings.rule_properties["r1"]["event_rule_window"].value == 4


def test_unknown_etalis_flag_is_a_warning():
    unit = through(":- set_etalis_flag(garbage_control, general).\nh <- a.", collect_settings)
    assert "garbage_control" in unit.warnings[0]


def test_rule_window_property_wraps_the_pattern():
    unit = through("r([property(event_rule_window, 3)]) 'rule:' h(X) <- a(X) seq b(X).", apply_rule_windows)
    pattern = unit.program.event_rules[0].pattern
    assert isinstance(pattern, Window) and pattern.length == 3


# ---- push_conditions ------------------------------------------------------------------------

def test_single_event_conditions_move_onto_the_event():
    unit = through("h(I) <- a(I, X) seq b(I, Y) where (Y < 5, X < Y, p(X)).\np(_).", push_conditions)
    assert pattern_text(unit.program.event_rules[0].pattern) == \
        "(((a(I, X) where p(X)) seq (b(I, Y) where Y < 5)) where X < Y)"


def test_conditions_stay_put_across_or_and_for_unknown_predicates():
    unit = through("h(X) <- (a(X) or b(X)) where X > 1.\ng(X) <- a(X) seq b(X) where q(X).", push_conditions)
    first, second = unit.program.event_rules
    assert isinstance(first.pattern, Where) and isinstance(first.pattern.pattern, Binary)
    assert isinstance(second.pattern, Where)


# ---- binarize -------------------------------------------------------------------------------

def test_binarize_three_way_sequence():
    unit = through("out(I, X, Y, Z) <- (a(I, X) seq b(I, Y) seq c(I, Z)).10.", binarize)
    rule = unit.rules[0]
    assert [s.name for s in rule.steps] == ["e_r1_1", "e_r1_2"]
    first, last = rule.steps
    assert write_term(first.output) == "e_r1_1(I, X, Y)"
    assert first.window == 10 and last.window == 10
    assert last.left.step is first and last.derives_head
    assert dump_binary_rule(rule).splitlines()[1] == "e_r1_1(I, X, Y) <- a(I, X) seq b(I, Y) within 10"


def test_binarize_single_event_rule_gets_a_pass_step():
    unit = through("h(X) <- a(X) where X > 1.", binarize)
    step = unit.rules[0].steps[0]
    assert step.op == "pass" and step.derives_head and step.left.filters


def test_labels_name_rules():
    unit = through("fire 'rule:' h <- a seq b.\nh2 <- a.", binarize)
    assert [r.rule_id for r in unit.rules] == ["fire", "r2"]


# ---- edbc -------------------------------------------------------------------------------------

def test_edbc_stores_are_keyed_by_join_variables():
    unit = through("out(I, X, Y) <- (a(I, X) seq b(I, Y)).5.", edbc)
    generated = unit.generated[0]
    assert ("e_r1_1_lefts", 4, 5) in generated.stores and ("e_r1_1_rights", 4, 5) in generated.stores
    texts = [write_term(c) for c in generated.clauses]
    left = next(t for t in texts if t.startswith("e_r1_1_left("))
    assert "e_r1_1_rights(I, Y, RStart, REnd)" in left and "LEnd < RStart" in left
    assert "assertz(e_r1_1_lefts(I, X, LStart, LEnd))" in left
    right = next(t for t in texts if t.startswith("e_r1_1_right("))
    assert "assertz(e_r1_1_rights(I, Y, RStart, REnd))" in right
    undo = next(t for t in texts if t.startswith("e_r1_1_left_retract("))
    assert "retract(e_r1_1_lefts(I, X, LStart, LEnd))" in undo and "e_r1_1_retract(I, X, Y, LStart, REnd)" in undo


def test_edbc_time_variables_do_not_capture_user_variables():
    unit = through("h(Start, End) <- a(Start) and b(End).", edbc)
    texts = " ".join(write_term(c) for c in unit.generated[0].clauses)
    assert "Start_" in texts and "End_" in texts


def test_edbc_numbers_the_arrivals_of_rules_without_a_policy_that_feed_a_policy_rule():
    """Only a rule whose results a policy rule takes: its stores carry the arrival numbers of
    their instances, and its results the numbers of the pair they were made from."""
    feeding = "u(I) <- a(I, _) seq b(I, _).\n"
    consumer = "p([property(consumption_policy, recent)]) 'rule:' p(I, Y) <- u(I) seq c(I, Y).\n"
    unit = through(feeding + consumer, edbc)
    texts = [write_term(c) for c in unit.generated[0].triggers + unit.generated[0].clauses]
    assert "ele_trigger(a(I, Any1), LStart, LEnd) :- rtl_policy_arrival(LArrivals), " \
           "e_r1_1_left(I, Any1, LArrivals, LStart, LEnd)" in texts
    left = next(t for t in texts if t.startswith("e_r1_1_left("))
    assert "e_r1_1(I, Any1, Any2, LStart, REnd, LArrivals - RArrivals)" in left
    assert "assertz(e_r1_1_lefts(I, Any1, LArrivals, LStart, LEnd))" in left
    undo = next(t for t in texts if t.startswith("e_r1_1_left_retract("))
    assert undo.startswith("e_r1_1_left_retract(I, Any1, LArrivals, LStart, LEnd) :- "
                           "rtl_policy_take_arrival([e_r1_1_lefts(I, Any1, LArrivals, LStart, LEnd)], none) -> ")
    # the same rule feeding no policy rule, and the policy rule itself, number nothing
    for unit_ in (through(feeding, edbc), unit):
        generated = unit_.generated[-1]
        assert not any("rtl_policy_arrival" in write_term(c) for c in generated.triggers + generated.clauses)

def test_edbc_numbers_the_changes_of_a_sliding_aggregate_only_when_a_policy_step_takes_them():
    """A sliding aggregate feeding a policy rule, or inside one, stores its matches with their
    arrival numbers and gives its changes at a position (rtl_sliding_refresh_numbered/10);
    feeding no policy step, it keeps the plain refresh."""
    sliding = "s(R, N) <- sliding(count, a(R, _), R, 5, N).\n"
    consumer = "p([property(consumption_policy, recent)]) 'rule:' p(R, N, Y) <- s(R, N) seq c(R, Y).\n"
    inside = ("q([property(consumption_policy, chronological)]) 'rule:' "
              "q(R, N, Y) <- sliding(count, a(R, _), R, 5, N) seq c(R, Y).\n")

    def texts(unit, index):
        generated = unit.generated[index]
        return [write_term(c) for c in generated.triggers + generated.clauses]

    for unit, index in ((through(sliding + consumer, edbc), 0), (through(inside, edbc), 0)):
        numbered = texts(unit, index)
        assert any("rtl_sliding_refresh_numbered(count, 5, " in t for t in numbered)
        assert any("_show(R, N, T, At) :- assertz(" in t and "rtl_policy_at(At, " in t for t in numbered)
        assert not any("rtl_sliding_refresh(count" in t for t in numbered)
    plain = texts(through(sliding, edbc), 0)
    assert any("rtl_sliding_refresh(count, 5, " in t for t in plain)
    assert not any("numbered" in t or "rtl_policy" in t for t in plain)


def test_pipeline_dump_after_every_pass():
    for compiler_pass in EVENT_PIPELINE:
        dumps = []
        compile_source("h(X) <- a(X) seq b(X) where X > 1.", "t.rtl", dump_after=compiler_pass.name,
                       dump=dumps.append)
        assert len(dumps) == 1 and dumps[0].startswith(f"% retalisc: the program after pass '{compiler_pass.name}'")


def test_run_pipeline_shows_the_unit_after_each_pass():
    seen = []
    run_pipeline(unit_of("h(X) <- a(X)."), EVENT_PIPELINE, lambda name, unit: seen.append(name))
    assert seen == [p.name for p in EVENT_PIPELINE] == pass_names()


# ---- the active-query pipeline ----------------------------------------------------------------

PATH = "edge(1, 2).\npath(X, Y) :- edge(X, Y).\npath(X, Y) :- edge(X, Z), path(Z, Y), X < Y.\n"


def test_active_query_pipeline_pass_names():
    common = ["aq_normalise", "aq_program", "aq_join_order"]
    assert [p.name for p in ACTIVE_QUERY_PIPELINE] == common + ["aq_naive", "aq_optimized", "aq_tabled"]
    assert AQ_MODES == ["naive", "optimized", "tabled"]
    for mode in AQ_MODES:
        assert [p.name for p in active_query_passes(mode)] == common + [f"aq_{mode}"]
        assert pass_names(AqOptions(mode)) == common + [f"aq_{mode}"]
    with pytest.raises(ValueError):
        active_query_passes("eager")


def test_aq_program_marks_literal_kinds_and_the_transformation_its_mode():
    result = compile_source(PATH, "path.pl", active_queries=AqOptions("optimized"))
    rule = result.unit.program.rules[1]
    assert [lit.kind for lit in rule.body] == ["fact", "call", "builtin"]
    assert result.unit.program.mode == "optimized" and "aq_configure([mode(optimized)" in result.prolog
    naive = compile_source(PATH, "path.pl", active_queries=AqOptions("naive")).unit.program
    assert [lit.kind for lit in naive.rules[1].body] == ["call", "call", "builtin"]
    assert naive.rules[-1].synthetic


@pytest.mark.parametrize("mode", AQ_MODES)
def test_dump_after_an_active_query_pass(mode):
    for name in pass_names(AqOptions(mode)):
        dumps = []
        compile_source(PATH, "path.pl", dump_after=name, dump=dumps.append, active_queries=AqOptions(mode))
        assert len(dumps) == 1 and dumps[0].startswith(f"% retalisc: the program after pass '{name}'")
        # aq_normalise runs before aq_program marks the kinds
        assert f"    path(Z, Y),  % {'?' if name == 'aq_normalise' else 'call'}" in dumps[0]
    with pytest.raises(ValueError, match="does not run"):
        compile_source(PATH, "path.pl", dump_after="edbc", active_queries=AqOptions(mode))


def test_aq_program_rejects_what_is_not_definite():
    # (stratified negation is accepted: tests/test_aq_negation.py)
    with pytest.raises(RetalisSemanticError) as info:
        compile_source("q(1).\np(X) :- q(X), !.\n", "cut.pl", active_queries=AqOptions())
    assert "cut" in info.value.message and (info.value.span.line, info.value.span.column) == (2, 15)


# ---- passes only transform dataclasses ----------------------------------------------------------

PASSES_DIR = Path(__file__).resolve().parent.parent / "retalisc" / "passes"
PARSER_NAMES = {"parse_program", "build_program", "read_program", "read_term", "read_definite_program"}


@pytest.mark.parametrize("path", sorted(PASSES_DIR.rglob("*.py")), ids=lambda p: str(p.relative_to(PASSES_DIR)))
def test_passes_neither_render_nor_parse(path):
    """A pass imports nothing from the backends and never calls the parser: the frontend reads
    text, the backend writes it."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            module = node.module or ""
            assert "backends" not in module and not module.endswith("parser"), f"{path.name}: from {module} import"
            assert not PARSER_NAMES & {alias.name for alias in node.names}, f"{path.name}: imports a parser"
        elif isinstance(node, ast.Import):
            assert not any("backends" in a.name or a.name.endswith("parser") for a in node.names), path.name
        elif isinstance(node, (ast.Name, ast.Attribute)):
            name = node.id if isinstance(node, ast.Name) else node.attr
            assert name not in PARSER_NAMES, f"{path.name}:{node.lineno}: uses {name}"


def test_every_pass_has_a_name_and_run():
    for compiler_pass in EVENT_PIPELINE + ACTIVE_QUERY_PIPELINE:
        assert isinstance(compiler_pass.name, str) and callable(compiler_pass.run)


def test_unsupported_operator_reports_its_place():
    with pytest.raises(RetalisSemanticError) as info:
        through("h <- a.\nh2(N) <- aggregate(count, x, N).", binarize)
    assert info.value.span.line == 2
