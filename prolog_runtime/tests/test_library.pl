/*  plunit tests of rtl_library.pl: ETALIS's library predicates. On random datimes, the
    order (less_datime/2, equal_datime/2, min/3, max/3, between_datime/3) is the order of
    their UTC time stamps, and the arithmetic (datime_plus_sec/3, datime_minus_sec/3,
    datime_minus_datime/3) agrees with date_time_stamp/2 across month and year ends; static
    rules are added to and removed from the running program, never a static predicate.

        swipl -g run_tests -t halt prolog_runtime/tests/test_library.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(random)).
:- use_module('../retalis').

:- dynamic lib_test_program:ele_trigger/3, lib_test_program:ele_untrigger/3,
           lib_test_program:ele_store/3, lib_test_program:ele_partial_store/2,
           lib_test_program:ele_declaration/1, lib_test_program:door/1.
lib_test_program:ele_printed(_).
lib_test_program:fixed(1).

random_datime(datime(Y, M, D, H, Min, S)) :-
    random_between(1999, 2031, Y), random_between(1, 12, M), random_between(1, 28, D0),
    ( random(R), R < 0.3 -> D = 28 ; D = D0 ),
    random_between(0, 23, H), random_between(0, 59, Min), random_between(0, 59, S).

stamp(datime(Y, M, D, H, Min, S), T) :- date_time_stamp(date(Y, M, D, H, Min, S, 0, -, -), T).
stamp(datime(Y, M, D, H, Min, S, _), T) :- stamp(datime(Y, M, D, H, Min, S), T).

:- begin_tests(rtl_library, [setup(rtl_use_program(lib_test_program))]).

test(the_order_of_datimes_is_that_of_their_stamps) :-
    set_random(seed(36)),
    forall(between(1, 500, _),
           ( random_datime(A), random_datime(B0),
             ( random(R), R < 0.2 -> B = A ; B = B0 ),
             stamp(A, TA), stamp(B, TB),
             ( TA < TB -> assertion(less_datime(A, B)) ; assertion(\+ less_datime(A, B)) ),
             ( TA =:= TB -> assertion(equal_datime(A, B)) ; assertion(\+ equal_datime(A, B)) ),
             min(A, B, Min), max(A, B, Max), stamp(Min, TMin), stamp(Max, TMax),
             assertion(TMin =:= min(TA, TB)), assertion(TMax =:= max(TA, TB)) )).

test(counters_order_within_a_second_but_do_not_make_it_another) :-
    assertion(less_datime(datime(2015, 1, 1, 0, 0, 0, 1), datime(2015, 1, 1, 0, 0, 0, 2))),
    assertion(equal_datime(datime(2015, 1, 1, 0, 0, 0, 1), datime(2015, 1, 1, 0, 0, 0, 2))).

test(between) :-
    assertion(between_datime(datime(2015, 1, 2, 0, 0, 0), datime(2015, 1, 1, 0, 0, 0), datime(2015, 1, 3, 0, 0, 0))),
    assertion(\+ between_datime(datime(2015, 1, 1, 0, 0, 0), datime(2015, 1, 1, 0, 0, 0), datime(2015, 1, 3, 0, 0, 0))),
    assertion(between_datime(1, 1, 3)),
    assertion(\+ between_datime(4, 1, 3)).

test(arithmetic_agrees_with_the_stamps) :-
    set_random(seed(7)),
    forall(between(1, 500, _),
           ( random_datime(A), random_between(-100000000, 100000000, Sec),
             datime_plus_sec(A, Sec, B),
             stamp(A, TA), stamp(B, TB),
             assertion(TB =:= TA + Sec),
             B = datime(_, _, _, _, _, S), assertion(integer(S)),
             datime_minus_sec(B, Sec, A2), assertion(A2 == A),
             datime_minus_datime(B, A, Diff), assertion(Diff =:= Sec) )).

test(month_and_year_ends) :-
    datime_plus_sec(datime(2010, 1, 30, 23, 0, 0), 90000, D1),           % 25 hours
    assertion(D1 == datime(2010, 2, 1, 0, 0, 0)),
    datime_plus_sec(datime(2015, 12, 31, 23, 59, 59, 7), 1, D2),
    assertion(D2 == datime(2016, 1, 1, 0, 0, 0, 7)),
    datime_plus_sec(datime(2016, 2, 28, 12, 0, 0), 86400, D3),
    assertion(D3 == datime(2016, 2, 29, 12, 0, 0)).

test(differences_of_every_time_form) :-
    datime_minus_datime([100, 999999999], [90, 0], A), assertion(A == 10),
    datime_minus_datime(datime(100.7, 3), datime(90), B), assertion(B == 10),
    datime_minus_datime(7.9, 2, C), assertion(C == 5),
    catch(datime_minus_datime(soon, 1, _), error(type_error(time_stamp, soon), _), true).

test(type_errors) :-
    catch(less_datime(datime(2015, 1, 1, 0, 0, x), datime(2015, 1, 1, 0, 0, 0)), error(type_error(datime, _), _), true),
    catch(less_datime(1, datime(2015, 1, 1, 0, 0, 0)), error(type_error(datime, 1), _), true).

test(numbers_and_expressions) :-
    min(3, 1 + 1, M), assertion(M == 2),
    max(2.5, 2, X), assertion(X == 2.5).

test(static_rules) :-
    ins_static_rule(door(open)),
    ins_static_rule((door(X) :- X == ajar)),
    assertion(lib_test_program:door(open)),
    assertion(lib_test_program:door(ajar)),
    assertion(del_static_rule(door(open))),
    assertion(\+ lib_test_program:door(open)),
    assertion(\+ del_static_rule(door(open))),
    assertion(\+ del_static_rule(nothing_here(1))),
    catch(ins_static_rule(fixed(2)), error(permission_error(modify, static_procedure, fixed/1), _), true),
    catch(del_static_rule(fixed(1)), error(permission_error(modify, static_procedure, fixed/1), _), true),
    assertion(lib_test_program:fixed(1)),
    assertion(\+ lib_test_program:fixed(2)).

:- end_tests(rtl_library).
