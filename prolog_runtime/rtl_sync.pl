:- module(rtl_sync,
          [ rtl_synchronized/5,         % +Event, :Query, +SyncConds, +Start, +End
            rtl_synchronized_retract/5, % +Event, :Query, +SyncConds, +Start, +End
            rtl_sync_finish/1,          % +Mode (run or drop)
            rtl_sync_pending/1          % -Count
          ]).

/** <module> Synchronized rules: wait for late data, then query (thesis 4.2.5, A.2.5.2)

A rule `synchronized(Event, Query, SyncConds) <- Pattern` (the original release spells it
`syncronized`) runs Query once for each match of Pattern, but only when the memories it
reads are up to date: SyncConds is a list `[[MemoryId, Time], ...]`, and the query waits
until each memory MemoryId either holds a record that ends after Time, or its history up to
Time is complete (the clock has passed Time by the delay bound `max_delay`: nothing ending at
or before Time can still arrive). Then Query runs (its first solution binds Event) and Event
is derived over the match's interval, once. A match that must wait is *postponed*; other
matches and the event flow go on.

Postponed matches wait on monitors: one per (memory, time) still missing, woken by the
memory's record additions (rtl_slr's memory_update_hook/4), and one deadline per match (the
largest Time plus the delay bound), checked as the clock moves. At the end of the input
every history is complete, so rtl_sync_finish(run) runs the matches still postponed, in time
order; rtl_sync_finish(drop) discards them.
*/

:- use_module(rtl_ele).
:- use_module(rtl_slr).
:- use_module(rtl_time).

:- meta_predicate rtl_synchronized(+, 0, +, +, +), rtl_synchronized_retract(+, 0, +, +, +).

% pending(N, Event, Query, Start, End, Waiting, Deadline)
:- dynamic pending/7.
% monitor(MemoryId, N, Time): match N waits for a record of MemoryId ending after Time
:- dynamic monitor/3.

%!  rtl_synchronized(+Event, :Query, +SyncConds, +Start, +End) is det.
%
%   Called by a compiled synchronized rule for each match [Start, End] of its pattern.

rtl_synchronized(Event, Query, SyncConds, Start, End) :-
    sync_conditions(SyncConds, Waits),
    exclude(up_to_date, Waits, Open),
    (   Open == []
    ->  release(Event, Query, Start, End)
    ;   flag(rtl_sync_match, N0, N0 + 1),
        N is N0 + 1,
        rtl_flag(max_delay, Delay),
        aggregate_all(max(T), member(_-T, Open), Latest),
        (   Delay == inf -> Deadline = inf ; Deadline is Latest + Delay ),   % history complete then
        length(Open, Waiting),
        assertz(pending(N, Event, Query, Start, End, Waiting, Deadline)),
        forall(member(Id-T, Open), assertz(monitor(Id, N, T))),
        (   nb_current(rtl_sync_next_deadline, Next0), Next0 \== [] -> true ; Next0 = inf ),
        (   Deadline @< Next0, Deadline \== inf -> nb_setval(rtl_sync_next_deadline, Deadline) ; true ),
        rtl_add_output_hook(rtl_sync:clock_moved)
    ).

%!  rtl_synchronized_retract(+Event, :Query, +SyncConds, +Start, +End) is det.
%
%   The match [Start, End] was deleted: a postponed query for it is dropped. (An event
%   already released stays.)

rtl_synchronized_retract(Event, Query, _, Start, End) :-
    forall(( pending(N, E, Q, S, En, _, _), S =:= Start, En =:= End, E-Q =@= Event-Query ),
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

% A memory is up to date for time T when it has a record that ends after T, or when nothing
% ending at or before T can arrive any more.
up_to_date(Id-T) :-
    (   rtl_memory_last_end(Id, Last), Last > T
    ->  true
    ;   history_complete(T)
    ).

history_complete(T) :-
    rtl_flag(max_delay, Delay),
    Delay \== inf,
    rtl_clock(Clock),
    Clock - Delay >= T.

release(Event, Query, Start, End) :-
    (   catch(once(Query), Error,
              ( print_message(warning, format("synchronized query ~q raised ~q; no event", [Query, Error])),
                fail ))
    ->  rtl_derived(Event, Start, End)
    ;   true
    ).

forget(N) :-
    retractall(pending(N, _, _, _, _, _, _)),
    retractall(monitor(_, N, _)),
    (   pending(_, _, _, _, _, _, _) -> true ; rtl_remove_output_hook(rtl_sync:clock_moved) ).

release_pending(N) :-
    (   retract(pending(N, Event, Query, Start, End, _, _))
    ->  retractall(monitor(_, N, _)),
        (   pending(_, _, _, _, _, _, _) -> true ; rtl_remove_output_hook(rtl_sync:clock_moved) ),
        release(Event, Query, Start, End)
    ;   true
    ).

%   A record was added to memory Id: wake the matches waiting for it.
:- multifile rtl_slr:memory_update_hook/4.
rtl_slr:memory_update_hook(M, Id, _, End) :-
    monitor(Id, _, _),
    findall(N, ( monitor(Id, N, T), End > T, pending(N, _, M:_, _, _, _, _) ), Woken),
    forall(member(N, Woken), woken(Id, N)).

woken(Id, N) :-
    (   retract(monitor(Id, N, _)),
        retract(pending(N, Event, Query, Start, End, Waiting, Deadline))
    ->  Left is Waiting - 1,
        (   Left =:= 0
        ->  release_pending_term(N, Event, Query, Start, End)
        ;   assertz(pending(N, Event, Query, Start, End, Left, Deadline))
        )
    ;   true
    ).

release_pending_term(N, Event, Query, Start, End) :-
    retractall(monitor(_, N, _)),
    (   pending(_, _, _, _, _, _, _) -> true ; rtl_remove_output_hook(rtl_sync:clock_moved) ),
    release(Event, Query, Start, End).

%   The output hook while matches are postponed: release those whose histories are
%   complete now that the clock has moved.
clock_moved(_, _, _, add) :- !,
    rtl_clock(Clock),
    (   nb_current(rtl_sync_next_deadline, Next), number(Next), Clock >= Next
    ->  rtl_program(M),
        findall(D-N, ( pending(N, _, M:_, _, _, _, D), D \== inf, D =< Clock ), Due0),
        keysort(Due0, Due),
        forall(member(_-N, Due), release_pending(N)),
        (   aggregate_all(min(D), ( pending(_, _, _, _, _, _, D), D \== inf ), Min)
        ->  nb_setval(rtl_sync_next_deadline, Min)
        ;   nb_setval(rtl_sync_next_deadline, inf)
        )
    ;   true
    ).
clock_moved(_, _, _, _).

%!  rtl_sync_finish(+Mode) is det.
%
%   The input has ended, so every history is complete: run (Mode `run`) the postponed
%   matches in the order of their match end times, or discard them (Mode `drop`).

rtl_sync_finish(drop) :- !,
    rtl_program(M),
    forall(pending(N, _, M:_, _, _, _, _), forget(N)).
rtl_sync_finish(run) :-
    rtl_program(M),
    findall(End-N, pending(N, _, M:_, _, End, _, _), Pairs),
    keysort(Pairs, Sorted),
    forall(member(_-N, Sorted), release_pending(N)).

%!  rtl_sync_pending(-Count:integer) is det.
%
%   The number of postponed synchronized matches of the running program.

rtl_sync_pending(Count) :-
    rtl_program(M),
    aggregate_all(count, pending(_, _, M:_, _, _, _, _), Count).
