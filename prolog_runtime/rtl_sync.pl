:- module(rtl_sync,
          [ rtl_synchronized/5,         % +Event, :Query, +SyncConds, +Start, +End
            rtl_synchronized_retract/5, % +Event, :Query, +SyncConds, +Start, +End
            rtl_sync_finish/1,          % +Mode (run or drop)
            rtl_sync_pending/1,         % -Count
            max_delay/2,                % +Name/Arity, +Seconds or learn
            rtl_history_complete/2,     % +Name/Arity, +Time
            rtl_type_delay/2,           % +Name/Arity, -Seconds
            rtl_postpone/3,             % +Conditions, +Until, :Action
            rtl_up_to_date/1,           % +MemoryId-Time
            rtl_input_ended/0,
            rtl_goal_set/3,             % +Name/Arity, -MemoryIds, -StreamTypes
            goal_set/3                  % +Name/Arity, +MemoryIds, +StreamTypes
          ]).

/** <module> Synchronized rules: wait for late data, then query (thesis 4.2.5, A.2.5.2)

*History availability* (Def. 27): the history of events of type Name/Arity is complete up
to time T when

  - an input event `updated(Name/Arity)` with time at least T has been processed (a producer
    says it has sent everything up to then), or
  - T lies beyond the type's delay bound behind the clock (`T + Delay < Clock`,
    rtl_time:rtl_beyond_bound/3): an event ending at T would be late now, while one exactly
    Delay seconds late is still within the bound and may come. The delay bound of a type is
    declared with `max_delay(Name/Arity, Seconds)`, or learned with
    `max_delay(Name/Arity, learn)` as the largest delay seen so far (the clock when the
    event arrived minus its end time, Def. 25-26); otherwise it is the flag `max_delay`.

A rule `synchronized(Event, Query, SyncConds) <- Pattern` (the original release spells it
`syncronized`) runs Query once for each match of Pattern, but only when the memories it
reads are up to date: SyncConds is a list `[[MemoryId, Time], ...]`, and the query waits
until each memory MemoryId either holds a record that ends after Time, or the history of the
events it records is complete up to Time. Then Query runs (its first solution binds Event) and Event
is derived over the match's interval, once. A match that must wait is *postponed*; other
matches and the event flow go on.

Postponed matches wait on monitors: one per (memory, time) still missing, woken by the
memory's record additions (rtl_slr's memory_update_hook/4), and one deadline per such
condition (its Time plus the delay bound of its memory's events), checked as the clock
moves: a condition is cleared by whichever comes first, and the match is released when its
last condition is cleared. Both are kept in time
indexes (rtl_time_index.pl), so a record or a clock step costs what it wakes, not the
number of matches waiting (thousands when producers are seconds late). At the end of the input
every history is complete, so rtl_sync_finish(run) runs the matches still postponed, in time
order; rtl_sync_finish(drop) discards them.
*/

:- use_module(rtl_error_text, [rtl_term_text/2]).
:- use_module(rtl_guard, [rtl_condition_raised/3]).
:- use_module(rtl_ele).
:- use_module(rtl_slr).
:- use_module(rtl_time).
:- use_module(rtl_time_index).

:- meta_predicate rtl_synchronized(+, 0, +, +, +), rtl_synchronized_retract(+, 0, +, +, +),
                  rtl_postpone(+, +, 1).

% pending(N, Event, Query, Start, End, Until): match N, its open conditions being
% condition(N, _, _, _); Until is the time a '$call' wait gives up (`inf`: never, and for
% rules), in the time index `until` under Program (item N)
:- dynamic pending/6.
% condition(N, MemoryId, Time, Due): match N waits until memory MemoryId is up to date for
% Time. Its monitor is in the time index `monitor` under Program-MemoryId (item N-Time), or,
% for a query ('$call'), which any new record may satisfy, call_monitor(Program-MemoryId, N);
% Due (`inf`: none) is when the delay bound of the memory's events completes its history up
% to Time, in the time index `deadline` under Program (item N-MemoryId-Time): each
% condition has its own deadline, so one met by the clock is cleared when the clock passes
% it, whatever the other conditions of the match wait for.
:- dynamic condition/4.
:- dynamic call_monitor/2.
% declared_delay(Program, Name, Arity, Seconds or learn)
:- dynamic declared_delay/4.
% learned_delay(Program, Name, Arity, Seconds)
:- dynamic learned_delay/4.
% updated_until(Program, Name, Arity, Time)
:- dynamic updated_until/4.

:- multifile retalis:rtl_declaration_handler/3.
retalis:rtl_declaration_handler(max_delay, 2, rtl_sync).
retalis:rtl_declaration_handler(goal_set, 3, rtl_sync).

% goal_set_of(Program, Name, Arity, MemoryIds, StreamTypes)
:- dynamic goal_set_of/5.

%!  goal_set(+Type, +MemoryIds, +StreamTypes) is det.
%
%   Declared by the compiler (pass slr_goal_sets): the dynamic goal set of the static
%   predicate Type (Def. 28): the ids (or id patterns) of the memories and the event types
%   of the stream histories a goal of Type may read.

goal_set(Name/Arity, Ids, Types) :-
    (   prolog_load_context(module, M), current_predicate(M:ele_trigger/3)
    ->  true
    ;   rtl_program(M)
    ),
    retractall(goal_set_of(M, Name, Arity, _, _)),
    assertz(goal_set_of(M, Name, Arity, Ids, Types)).

%!  rtl_goal_set(+Type, -MemoryIds, -StreamTypes) is semidet.

rtl_goal_set(Name/Arity, Ids, Types) :-
    rtl_program(M),
    goal_set_of(M, Name, Arity, Ids, Types).

%!  rtl_postpone(+Conditions, +Until, :Action) is det.
%
%   Conditions is a list `MemoryId-Time`. Call `call(Action, ready)` as soon as every
%   memory is up to date for its time (at once if they are now); `call(Action, timeout)` if
%   the clock reaches Until (a number or `inf`) first; `call(Action, dropped)` if the input
%   ends with rtl_sync_finish(drop).

rtl_postpone(Conds, Until, Action) :-
    exclude(rtl_up_to_date, Conds, Open),
    (   Open == []
    ->  call(Action, ready)
    ;   rtl_clock(Clock), Until \== inf, Clock >= Until
    ->  call(Action, timeout)
    ;   rtl_program(M),
        park('$call'(Action, Until), M:true, Open, 0, 0)
    ).

%!  max_delay(+Type, +Delay) is det.
%
%   Declare the delay bound of events of Type (Name/Arity): a number of seconds, or `learn`
%   (the largest delay seen so far).

max_delay(Type, Delay) :-
    (   Type = Name/Arity, atom(Name), integer(Arity)
    ->  true
    ;   throw(error(type_error(event_type, Type), context(max_delay/2, 'write Name/Arity')))
    ),
    (   Delay == learn -> true
    ;   number(Delay), Delay >= 0 -> true
    ;   throw(error(domain_error(delay, Delay), context(max_delay/2, 'seconds >= 0 or learn')))
    ),
    (   prolog_load_context(module, M), current_predicate(M:ele_trigger/3)
    ->  true                                 % a directive of the program being loaded
    ;   rtl_program(M)
    ),
    retractall(declared_delay(M, Name, Arity, _)),
    assertz(declared_delay(M, Name, Arity, Delay)),
    rtl_add_type_output_hook(updated(_), rtl_sync:availability),
    (   Delay == learn
    ->  functor(Pattern, Name, Arity),
        rtl_add_type_output_hook(Pattern, rtl_sync:availability)
    ;   true
    ).

%!  rtl_type_delay(+Type, -Delay) is det.
%
%   The delay bound of Type (Name/Arity) now: declared, learned, or the flag max_delay.

rtl_type_delay(Name/Arity, Delay) :-
    rtl_program(M),
    (   declared_delay(M, Name, Arity, D0)
    ->  (   D0 == learn
        ->  ( learned_delay(M, Name, Arity, D) -> Delay = D ; Delay = 0 )
        ;   Delay = D0
        )
    ;   rtl_flag(max_delay, Delay)
    ).

%!  rtl_history_complete(+Type, +Time) is semidet.
%
%   Every event of Type (Name/Arity) ending at or before Time has arrived.

rtl_history_complete(Name/Arity, T) :-
    rtl_program(M),
    (   updated_until(M, Name, Arity, U), U >= T
    ->  true
    ;   rtl_type_delay(Name/Arity, Delay),
        rtl_clock(Clock),
        rtl_beyond_bound(T, Clock, Delay)       % an event ending at T would be late now
    ).

%   The type output hook of availability: `updated(Type)` events, and the events of the
%   types whose delay is learned.
availability(updated(Type), _, End, add) :- !,
    (   nonvar(Type), Type = Name/Arity
    ->  rtl_program(M),
        (   updated_until(M, Name, Arity, U), U >= End
        ->  true
        ;   retractall(updated_until(M, Name, Arity, _)),
            assertz(updated_until(M, Name, Arity, End)),
            recheck_all
        )
    ;   true
    ).
availability(Event, _, End, add) :- !,
    functor(Event, Name, Arity),
    (   rtl_program(M),
        declared_delay(M, Name, Arity, learn)
    ->  rtl_clock(Clock),
        Delay is Clock - End,
        (   learned_delay(M, Name, Arity, D0), D0 >= Delay
        ->  true
        ;   retractall(learned_delay(M, Name, Arity, _)),
            assertz(learned_delay(M, Name, Arity, Delay))
        )
    ;   true
    ).
availability(_, _, _, _).

%   rtl_clear/0 forgets what the program has seen: the histories made complete by
%   `updated` events, the delays learned and the matches still postponed (not the delays
%   the program declares).
:- multifile rtl_ele:clear_hook/0.
rtl_ele:clear_hook :-
    rtl_program(M),
    retractall(learned_delay(M, _, _, _)),
    retractall(updated_until(M, _, _, _)),
    forall(pending(N, _, M:_, _, _, _), forget(N)).

%   Memories register the availability hook: `updated` events may come before any wait.
:- multifile rtl_slr:instance_created_hook/2.
rtl_slr:instance_created_hook(_, _) :-
    rtl_add_type_output_hook(updated(_), rtl_sync:availability).

%!  rtl_synchronized(+Event, :Query, +SyncConds, +Start, +End) is det.
%
%   Called by a compiled synchronized rule for each match [Start, End] of its pattern.

rtl_synchronized(Event, Query, SyncConds, Start, End) :-
    sync_conditions(SyncConds, Waits),
    exclude(rtl_up_to_date, Waits, Open),
    (   Open == []
    ->  release(Event, Query, Start, End)
    ;   park(Event, Query, Open, Start, End)
    ).

park(Event, Query, Open, Start, End) :-
    flag(rtl_sync_match, N0, N0 + 1),
    N is N0 + 1,
    (   Event = '$call'(_, Until0) -> Until = Until0 ; Until = inf ),
    Query = M:_,
    assertz(pending(N, Event, Query, Start, End, Until)),
    forall(member(Id-T, Open), add_condition(M, N, Event, Id, T)),
    (   Until == inf -> true ; time_index_add(until, M, Until, N) ),
    rtl_add_output_hook(rtl_sync:clock_moved).

add_condition(M, N, Event, Id, T) :-
    condition_due(Id-T, Due),
    assertz(condition(N, Id, T, Due)),
    (   Event = '$call'(_, _)
    ->  assertz(call_monitor(M-Id, N))
    ;   time_index_add(monitor, M-Id, T, N-T)
    ),
    (   Due == inf -> true ; time_index_add(deadline, M, Due, N-Id-T) ).

remove_condition(M, N, Id, T) :-
    retract(condition(N, Id, T, Due)),
    (   retract(call_monitor(M-Id, N))
    ->  true
    ;   time_index_remove(monitor, M-Id, T, N-T)
    ),
    (   Due == inf -> true ; time_index_remove(deadline, M, Due, N-Id-T) ).

% Remove match N with its conditions, monitors and deadlines; the last one removes the hook.
unpark(N, Event, Query, Start, End) :-
    retract(pending(N, Event, Query, Start, End, Until)),
    Query = M:_,
    forall(condition(N, Id, T, _), remove_condition(M, N, Id, T)),
    (   Until == inf -> true ; time_index_remove(until, M, Until, N) ),
    (   pending(_, _, _, _, _, _) -> true ; rtl_remove_output_hook(rtl_sync:clock_moved) ).

%!  rtl_synchronized_retract(+Event, :Query, +SyncConds, +Start, +End) is det.
%
%   The match [Start, End] was deleted: a postponed query for it is dropped. (An event
%   already released stays.)

rtl_synchronized_retract(Event, Query, _, Start, End) :-
    forall(( pending(N, E, Q, S, En, _), S =:= Start, En =:= End, E-Q =@= Event-Query ),
           forget(N)).

sync_conditions(Conds, Waits) :-
    (   is_list(Conds)
    ->  maplist(sync_condition, Conds, Waits)
    ;   throw(error(type_error(list, Conds),
                    context(synchronized/3, 'the synchronization conditions are a list [[MemoryId, Time], ...]')))
    ).

sync_condition(Cond, Id-T) :-
    (   Cond = [Id, Time], ground(Id), nonvar(Time)
    ->  (   rtl_time_seconds(Time, T) -> true
        ;   catch(T is Time, _, fail) -> true
        ;   throw(error(type_error(time, Time), context(synchronized/3, _)))
        )
    ;   throw(error(instantiation_error,
                    context(synchronized/3, 'a synchronization condition is [MemoryId, Time], both bound')))
    ).

%!  rtl_up_to_date(+Condition) is semidet.
%
%   Condition `MemoryId-Time` holds: the memory has a record that ends after Time, or the
%   history of the events it records is complete up to Time, or the input has ended.
%
%   A record that ends exactly at Time is not enough, although prev and next at Time count
%   it (their bounds are inclusive): several events of one type may end at the same time
%   (the transforms of one tf message share a stamp), and a second one arriving after the
%   first may change what prev and next answer at Time (among equal end times the order is
%   that of the records, rtl_slr). Only a record ending after Time shows, under the thesis's
%   assumption that the events of a type arrive in the order of their end times, that every
%   record ending at or before Time has come.

rtl_up_to_date(Id-T) :-
    (   rtl_input_ended
    ->  true
    ;   rtl_memory_last_end(Id, Last), Last > T
    ->  true
    ;   rtl_memory_type(Id, Type)
    ->  rtl_history_complete(Type, T)
    ;   throw(error(existence_error(memory_instance, Id), context(synchronized/3, _)))
    ).

% condition_due(+Condition, -Due): the clock passing Due (strictly) completes the history of
% the condition's memory up to its time by the delay bound now (`inf`: it never does).
condition_due(Id-T, Due) :-
    (   T \== inf, rtl_memory_type(Id, Type), rtl_type_delay(Type, Delay), Delay \== inf
    ->  Due is T + Delay                        % rtl_beyond_bound/3's sum
    ;   Due = inf
    ).

release('$call'(Action, _), _, _, _) :- !,
    call(Action, ready).
release(Event, Query, Start, End) :-
    (   catch(once(Query), Error,
              ( rtl_term_text(Query, Q),
                rtl_condition_raised(Error, "synchronized query ~s raised ~s; no event", [Q]) ))
    ->  rtl_derived(Event, Start, End)
    ;   true
    ).

forget(N) :-
    (   unpark(N, _, _, _, _) -> true ; true ).

release_pending(N) :-
    (   unpark(N, Event, Query, Start, End)
    ->  release(Event, Query, Start, End)
    ;   true
    ).

%   A record was added to memory Id: wake the matches waiting for it (each one's condition
%   on Id for a time before End now holds), and the queries waiting on Id, in the order
%   the matches were postponed.
:- multifile rtl_slr:memory_update_hook/4.
rtl_slr:memory_update_hook(M, Id, _, End) :-
    time_index_take(monitor, M-Id, <, End, Met),
    findall(N-call, call_monitor(M-Id, N), Calls),
    append(Met, Calls, Woken0),
    (   Woken0 == []
    ->  true
    ;   msort(Woken0, Woken),
        forall(member(N-What, Woken), woken(Id, N, What))
    ).

woken(_, N, call) :- !,
    release_pending(N).          % a query: evaluate it again, it says what it still needs
woken(Id, N, T) :-
    (   pending(N, _, M:_, _, _, _),
        condition(N, Id, T, _)
    ->  remove_condition(M, N, Id, T),
        (   condition(N, _, _, _) -> true ; release_pending(N) )
    ;   true
    ).

%   The output hook while matches are postponed: the conditions whose deadlines the clock
%   has passed are met now (unless a learned delay grew: then they wait for the new one),
%   and a match whose last condition that was is released; queries whose time is up get
%   `timeout`.
clock_moved(_, _, _, add) :- !,
    rtl_clock(Clock),
    rtl_program(M),
    time_index_take(deadline, M, <, Clock, Due),
    forall(member(N-Id-T, Due), condition_due_passed(M, N, Id, T)),
    time_index_take(until, M, =<, Clock, TimedOut),
    forall(member(N, TimedOut), timed_out(N)).
clock_moved(_, _, _, _).

condition_due_passed(M, N, Id, T) :-
    (   retract(condition(N, Id, T, _))           % its deadline entry was taken
    ->  (   rtl_up_to_date(Id-T)
        ->  (   retract(call_monitor(M-Id, N)) -> true ; time_index_remove(monitor, M-Id, T, N-T) ),
            (   condition(N, _, _, _) -> true ; release_pending(N) )
        ;   condition_due(Id-T, Due),           % the delay bound grew
            assertz(condition(N, Id, T, Due)),
            (   Due == inf -> true ; time_index_add(deadline, M, Due, N-Id-T) )
        )
    ;   true
    ).

timed_out(N) :-
    (   pending(N, '$call'(Action, _), _, _, _, _)
    ->  forget(N),
        call(Action, timeout)
    ;   true
    ).

% An `updated` event came: check the open conditions of match N again, release it when all
% hold.
recheck(N) :-
    (   pending(N, _, M:_, _, _, _)
    ->  forall(( condition(N, Id, T, _), rtl_up_to_date(Id-T) ), remove_condition(M, N, Id, T)),
        (   condition(N, _, _, _) -> true ; release_pending(N) )
    ;   true
    ).

recheck_all :-
    (   rtl_program(M), pending(_, _, M:_, _, _, _)
    ->  findall(End-N, pending(N, _, M:_, _, End, _), Pairs),
        keysort(Pairs, Sorted),
        forall(member(_-N, Sorted), recheck(N))
    ;   true
    ).

%!  rtl_sync_finish(+Mode) is det.
%
%   The input has ended, so every history is complete: run (Mode `run`) the postponed
%   matches in the order of their match end times, or discard them (Mode `drop`).

rtl_sync_finish(drop) :- !,
    rtl_program(M),
    forall(pending(N, Event, M:_, _, _, _),
           ( forget(N),
             ( Event = '$call'(Action, _) -> call(Action, dropped) ; true ) )).
rtl_sync_finish(run) :-
    rtl_program(M),
    findall(End-N, pending(N, _, M:_, _, End, _), Pairs),
    keysort(Pairs, Sorted),
    setup_call_cleanup(nb_setval(rtl_input_ended, true),
                       forall(member(_-N, Sorted), release_pending(N)),
                       nb_setval(rtl_input_ended, false)).

%!  rtl_input_ended is semidet.
%
%   True while rtl_sync_finish(run) runs what still waits at the end of the input.

rtl_input_ended :-
    nb_current(rtl_input_ended, true).

%!  rtl_sync_pending(-Count:integer) is det.
%
%   The number of postponed synchronized matches of the running program.

rtl_sync_pending(Count) :-
    rtl_program(M),
    aggregate_all(count, pending(_, _, M:_, _, _, _), Count).
