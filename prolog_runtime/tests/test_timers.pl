/*  plunit tests of rtl_timers.pl, through its exported predicates only: timers on event time
    fire as the clock moves past them, in the order of their times (ties in the order set),
    `at` timers at the clock itself after the event, `after` ones only once passed; random
    sets of timers, cancellations and clock moves are checked against a list model, and the
    flush at the end of the input, the cap `max_timers` and dropping a program's timers.

        swipl -g run_tests -t halt prolog_runtime/tests/test_timers.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(random)).
:- use_module('../retalis', []).
:- use_module('../rtl_timers').

:- dynamic fired/1.

fire(Id) :- assertz(fired(Id)).

fresh :-
    retalis:rtl_reset,
    retalis:rtl_default_flags,
    rtl_timers_clear,
    retractall(fired(_)).

clock(T) :- nb_setval(rtl_clock, T).           % rtl_ele's clock, as an input event moves it

fired_ids(Ids) :- findall(Id, fired(Id), Ids), retractall(fired(_)).

% The model: Pending is a list of t(Due, Seq, Kind, Id); the ones due at Phase, in order.
model_due(Phase, Clock, Pending, Due, Rest) :-
    partition(model_is_due(Phase, Clock), Pending, Due0, Rest),
    msort(Due0, Due).
model_is_due(_, Clock, t(D, _, _, _)) :- D \== inf, D < Clock, !.
model_is_due(after, Clock, t(D, _, at, _)) :- D \== inf, D =:= Clock.

ids(Timers, Ids) :- findall(Id, member(t(_, _, _, Id), Timers), Ids).

add_random(Id, P0, P) :-
    random_between(0, 20, D0), random_member(K, [at, after]),
    ( random(R), R < 0.1 -> D = inf ; D = D0 ),
    rtl_timer_add(D, K, user:fire(Id)),
    append(P0, [t(D, Id, K, Id)], P).

cancelled(Round, t(_, _, _, Id)) :-
    Id mod 4 =:= Round mod 4,
    rtl_timer_cancel(user:fire(Id)).

step(_, C0-P0, C-P) :-
    random_between(0, 5, Dt), C is C0 + Dt, clock(C),
    rtl_timers_run(before), fired_ids(F1),
    model_due(before, C, P0, Due1, P1), ids(Due1, E1),
    assertion(F1 == E1),
    rtl_timers_run(after), fired_ids(F2),
    model_due(after, C, P1, Due2, P), ids(Due2, E2),
    assertion(F2 == E2).

unbounded(t(inf, _, _, _)).

:- begin_tests(rtl_timers, [setup(fresh), cleanup(fresh)]).

test(at_fires_at_the_clock_after_fires_once_passed, [setup(fresh)]) :-
    rtl_timer_add(5, at, user:fire(a)),
    rtl_timer_add(5, after, user:fire(b)),
    clock(5), rtl_timers_run(before), fired_ids(I1), assertion(I1 == []),
    rtl_timers_run(after), fired_ids(I2), assertion(I2 == [a]),
    clock(5.5), rtl_timers_run(before), fired_ids(I3), assertion(I3 == [b]),
    rtl_timers_pending(N), assertion(N == 0).

test(ties_fire_in_the_order_set, [setup(fresh)]) :-
    forall(member(Id, [x, y, z]), rtl_timer_add(3, at, user:fire(Id))),
    rtl_timer_add(2, at, user:fire(first)),
    clock(10), rtl_timers_run(before),
    fired_ids(Ids), assertion(Ids == [first, x, y, z]).

test(cancel_one_of_two_variants, [setup(fresh)]) :-
    rtl_timer_add(3, at, user:fire(v)),
    rtl_timer_add(4, at, user:fire(v)),
    assertion(rtl_timer_cancel(user:fire(v))),
    clock(10), rtl_timers_run(before),
    fired_ids(Ids), assertion(Ids == [v]),
    assertion(\+ rtl_timer_cancel(user:fire(v))).

test(random_timers_against_a_model, [setup(fresh)]) :-
    set_random(seed(36)),
    forall(between(1, 60, Round),
           ( fresh, clock(0),
             random_between(1, 12, N), numlist(1, N, Ids),
             foldl(add_random, Ids, [], Pending0),
             exclude(cancelled(Round), Pending0, Pending1),
             random_between(1, 6, Steps),
             numlist(1, Steps, StepList),
             foldl(step, StepList, 0-Pending1, _-Left),
             rtl_timers_pending(Count), length(Left, Count1), assertion(Count == Count1),
             rtl_timers_flush, fired_ids(Flushed),
             partition(unbounded, Left, Unbounded, Bounded),
             msort(Bounded, InOrder),
             append(InOrder, Unbounded, Expected0),
             ids(Expected0, Expected),
             assertion(Flushed == Expected) )).

test(an_absence_waits_for_the_delay_bound, [setup(fresh)]) :-
    retalis:rtl_set_flag(max_delay, 2),
    rtl_absence_wait(10, user:fire(gone)),
    clock(12), rtl_timers_run(after), fired_ids(I1), assertion(I1 == []),
    clock(12.5), rtl_timers_run(before), fired_ids(I2), assertion(I2 == [gone]).

test(an_unbounded_delay_waits_for_the_flush, [setup(fresh)]) :-
    retalis:rtl_set_flag(max_delay, inf),
    rtl_absence_wait(10, user:fire(gone)),
    clock(1.0e9), rtl_timers_run(after), fired_ids(I1), assertion(I1 == []),
    rtl_timers_flush, fired_ids(I2), assertion(I2 == [gone]).

test(the_cap_refuses_one_more, [setup(fresh)]) :-
    retalis:rtl_set_flag(max_timers, 2),
    retalis:rtl_stat(timers_refused, R0),
    rtl_timer_add(1, at, user:fire(a)),
    rtl_timer_add(2, at, user:fire(b)),
    with_output_to(string(_), rtl_timer_add(3, at, user:fire(c))),
    rtl_timers_pending(N), assertion(N == 2),
    retalis:rtl_stat(timers_refused, R1), assertion(R1 =:= R0 + 1).

test(timers_of_a_rule_or_another_program_are_dropped, [setup(fresh)]) :-
    rtl_timer_add(1, at, p1:keep(1)),
    rtl_timer_add(1, at, p1:rule_gone(1)),
    rtl_timer_add(1, at, p2:other(1)),
    rtl_timers_drop(p1, ==(rule_gone)),
    rtl_timers_pending(N1), assertion(N1 == 2),
    rtl_timers_program(p1),
    rtl_timers_pending(N2), assertion(N2 == 1),
    assertion(rtl_timer_cancel(p1:keep(1))).

:- end_tests(rtl_timers).
