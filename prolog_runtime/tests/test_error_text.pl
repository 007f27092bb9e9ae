/*  plunit tests of rtl_error_text.pl, the one printer of errors, and of the guards of
    rtl_guard.pl: an error term is printed, never interpreted (a `~@` goal in it does not
    run, no portray or message hook is called), the line is bounded, and the known forms read
    as SWI-Prolog's messages do.

        swipl -g run_tests -t halt prolog_runtime/tests/test_error_text.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module('../rtl_error_text').
:- use_module('../rtl_guard').

:- dynamic ran/0.
:- dynamic user:portray/1.
:- multifile user:portray/1.

mark :- assertz(ran).

contains(Text, Part) :- once(sub_string(Text, _, _, _, Part)).

:- begin_tests(rtl_error_text).

test(never_runs_a_format_goal, [true(\+ ran), setup(retractall(ran))]) :-
    rtl_error_text(error(format("~@", [mark]), _), T1),
    rtl_error_text(format("~@", [mark]), T2),
    rtl_error_text(error(type_error(integer, format("~@", [mark])), context(foo/1, format("~@", [mark]))), T3),
    maplist([T]>>contains(T, "mark"), [T1, T2, T3]).

test(never_calls_portray, [true(\+ ran), setup(retractall(ran)),
                            cleanup(retractall(user:portray(_)))]) :-
    assertz((user:portray(secret) :- mark)),
    rtl_error_text(error(domain_error(x, secret), _), T),
    contains(T, "secret").

test(bounded_line, [true(L < 2100)]) :-
    numlist(1, 300000, List),
    rtl_error_text(error(type_error(integer, List), _), T),
    string_length(T, L),
    contains(T, "[1,2,3").

test(a_long_atom_is_cut, [true(L =< 2000)]) :-
    length(Cs, 100000), maplist(=(0'a), Cs), atom_codes(A, Cs),
    rtl_error_text(A, T),
    string_length(T, L).

test(one_line) :-
    rtl_error_text(error(domain_error(x, 'a\nb'), context(p/1, 'two\nlines')), T),
    \+ contains(T, "\n").

test(iso_forms) :-
    rtl_error_text(error(type_error(integer, a), context(system:atom_length/2, _)), T1),
    T1 == "system:atom_length/2: Type error: `integer' expected, found `a' (an atom)",
    rtl_error_text(error(existence_error(procedure, foo/1), context(foo/1, _)), T2),
    contains(T2, "Unknown procedure: foo/1"),
    rtl_error_text(error(instantiation_error, _), "Arguments are not sufficiently instantiated"),
    rtl_error_text(error(evaluation_error(zero_divisor), context(system:(/)/2, _)), T3),
    contains(T3, "Arithmetic: evaluation error: zero_divisor").

test(runtime_forms) :-
    rtl_error_text(error(rtl_step_limit(1000000), _), "more than 1,000,000 steps (--max-steps)"),
    rtl_error_text(time_limit_exceeded, "no answer within the time limit").

test(unknown_forms) :-
    rtl_error_text(error(my_error(1), _), "Unknown error term: my_error(1)"),
    rtl_error_text(my_ball, "Unhandled exception: my_ball"),
    rtl_error_text(_, T),
    sub_string(T, 0, _, _, "Unhandled exception: _").

test(cyclic) :-
    X = f(X),
    rtl_error_text(error(domain_error(x, X), _), T),
    string(T).

:- end_tests(rtl_error_text).

:- begin_tests(rtl_guard).

test(catch_lets_reserved_balls_pass, [throws(time_limit_exceeded)]) :-
    rtl_catch(throw(time_limit_exceeded), _, true).

test(catch_lets_the_step_limit_pass, [throws(error(rtl_step_limit(5), _))]) :-
    rtl_catch(throw(error(rtl_step_limit(5), _)), error(_, _), true).

test(catch_catches_the_others, [true(B == mine)]) :-
    rtl_catch(throw(mine), B, true).

test(catch_keeps_choice_points, [all(X == [1, 2])]) :-
    rtl_catch(member(X, [1, 2]), _, true).

test(throw_refuses_reserved, [error(permission_error(throw, reserved_ball, '$aborted'))]) :-
    rtl_throw('$aborted').

test(throw_throws_the_others, [throws(mine(1))]) :-
    rtl_throw(mine(1)).

test(format_directives) :-
    rtl_format_directive("a ~@ b", '~@'),
    rtl_format_directive('~W', '~W'),
    rtl_format_directive("~p", '~p'),
    rtl_format_directive(`~10|~*c~W`, '~W'),
    \+ rtl_format_directive("~w ~a ~q ~d ~2f ~e ~s ~n ~t~20| ~c ~~ ~:d ~`-t~30|", _).

test(format_guard, [error(permission_error(use, format_directive, '~@'))]) :-
    rtl_format(atom(_), "~@", [true]).

test(format_sink, [error(permission_error(output, sink, user_error))]) :-
    rtl_format(user_error, "~w", [x]).

:- end_tests(rtl_guard).
