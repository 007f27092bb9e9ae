"""Unit tests of the SLR passes: slr_time_terms and slr_stream_histories."""
from retalisc.frontend.program import Declaration, EventRule, StaticClause, parse_program
from retalisc.frontend.writer import write_term
from retalisc.passes import slr_stream_histories, slr_time_terms
from retalisc.passes.unit import Unit


def _unit(text: str) -> Unit:
    return Unit(parse_program(text, "t.rtl"), "m")


def _static_texts(unit: Unit):
    return [write_term(c.term, 1200) for c in unit.program.clauses if isinstance(c, StaticClause)]


def test_time_terms_in_heads_and_goals_become_the_last_two_arguments():
    unit = slr_time_terms.run(_unit(
        "color(O, C)^T :- prev(obj(O, C)^Z, T).\n"
        "seen(O)^[T1, T2] :- \\+ hidden(O)^T1, findall(X, at(X)^T2, _).\n"
        "plain(X) :- X > 1.\n"))
    assert _static_texts(unit) == [
        "color(O, C, T, T) :- prev(obj(O, C) ^ Z, T)",
        "seen(O, T1, T2) :- \\+ hidden(O, T1, T1), findall(X, at(X, T2, T2), _)",
        "plain(X) :- X > 1",
    ]


def test_time_terms_in_where_conditions_and_actions():
    unit = slr_time_terms.run(_unit("r(L) do note(L)^T <- seg(O)^T where tf(cam, L)^T.\n"))
    rule = next(c for c in unit.program.clauses if isinstance(c, EventRule))
    assert write_term(rule.pattern.condition, 999) == "tf(cam, L, T, T)"
    assert write_term(rule.action, 999) == "note(L, T, T)"
    assert rule.pattern.pattern.start is not None    # the event atom's own E^T stays a time binder


def test_stream_queries_declare_their_histories_once():
    unit = slr_stream_histories.run(_unit(
        "a(X)^T :- prev(obj(X, _)^Z, T), next(obj(X, _), T, inf).\n"
        "b(T) :- next(seg(_), [T, inf]).\n"
        "r(X) <- e(X) where prev(tf(X)^Z, 3).\n"
        "c(T) :- prev(m, obj(_, _), T).\n"))
    declared = [write_term(c.goal, 999) for c in unit.program.clauses if isinstance(c, Declaration)]
    assert declared == ["stream_history(obj / 2)", "stream_history(seg / 1)", "stream_history(tf / 1)"]


def test_a_declared_stream_history_is_kept_as_written():
    unit = slr_stream_histories.run(_unit("stream_history(obj/2, 10, 5).\na(T) :- prev(obj(_, _), T).\n"))
    declared = [write_term(c.goal, 999) for c in unit.program.clauses if isinstance(c, Declaration)]
    assert declared == ["stream_history(obj / 2, 10, 5)"]


def test_goal_sets_follow_the_call_graph():
    from retalisc.passes import slr_goal_sets

    unit = slr_goal_sets.run(slr_time_terms.run(_unit(
        "interp(Id, T, V) :- prev(Id, tf(V)^_, T).\n"
        "place(T, P) :- interp(odom, T, A), head(T, B), P is A + B.\n"
        "head(T, B) :- prev(neck_head, tf(B)^_, T), next(seen(_), T, inf).\n"
        "plain(X) :- X > 1.\n"
        "obj_color(O, C)^T :- prev(obj(O), color(C)^_, T).\n")))
    declared = [write_term(c.goal, 999) for c in unit.program.clauses if isinstance(c, Declaration)]
    assert declared == [
        "goal_set(head / 2, [neck_head], [seen / 1])",
        "goal_set(interp / 3, [Id], [])",
        "goal_set(obj_color / 4, [obj(O)], [])",
        "goal_set(place / 2, [Id, neck_head], [seen / 1])",
    ]


def test_declarations_written_as_directives_run_at_start_like_facts():
    program = parse_program(":- c_mem(m, a(_)-[], 3, inf).\n:- max_delay(a/1, 0.5).\n:- dynamic foo/1.\n", "t.rtl")
    kinds = [type(c).__name__ for c in program.clauses]
    assert kinds == ["Declaration", "Declaration", "Directive"]
