:- module(rtl_timers,
          [ rtl_timer_add/3,            % +Due, +Kind, :Goal
            rtl_timer_cancel/1,         % :Goal
            rtl_absence_wait/2,         % +Close, :Goal
            rtl_timers_run/1,           % +Phase
            rtl_timers_flush/0,
            rtl_timers_clear/0,
            rtl_timers_drop/2,          % +Module, :NameTest
            rtl_timers_program/1,       % +Module
            rtl_timers_pending/1        % -Count
          ]).

/** <module> Timers on event time: absences and alarms

A timer is a goal of the compiled program that runs when the component's clock (the largest
end time processed, rtl_ele) passes a time. Timers never move the clock: they fire when
input events (or the live heartbeat, or clock lines) move it past them, in the order of
their times (ties in the order they were set), each before the event that moved the clock
past it is processed. Two kinds:

  - `at`: fires once the clock has reached Due (`alarm(E, D)` heads: E is raised at
    end + D);
  - `after`: fires once the clock has passed Due strictly (absences `not(C).[A, D]`: decided
    when no blocker within the delay bound can arrive any more, rtl_absence_wait/2).

Pending timers are state like partial matches: one per match that set it, removed when it
fires or when the match is deleted (rtl_timer_cancel/1, called by the compiled delete
rules), forgotten by rtl_clear/0. At most `max_timers` (a flag, default 100,000) are pending:
one more is not set, but counted and reported (rtl_timer_add/3). The next due time is cached, so an event that moves the
clock past no timer pays one comparison.

At the end of the input, pending timers do not fire (the clock did not reach them) unless
the flag `flush_timers` is true (rtl_timers_flush/0): then every timer pending at that
moment fires in time order, as if the clock had passed the last of them.
*/

:- use_module(rtl_flags, [rtl_flag/2, rtl_count/1]).

:- meta_predicate rtl_timer_add(+, +, :), rtl_timer_cancel(:), rtl_absence_wait(+, :),
                  rtl_timers_drop(+, 1).

:- dynamic timer/4.                 % timer(Due, Seq, Kind, Module:Goal)

%!  rtl_timer_add(+Due:number, +Kind, :Goal) is det.
%
%   Run Goal when the clock reaches Due (Kind `at`) or passes it (Kind `after`). A timer
%   already due runs at the end of the current input event (rtl_timers_run/1). When the
%   flag `max_timers` timers are pending already, the timer is not set: it is counted
%   (`timers_refused`) and reported as a warning of the input line being processed.

rtl_timer_add(Due, _Kind, _Goal) :-
    rtl_flag(max_timers, Max),
    Max \== inf,
    rtl_timers_pending(Pending),
    Pending >= Max,
    !,
    rtl_count(timers_refused),
    format(string(Text), "~D timers pending (max_timers): a timer due at ~w was not set", [Pending, Due]),
    rtl_horizon:rtl_warning(Text).
rtl_timer_add(Due, Kind, Goal) :-
    flag(rtl_timer_seq, Seq, Seq + 1),
    assertz(timer(Due, Seq, Kind, Goal)),
    (   nb_current(rtl_next_timer, Next), number(Next), Next =< Due
    ->  true
    ;   nb_setval(rtl_next_timer, Due)
    ).

%!  rtl_timer_cancel(:Goal) is semidet.
%
%   Remove one pending timer of Goal (a variant); fails if there is none (it has fired).

rtl_timer_cancel(Goal) :-
    clause(timer(_, _, _, G), true, Ref),
    G =@= Goal,
    !,
    erase(Ref).

%!  rtl_absence_wait(+Close:number, :Goal) is det.
%
%   An absence whose period ends at Close: Goal decides it once the clock has passed
%   Close + max_delay (Close is beyond the delay bound, rtl_time:rtl_beyond_bound/3: no
%   blocker ending by Close can arrive within the bound any more; the `after` timer at that
%   sum is due exactly then). With `max_delay` `inf` it is decided only by
%   rtl_timers_flush/0.

rtl_absence_wait(Close, Goal) :-
    rtl_flag(max_delay, Delay),
    (   Delay == inf -> Due = inf ; Due is Close + Delay ),
    rtl_timer_add(Due, after, Goal).

%!  rtl_timers_run(+Phase) is det.
%
%   Fire the timers the clock has moved past, in time order. Phase `before` (the clock has
%   just moved to the end of an input event, which is not processed yet): the timers due
%   strictly before the clock. Phase `after` (the event has been processed): also the `at`
%   timers due at the clock itself.

rtl_timers_run(Phase) :-
    (   nb_current(rtl_next_timer, Next),
        nb_getval(rtl_clock, Clock),
        Next =< Clock
    ->  fire_loop(Phase, Clock)
    ;   true
    ).

fire_loop(Phase, Clock) :-
    (   aggregate_all(min(D, S), ( timer(D, S, Kind, _), due(Phase, Kind, D, Clock) ), min(Due, Seq))
    ->  (   retract(timer(Due, Seq, _, Goal))
        ->  call(Goal)
        ;   true
        ),
        fire_loop(Phase, Clock)
    ;   next_due
    ).

due(_, _, Due, Clock) :- Due \== inf, Due < Clock, !.
due(after, at, Due, Clock) :- Due =:= Clock.

next_due :-
    (   aggregate_all(min(Due), ( timer(Due, _, _, _), Due \== inf ), Next)
    ->  nb_setval(rtl_next_timer, Next)
    ;   nb_setval(rtl_next_timer, inf)
    ).

%!  rtl_timers_flush is det.
%
%   The end of the input with the flag `flush_timers`: every timer pending now fires, in
%   time order (absences waiting for the delay bound included, `inf` ones last). Timers that
%   the fired ones set, later than the last pending one, do not fire (a timer that re-arms
%   itself would never end).

rtl_timers_flush :-
    (   timer(_, _, _, _)
    ->  (   aggregate_all(max(Due), ( timer(Due, _, _, _), Due \== inf ), Last0) -> true ; Last0 = none ),
        flush_until(Last0),
        flush_unbounded
    ;   true
    ).

% the absences that wait for an unbounded delay, in the order they were set
flush_unbounded :-
    forall(retract(timer(inf, _, _, Goal)), call(Goal)),
    next_due.

flush_until(none) :- !.
flush_until(Last) :-
    (   aggregate_all(min(D, S), ( timer(D, S, _, _), D \== inf, D =< Last ), min(Due, Seq))
    ->  (   retract(timer(Due, Seq, _, Goal))
        ->  call(Goal)
        ;   true
        ),
        flush_until(Last)
    ;   next_due
    ).

%!  rtl_timers_clear is det.
%
%   Forget every pending timer.

rtl_timers_clear :-
    retractall(timer(_, _, _, _)),
    nb_setval(rtl_next_timer, inf).

%!  rtl_timers_drop(+Module, :NameTest) is det.
%
%   Forget the pending timers of Module whose goal's name passes call(NameTest, Name) (the
%   timers of an event rule that is removed).

rtl_timers_drop(M, Test) :-
    forall(( clause(timer(_, _, _, M:Goal), true, Ref),
             functor(Goal, Name, _),
             call(Test, Name) ),
           erase(Ref)),
    next_due.

%!  rtl_timers_program(+Module) is det.
%
%   Module becomes the program that processes events: the pending timers of other programs
%   are forgotten (they would call into a program that no longer receives events).

rtl_timers_program(M) :-
    forall(( clause(timer(_, _, _, M1:_), true, Ref), M1 \== M ), erase(Ref)),
    next_due.

%!  rtl_timers_pending(-Count:integer) is det.
%
%   The number of pending timers.

rtl_timers_pending(Count) :-
    predicate_property(timer(_, _, _, _), number_of_clauses(Count)), !.
rtl_timers_pending(0).

:- multifile rtl_ele:clear_hook/0.
rtl_ele:clear_hook :-
    rtl_timers_clear.
