/*  plunit tests of rtl_raise.pl: events raised by program code (new_event/1,2,3) are input
    events processed after the event being processed, with all it derives, in the order
    raised; events raised by those go to the end of the queue (a breadth-first order, checked
    on random trees of raised events); their times are the clock or the ones given. An event
    raised outside an event waits for the next input event or rtl_flush_raised/0 (raise/3
    queues whenever prolog_load_context(module, _) holds, which it does anywhere: so also at
    the top level, where docs/runtime.md says such an event is processed at once; the
    directives of a program loaded by the Engine rely on the queueing).

        swipl -g run_tests -t halt prolog_runtime/tests/test_raise.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(random)).
:- use_module('../retalis').

% A program with no rules; the trigger raises the children of n(K) (children/2 below).
:- dynamic raise_test_program:ele_untrigger/3, raise_test_program:ele_store/3,
           raise_test_program:ele_partial_store/2.
raise_test_program:ele_printed(_).
raise_test_program:(ele_trigger(n(K), _, _) :- user:raise_children(K)).
raise_test_program:(ele_trigger(at(E, T), _, _) :- rtl_raise:new_event(E, T)).

:- dynamic child/2, seen/3.
raise_children(K) :- forall(child(K, C), new_event(n(C))).

record(Event, Start, End, add) :- assertz(seen(Event, Start, End)).
record(_, _, _, retract).

fresh :-
    rtl_use_program(raise_test_program),
    rtl_clear,
    rtl_output_to(buffer),
    retractall(seen(_, _, _)),
    retractall(child(_, _)),
    rtl_add_output_hook(user:record).

processed(Events) :- findall(E, seen(E, _, _), Events).

% Breadth first: the children of each node in the order raised, after everything before.
bfs([], []).
bfs([K|Ks], [n(K)|Out]) :-
    findall(C, child(K, C), Cs),
    append(Ks, Cs, Queue),
    bfs(Queue, Out).

:- begin_tests(rtl_raise, [setup(fresh)]).

test(raised_events_come_after_the_event_breadth_first, [setup(fresh)]) :-
    set_random(seed(36)),
    forall(between(1, 50, _),
           ( fresh,
             random_between(1, 15, N),
             forall(between(2, N, C), ( P is random(C - 1) + 1, assertz(child(P, C)) )),
             rtl_input(add, n(1), 1, 1),
             processed(Events),
             bfs([1], Expected),
             assertion(Events == Expected) )).

test(times_are_the_clock_or_given, [setup(fresh)]) :-
    rtl_input(add, start, 5, 5),
    new_event(now),                                    % outside an event: queued
    new_event(later, 7),
    new_event(span, [8, [9, 500000000]]),
    new_event(ros, 10, 250000000),
    assertion(\+ seen(now, _, _)),
    rtl_flush_raised,
    findall(E-S-T, seen(E, S, T), Seen),
    assertion(Seen == [start-5-5, now-5-5, later-7-7, span-8-9.5, ros-10.25-10.25]).

test(an_action_s_event_waits_for_the_action_s_event, [setup(fresh)]) :-
    rtl_flush_raised,
    rtl_input(add, at(inner, 3), 2, 2),
    findall(E-S, seen(E, S, _), Seen),
    assertion(Seen == [at(inner, 3)-2, inner-3]).

test(not_ground_is_refused, [setup(fresh), error(instantiation_error)]) :-
    new_event(p(_)).

:- end_tests(rtl_raise).
