:- module(rtl_ele,
          [ rtl_use_program/1,          % +Module
            rtl_program/1,              % -Module
            rtl_reset/0,
            rtl_clear/0,
            rtl_event/3,                % +Event, +Start, +End
            rtl_retract_event/3,        % +Event, +Start, +End
            rtl_derived/3,              % +Event, +Start, +End
            rtl_internal_event/3,       % +Event, +Start, +End
            rtl_underived/3,            % +Event, +Start, +End
            rtl_clock/1,                % -Clock
            rtl_advance_clock/1,        % +Time
            rtl_future_problem/2,       % +End, -Problem
            rtl_started_after/1,        % +Time
            rtl_blockers_due/4,         % +Step, +Partner, +Clock, -Before
            rtl_set_action_output/1,    % +Target
            rtl_action_stream/1,        % -Stream
            rtl_close_action_output/0,
            rtl_output_to/1,            % +Sink
            rtl_take_output/1,          % -Lines
            rtl_take_output_records/1,  % -Records
            rtl_take_output_data/1,     % -Lines
            rtl_output_pending/0,
            rtl_emit/5,                 % +Event, +Start, +End, +Consumer, +Op
            rtl_emit_line/1,            % +Line
            rtl_detected/1,             % +Rule
            rtl_detections/1,           % -Pairs
            rtl_store_size/1,           % -Clauses
            rtl_collect_garbage/0,
            rtl_collect_garbage/1,      % +Scan
            rtl_add_output_hook/1,      % :Hook
            rtl_remove_output_hook/1,   % :Hook
            rtl_add_type_output_hook/2, % +Pattern, :Hook
            rtl_remove_type_output_hook/2, % +Pattern, :Hook
            rtl_remove_type_output_hooks/0,
            rtl_dry_run/3,              % :Goal, -Retracted, -Derived
            rtl_dry_running/0,
            rtl_dispatch_changed/0
          ]).

/** <module> ELE runtime: event ingestion, derivation, output and forgetting

A compiled program is a module holding, among others:

  - `ele_trigger(Event, Start, End)`: one clause per (event pattern, rule step) that
    reacts to Event. The runtime calls every matching clause for each event.
  - `ele_untrigger(Event, Start, End)`: the same for deletion (thesis Algorithm 2).
  - `ele_store(Name, Arity, Window)`: the dynamic predicates that hold partial matches
    of windowed steps, with the window in seconds. The last two arguments of a stored
    partial match are its start and end time.
  - `ele_printed(Event)`: which derived events are written to the output (print_trigger).
  - `ele_declaration(Goal)`: start-up declarations of the program (subscriptions...), run
    in order when the program is loaded.

Every processed event (input or derived, added or retracted) is also passed to the output
hooks registered with rtl_add_output_hook/1 (subscriptions use this).

The clock is the largest end time processed so far (event time, so replayed data behaves
like live data). A stored partial match whose start lies more than Window + max_delay
before the clock can no longer be part of any match with an event that respects the
delay bound, and is removed by the periodic sweep; it is kept for deletions and late
events until the retraction horizon has passed (rtl_horizon.pl, which also decides whether a
deletion is too late).
*/

:- use_module(library(assoc)).
:- reexport(rtl_flags).
:- use_module(rtl_io).
:- use_module(rtl_horizon).
:- use_module(rtl_timers).
:- use_module(rtl_time, [rtl_beyond_bound/3]).

:- dynamic rtl_output_record/1.        % event(Event, Start, End, Consumer, Op) or json(Line)
:- dynamic output_hook/1.
:- dynamic type_output_hook/2.              % type_output_hook(Skeleton, Hook)
:- dynamic counter_key_of/2.                % counter_key_of(Rule, GlobalKey)
:- dynamic dispatch_of/2.                   % dispatch_of(Skeleton, quiet | used)
:- meta_predicate rtl_dry_run(0, -, -).
:- meta_predicate rtl_add_output_hook(4), rtl_remove_output_hook(4),
                  rtl_add_type_output_hook(+, 4), rtl_remove_type_output_hook(+, 4).
%!  rtl_use_program(+Module) is det.
%
%   Make Module (a compiled Retalis program) the program that processes events.

rtl_use_program(Module) :-
    (   rtl_program(Old) -> true ; Old = [] ),
    forall(program_hook(Old, Module), true),
    nb_setval(rtl_program, Module),
    rtl_timers_program(Module),
    rtl_reset,
    latest_start_known(Module).

%!  rtl_program(-Module) is semidet.

rtl_program(Module) :-
    nb_current(rtl_program, Module),
    Module \== [].

%!  rtl_reset is det.
%
%   Forget the clock, statistics and pending output (not the partial matches).

rtl_reset :-
    nb_setval(rtl_clock, -inf),
    empty_assoc(NoIntervals),
    nb_setval(rtl_longest_by_type, NoIntervals),
    nb_setval(rtl_blockers_swept_by_type, NoIntervals),
    nb_setval(rtl_next_sweep, inf),
    nb_setval(rtl_replay_position, none),       % no policy step is being replayed (rtl_policy.pl)
    rtl_reset_counters,
    rtl_dispatch_changed,
    nb_setval(rtl_late_sweep, 64),
    forget_detections,
    forget_blocker_sweeps,
    rtl_horizon_reset,
    retractall(rtl_output_record(_)),
    rtl_take_warnings(_),
    (   nb_current(rtl_output_sink, _) -> true ; nb_setval(rtl_output_sink, print) ),
    schedule_sweep.

%!  rtl_clear is det.
%
%   Forget everything the program has seen: partial matches, memory records, clock,
%   statistics, output.

rtl_clear :-
    nb_getval(rtl_program, M),
    forall(M:ele_partial_store(Name, Arity),
           ( functor(Head, Name, Arity), retractall(M:Head) )),
    forall(clear_hook, true),
    rtl_reset,
    nb_setval(rtl_latest_start, -inf).

%!  clear_hook is det.
%
%   Multifile: other runtime modules forget what they keep of the events seen (rtl_clear/0).

:- multifile clear_hook/0.

%!  program_hook(+Old, +New) is nondet.
%
%   Multifile: rtl_use_program/1 switches from program Old (`[]` for none) to New; other
%   runtime modules switch what they keep per program (rtl_seen.pl).

:- multifile program_hook/2.

%!  expiry_hook(+Clock) is nondet.
%
%   Multifile: the clock moved to Clock, past the time in the global `rtl_slr_next_expiry`
%   (rtl_slr.pl forgets the memory records that expire).

:- multifile expiry_hook/1.

% A new delay bound or retraction horizon moves the next sweep (rtl_flags.pl).
:- multifile rtl_flags:flag_changed_hook/2.
rtl_flags:flag_changed_hook(Flag, _) :-
    memberchk(Flag, [max_delay, retraction_horizon]),
    schedule_sweep.
rtl_flags:flag_changed_hook(echo_input, _) :-             % echoed input is used (event_dispatch/2)
    rtl_dispatch_changed.

%!  rtl_set_action_output(+Target) is det.
%
%   Where the text that program code prints while events are processed goes (actions,
%   conditions, static rules): `user_error` (the default) or a file name, opened for
%   writing (UTF-8). Standard output carries only the output JSON Lines.

rtl_set_action_output(Target) :-
    rtl_close_action_output,
    (   Target == user_error
    ->  true
    ;   open(Target, write, Stream, [encoding(utf8)]),
        nb_setval(rtl_action_stream, Stream)
    ).

%!  rtl_action_stream(-Stream) is det.

rtl_action_stream(Stream) :-
    (   nb_current(rtl_action_stream, S), S \== []
    ->  Stream = S
    ;   Stream = user_error
    ).

%!  rtl_close_action_output is det.
%
%   Close the action output file, if any; printed text goes to standard error again.

rtl_close_action_output :-
    (   nb_current(rtl_action_stream, S), S \== []
    ->  nb_setval(rtl_action_stream, []),
        close(S)
    ;   true
    ).

%!  rtl_clock(-Clock:number) is det.

rtl_clock(Clock) :-
    nb_getval(rtl_clock, Clock).

%!  rtl_event(+Event, +Start:number, +End:number) is det.
%
%   Process one input event: derive everything it completes, deliver the results. An
%   event that nothing can use (quiet_event/2: no rule or hook takes its type, input is not
%   echoed, and it passes no sweep, timer or memory expiry) costs one look-up of its type's
%   dispatch: it moves the clock and counts, no more.
%
%   The clock, the counters and the other numbers kept in global variables on every event
%   are set with nb_linkval/2: for a number it is nb_setval/2 without the copy (nb_setval/2
%   is duplicate_term/2 and nb_linkval/2, and the link survives backtracking as the copy does).

rtl_event(Event, Start, End) :-
    nb_getval(rtl_clock, Clock0),
    (   End > Clock0,
        quiet_event(Event, End)
    ->  nb_linkval(rtl_clock, End),
        nb_getval(rtl_stat_events, N0),
        N is N0 + 1,
        nb_linkval(rtl_stat_events, N)
    ;   used_event(Event, Start, End, Clock0)
    ).

% An event in time order that nothing can use: its type is `quiet` (event_dispatch/2) and
% the clock it moves to passes no sweep, timer or memory expiry. It only moves the clock and
% counts. Its duration and start matter only to the rules that take its type
% (note_duration/3, rtl_started_after/1).
quiet_event(Event, End) :-
    event_dispatch(Event, quiet),
    no_sweep_due(End),
    \+ ( nb_current(rtl_next_timer, Due), number(Due), Due =< End ),
    \+ ( nb_current(rtl_slr_next_expiry, Expiry), Expiry < End ).

% The clock moving to End with one more event starts no sweep (periodic_sweep/0).
no_sweep_due(End) :-
    nb_getval(rtl_next_sweep, Sweep),
    (   End < Sweep
    ->  true
    ;   nb_getval(rtl_stat_events, Events),
        nb_getval(rtl_sweep_after, After),
        Events + 1 < After
    ).

% The dispatch of an event's type: `quiet` when no rule reacts to it (no ele_trigger/3
% clause), no hook takes it (a memory, a subscription: hooks of its type or of every type)
% and input is not echoed; else `used`. Found on the first event of the type and kept in
% dispatch_of/2, looked up by first-argument indexing on the event itself. Whatever adds
% or removes triggers or hooks, or turns echo on, forgets it (rtl_dispatch_changed/0).
event_dispatch(Event, Dispatch) :-
    (   dispatch_of(Event, Known)
    ->  Dispatch = Known
    ;   nb_getval(rtl_program, M),
        (   \+ clause(M:ele_trigger(Event, _, _), _),
            \+ type_output_hook(Event, _),
            \+ nb_current(rtl_output_hooks, true),
            \+ nb_current(rtl_echo_input, true)
        ->  Known = quiet
        ;   Known = used
        ),
        type_skeleton(Event, Skeleton),
        assertz(dispatch_of(Skeleton, Known)),
        Dispatch = Known
    ).

%!  rtl_dispatch_changed is det.
%
%   Triggers or type hooks were added or removed (rules changed, a snapshot was restored):
%   the dispatch of every type is found again (rtl_event/3).

rtl_dispatch_changed :-
    retractall(dispatch_of(_, _)).

used_event(Event, Start, End, Clock0) :-
    (   End > Start -> note_duration(Event, Start, End) ; true ),
    (   nb_current(rtl_latest_start, Latest), Start > Latest     % note_start/1, inline
    ->  nb_linkval(rtl_latest_start, Start)
    ;   true
    ),
    (   End > Clock0
    ->  nb_linkval(rtl_clock, End),
        (   nb_current(rtl_slr_next_expiry, Expiry), Expiry < End   % a memory record to forget
        ->  forall(expiry_hook(End), true)
        ;   true
        ),
        (   nb_current(rtl_next_timer, Due), Due < End      % a timer due before the event
        ->  rtl_timers_run(before)
        ;   true
        )
    ;   late_check(End, Clock0)
    ),
    nb_getval(rtl_stat_events, N0),
    N is N0 + 1,
    nb_linkval(rtl_stat_events, N),
    (   nb_current(rtl_echo_input, true) -> rtl_emit(Event, Start, End, echo(input), add) ; true ),
    (   type_output_hook(Event, Hook), call(Hook, Event, Start, End, add), fail ; true ),
    (   nb_current(rtl_output_hooks, true) -> run_hooks_of_every_type(Event, Start, End, add) ; true ),
    nb_getval(rtl_program, M),
    (   M:ele_trigger(Event, Start, End), fail ; true ),   % forall/2 without its meta-call
    nb_getval(rtl_clock, Clock),
    (   nb_current(rtl_next_timer, Next), Next =< Clock  % due now, or set by the event
    ->  rtl_timers_run(after)
    ;   true
    ),
    nb_getval(rtl_next_sweep, Sweep),
    (   End >= Sweep -> periodic_sweep ; true ).

% The longest interval of an event of each type (Name/Arity) seen so far, in the assoc
% rtl_longest_by_type: with the delay bound, it says how early a later event of that type can
% start (the sweep of negation blockers, rtl_blockers_due/4).  Only an event longer than any
% before it of its type can start before the time up to which a sweep dropped blockers for
% that type (rtl_blockers_swept_by_type); one that does, arriving within the delay bound, is
% counted late: a match it would have made with a waiting partial match the sweep dropped is
% missing (no longest interval is known in advance).
note_duration(Event, Start, End) :-
    (   End - Start > 0
    ->  Duration is End - Start,
        functor(Event, Name, Arity),
        nb_getval(rtl_longest_by_type, Longest0),
        (   get_assoc(Name/Arity, Longest0, Longest), Longest >= Duration
        ->  true
        ;   put_assoc(Name/Arity, Longest0, Duration, Longest1),
            nb_setval(rtl_longest_by_type, Longest1),
            started_before_sweep(Name/Arity, Start, End)
        )
    ;   true
    ).

started_before_sweep(Type, Start, End) :-
    nb_getval(rtl_blockers_swept_by_type, Swept),
    (   get_assoc(Type, Swept, Before),
        Start < Before,
        \+ beyond_delay(End)
    ->  rtl_count(late)
    ;   true
    ).

beyond_delay(End) :-
    rtl_flag(max_delay, Delay),
    nb_getval(rtl_clock, Clock),
    rtl_beyond_bound(End, Clock, Delay).

%!  rtl_started_after(+Time:number) is semidet.
%
%   Some event given to the program's rules so far (input, derived or internal) started
%   after Time, or that is not known. Every stored partial match starts when one of its
%   events starts, so when this fails no stored match starts after Time: a `seq` step skips
%   the search for a right partner of a left instance ending at Time (in a stream in time
%   order, none can follow it). The latest start is known from a moment when the stores
%   were empty (rtl_use_program/1, rtl_clear/0); a snapshot restores it with the stores.

rtl_started_after(Time) :-
    (   nb_current(rtl_latest_start, Latest)
    ->  Latest > Time
    ;   true
    ).

% The latest start, when known (it is not after a restore from a snapshot without it).
note_start(Start) :-
    (   nb_current(rtl_latest_start, Latest), Start > Latest
    ->  nb_linkval(rtl_latest_start, Start)
    ;   true
    ).

% A program taken into use with empty stores: from now on the latest start is known. With
% stored matches (another program was used meanwhile) it is not.
latest_start_known(M) :-
    (   \+ ( M:ele_partial_store(Name, Arity), functor(Head, Name, Arity), once(M:Head) )
    ->  nb_setval(rtl_latest_start, -inf)
    ;   nb_current(rtl_latest_start, _)
    ->  nb_delete(rtl_latest_start)
    ;   true
    ).

%!  rtl_advance_clock(+Time:number) is det.
%
%   A heartbeat: the clock moves to Time without an event (the live driver advances it with
%   the wall clock while no event arrives), so the timers it passes fire (rtl_timers.pl). A
%   Time not after the clock changes nothing.

rtl_advance_clock(Time) :-
    must_be(number, Time),
    nb_getval(rtl_clock, Clock0),
    (   Time > Clock0
    ->  nb_setval(rtl_clock, Time),
        (   nb_current(rtl_slr_next_expiry, Expiry), Expiry < Time
        ->  forall(expiry_hook(Time), true)
        ;   true
        ),
        rtl_timers_run(after),
        nb_getval(rtl_next_sweep, Next),
        (   Time >= Next -> periodic_sweep ; true )
    ;   true
    ).

%!  rtl_future_problem(+End:number, -Problem:string) is semidet.
%
%   An input event (or clock line) ending at End lies too far in the future to be taken:
%   more than the flag `max_future` seconds after the clock and after the wall clock. The
%   first event of a run (no clock yet) is measured against the wall clock alone, so that a
%   time base of its own (seconds from 0) or of the epoch (ROS stamps) both start freely,
%   while a time such as 1e300, after which every event would be late, is refused.

rtl_future_problem(End, Problem) :-
    rtl_flag(max_future, Max),
    Max \== inf,
    nb_getval(rtl_clock, Clock),
    get_time(Now),
    End > max(Clock, Now) + Max,
    (   integer(Max)
    ->  format(string(Problem), "time ~w is more than ~D seconds after the clock (max_future)", [End, Max])
    ;   format(string(Problem), "time ~w is more than ~w seconds after the clock (max_future)", [End, Max])
    ).

% A late event counts; every `late_sweep` of them the stores are swept (the clock-driven
% sweep never runs while only late events come: after one far in the future, their partial
% matches would pile up, and each event would search them all). The next sweep waits for as
% many late events as the stores hold matches, at least 64: sweeps cost one event each.
late_check(End, Clock) :-
    rtl_flag(max_delay, Delay),
    (   rtl_beyond_bound(End, Clock, Delay)
    ->  rtl_count(late),
        (   nb_current(rtl_late_sweep, Due) -> true ; Due = 64 ),
        nb_getval(rtl_stat_late, Late),
        (   Late >= Due
        ->  rtl_collect_garbage(whole),
            rtl_store_size(Size),
            Next is Late + max(64, Size),
            nb_setval(rtl_late_sweep, Next)
        ;   true
        )
    ;   true
    ).

%!  rtl_retract_event(+Event, +Start, +End) is det.
%
%   Delete a previously added input event and everything derived from it. A deletion
%   outside the retraction horizon (rtl_horizon.pl) changes nothing: it is counted as
%   `too_late` and reported by a warning (rtl_take_warnings/1) with what it would have
%   taken back.

rtl_retract_event(Event, Start, End) :-
    nb_getval(rtl_program, M),
    (   rtl_retraction_too_late(End)
    ->  rtl_count(too_late),
        rtl_dry_run(M:ele_untrigger(Event, Start, End), Retracted, Derived),
        rtl_too_late_text(End, Retracted, Derived, Text),
        rtl_warning(Text)
    ;   rtl_count(retracted),
        (   nb_current(rtl_echo_input, true) -> rtl_emit(Event, Start, End, echo(input), retract) ; true ),
        run_output_hooks(Event, Start, End, retract),
        (   M:ele_untrigger(Event, Start, End), fail ; true )
    ).

%!  rtl_derived(+Event, +Start, +End) is det.
%
%   Called by compiled rules when they derive Event: deliver it and feed it back in.

rtl_derived(Event, Start, End) :-
    nb_getval(rtl_stat_derived, D0),                            % rtl_count/1, inline
    D is D0 + 1,
    nb_linkval(rtl_stat_derived, D),
    (   End > Start -> note_duration(Event, Start, End) ; true ),
    (   nb_current(rtl_latest_start, Latest), Start > Latest     % note_start/1, inline
    ->  nb_linkval(rtl_latest_start, Start)
    ;   true
    ),
    nb_getval(rtl_program, M),
    (   M:ele_printed(Event) -> rtl_emit(Event, Start, End, -, add) ; true ),
    run_output_hooks(Event, Start, End, add),
    (   M:ele_trigger(Event, Start, End), fail ; true ).

%!  rtl_internal_event(+Event, +Start, +End) is det.
%
%   An event of the runtime itself (memory events): matched by event rules and
%   subscriptions, but not counted, not written as output and not moving the clock.

rtl_internal_event(Event, Start, End) :-
    note_duration(Event, Start, End),
    note_start(Start),
    run_output_hooks(Event, Start, End, add),
    nb_getval(rtl_program, M),
    (   M:ele_trigger(Event, Start, End), fail ; true ).

%!  rtl_underived(+Event, +Start, +End) is det.
%
%   Called by compiled delete rules when a derived event loses its support.

rtl_underived(Event, Start, End) :-
    rtl_count(underived),
    nb_getval(rtl_program, M),
    (   M:ele_printed(Event) -> rtl_emit(Event, Start, End, -, retract) ; true ),
    run_output_hooks(Event, Start, End, retract),
    (   M:ele_untrigger(Event, Start, End), fail ; true ).

%!  rtl_add_output_hook(:Hook) is det.
%!  rtl_remove_output_hook(:Hook) is det.
%
%   call(Hook, Event, Start, End, Op) runs for every processed event, input or derived,
%   with Op `add` or `retract`, right after the event is delivered to the output.

rtl_add_output_hook(Hook) :-
    (   output_hook(Hook) -> true ; assertz(output_hook(Hook)) ),
    nb_setval(rtl_output_hooks, true),
    rtl_dispatch_changed.

% Removing a hook that is not there changes nothing, not even the globals a snapshot holds
% (a restore that tidies the hooks of an idle module must leave the state it restored).
rtl_remove_output_hook(Hook) :-
    (   output_hook(Hook)
    ->  retractall(output_hook(Hook)),
        (   output_hook(_) -> true ; nb_setval(rtl_output_hooks, false) ),
        rtl_dispatch_changed
    ;   true
    ).

%!  rtl_add_type_output_hook(+Pattern, :Hook) is det.
%!  rtl_remove_type_output_hook(+Pattern, :Hook) is det.
%
%   As rtl_add_output_hook/1, for the events of Pattern's type (name and arity) only. The
%   hooks of a type are found by first-argument indexing on the event itself, so events
%   of other types do not pay for them (SLR memory instances use this). They run before
%   the hooks of every type.

rtl_add_type_output_hook(Pattern, Hook) :-
    type_skeleton(Pattern, Skeleton),
    (   type_output_hook(Skeleton, Hook) -> true ; assertz(type_output_hook(Skeleton, Hook)) ),
    rtl_dispatch_changed.

rtl_remove_type_output_hook(Pattern, Hook) :-
    type_skeleton(Pattern, Skeleton),
    retractall(type_output_hook(Skeleton, Hook)),
    rtl_dispatch_changed.

%!  rtl_dry_run(:Goal, -Retracted:integer, -Derived:integer) is det.
%
%   Run Goal without effect: outputs, output hooks and actions are off, and every change of
%   the database is undone. Retracted and Derived count the derived events Goal would have
%   taken back and derived.
%
%   Nothing on the path of ordinary events checks for a dry run: the output goes to the
%   buffer (rtl_ele keeps buffered outputs as clauses, undone), the output hooks are removed
%   inside the snapshot (undone) and switched off, and the counters of rtl_ele are put back;
%   only rtl_action/1 checks rtl_dry_running/0.

rtl_dry_run(Goal, Retracted, Derived) :-
    Saved = [rtl_output_sink, rtl_output_hooks, rtl_stat_derived, rtl_stat_underived],
    findall(Key-Value, ( member(Key, Saved), nb_current(Key, Value) ), Values),
    rtl_stat(derived, Derived0),
    rtl_stat(underived, Retracted0),
    setup_call_cleanup(( nb_setval(rtl_dry_run, true),
                         nb_setval(rtl_output_sink, buffer),
                         nb_setval(rtl_output_hooks, false) ),
                       snapshot(( rtl_remove_type_output_hooks,
                                  forall(Goal, true),
                                  rtl_stat(derived, Derived1),
                                  rtl_stat(underived, Retracted1) )),
                       ( nb_setval(rtl_dry_run, false),
                         forall(member(Key-Value, Values), nb_setval(Key, Value)) )),
    Derived is Derived1 - Derived0,
    Retracted is Retracted1 - Retracted0.

%!  rtl_dry_running is semidet.
%
%   A dry run (rtl_dry_run/3) is going on.

rtl_dry_running :-
    nb_current(rtl_dry_run, true).

%!  rtl_remove_type_output_hooks is det.
%
%   Remove the hooks of every type (inside the snapshot of a dry run, rtl_dry_run/3).

rtl_remove_type_output_hooks :-
    retractall(type_output_hook(_, _)),
    rtl_dispatch_changed.

type_skeleton(Pattern, Skeleton) :-
    (   compound(Pattern)
    ->  compound_name_arity(Pattern, Name, Arity),
        compound_name_arity(Skeleton, Name, Arity)
    ;   Skeleton = Pattern
    ).

% (rtl_event/3 runs the hooks of the event's type inline.)
run_output_hooks(Event, Start, End, Op) :-
    (   type_output_hook(Event, Hook), call(Hook, Event, Start, End, Op), fail ; true ),
    (   nb_current(rtl_output_hooks, true)
    ->  run_hooks_of_every_type(Event, Start, End, Op)
    ;   true
    ).

run_hooks_of_every_type(Event, Start, End, Op) :-
    forall(output_hook(Hook), call(Hook, Event, Start, End, Op)).

%!  rtl_output_to(+Sink) is det.
%
%   Sink is `print` (write each line to current output as it is produced) or `buffer`
%   (keep the outputs, as data, until rtl_take_output_data/1, rtl_take_output_records/1 or
%   rtl_take_output/1).

rtl_output_to(Sink) :-
    must_be(oneof([print, buffer]), Sink),
    nb_setval(rtl_output_sink, Sink).

%!  rtl_emit(+Event, +Start, +End, +Consumer, +Op) is det.
%
%   Deliver one output: with sink `print` its line (the JSON Lines format of
%   docs/runtime.md, "Output"), with sink `buffer` the record
%   `event(Event, Start, End, Consumer, Op)`: data, written when it is taken.

rtl_emit(Event, Start, End, Consumer, Op) :-
    nb_getval(rtl_output_sink, Sink),
    (   Sink == buffer
    ->  assertz(rtl_output_record(event(Event, Start, End, Consumer, Op)))
    ;   Consumer == (-), Op \== retract,
        rtl_write_event_line(user_output, Event, Start, End)      % the common case, in C
    ->  true
    ;   rtl_event_json(Event, Start, End, Consumer, Op, Line),
        format(user_output, "~s~n", [Line])     % one call: the step limit cannot split a line
    ).

%!  rtl_emit_line(+Line:string) is det.
%
%   Deliver one output line given as JSON text (answers of synchronized queries). With
%   sink `print` the line goes to `user_output`, whatever the current output is (the
%   entry points send the text program code prints elsewhere); with `buffer` it is kept as
%   the record `json(Line)`.

rtl_emit_line(Line) :-
    nb_getval(rtl_output_sink, Sink),
    (   Sink == print
    ->  format(user_output, "~s~n", [Line])
    ;   assertz(rtl_output_record(json(Line)))
    ).

%!  rtl_take_output_records(-Records:list) is det.
%
%   The buffered outputs in order, as records (rtl_emit/5, rtl_emit_line/1); the buffer is
%   emptied.

rtl_take_output_records(Records) :-
    findall(R, retract(rtl_output_record(R)), Records).

%!  rtl_take_output_data(-Lines:list(string)) is det.
%
%   The buffered outputs as data (rtl_output_data/2, the form in which they cross to
%   Python): `[Data]`, or `[]` when there are none; the buffer is emptied.

rtl_take_output_data(Lines) :-
    rtl_take_output_records(Records),
    (   Records == []
    ->  Lines = []
    ;   rtl_output_data(Records, Json),
        Lines = [Json]
    ).

%!  rtl_take_output(-Lines:list(string)) is det.
%
%   The buffered outputs in order as their output lines; the buffer is emptied.

rtl_take_output(Lines) :-
    rtl_take_output_records(Records),
    maplist(rtl_output_record_line, Records, Lines).

%!  rtl_output_pending is semidet.
%
%   Some buffered output waits to be taken.

rtl_output_pending :-
    rtl_output_record(_),
    !.

%!  rtl_detected(+Rule:atom) is det.
%
%   Called by the compiled rules for each complete match of rule Rule (its label, `r1` or
%   its own) that passed its conditions: counts it (rtl_detections/1). One global variable
%   per rule, `rtl_detected Rule`, reset with the other counters.

rtl_detected(Rule) :-
    counter_key(Rule, Key),
    (   nb_current(Key, N0) -> N is N0 + 1 ; N = 1 ),
    nb_linkval(Key, N).

% The global variable of a rule's count: made once per rule and kept in counter_key_of/2
% (looking it up costs a third of making it with atom_concat/3 at every detection).
counter_key(Rule, Key) :-
    (   counter_key_of(Rule, Key)
    ->  true
    ;   atom_concat('rtl_detected ', Rule, Key),
        assertz(counter_key_of(Rule, Key))
    ).

%!  rtl_detections(-Pairs:list(pair)) is det.
%
%   Rule-Count for every rule that detected something since the counters were reset,
%   in the standard order of the rules' labels.

rtl_detections(Pairs) :-
    findall(Rule-N, ( detection_key(Key, Rule), nb_current(Key, N) ), Pairs0),
    msort(Pairs0, Pairs).

detection_key(Key, Rule) :-
    nb_current(Key, _),
    atom(Key),
    atom_concat('rtl_detected ', Rule, Key).

forget_detections :-
    findall(Key, detection_key(Key, _), Keys),
    maplist(nb_delete, Keys).

%!  rtl_store_size(-Clauses:integer) is det.
%
%   The number of partial matches currently stored by all steps of the program.

rtl_store_size(Size) :-
    nb_getval(rtl_program, M),
    aggregate_all(sum(N),
                  ( M:ele_partial_store(Name, Arity),
                    functor(Head, Name, Arity),
                    predicate_property(M:Head, number_of_clauses(N))
                  ),
                  Size).

%!  rtl_collect_garbage is det.
%!  rtl_collect_garbage(+Scan) is det.
%
%   Retire the partial matches of windowed steps that can no longer take part in a match
%   with an event within the delay bound (their start lies more than Window + max_delay
%   before the clock): they are kept for deletions and late events, and dropped when the
%   retraction horizon has passed (rtl_horizon.pl).

rtl_collect_garbage :-
    rtl_collect_garbage(stored_order).

% Scan `stored_order`: a store kept oldest first is scanned to its first match that stays
% (rtl_retire_store/5); `whole`: to its end, for the sweep of late events, whose matches
% come after those of later events.
rtl_collect_garbage(Scan) :-
    nb_getval(rtl_program, M),
    nb_getval(rtl_clock, Clock),
    rtl_flag(max_delay, Delay),
    (   Delay == inf
    ->  true
    ;   forall(M:ele_store(Name, Arity, Window),
               ( Before is Clock - Window - Delay,
                 rtl_retire_store(M, Name, Arity, Before, Scan) )),
        rtl_forget_kept(M, Clock),
        forget_blockers(M, Clock),
        rtl_swept(Clock)
    ),
    schedule_next_sweep.

% Negated events of unwindowed negations that can no longer block anything, with the waiting
% partial matches they block for good (the compiled `ele_forget_blockers/1`, one clause per
% negation, each of which asks rtl_blockers_due/4 whether its sweep is due).
forget_blockers(M, Clock) :-
    (   predicate_property(M:ele_forget_blockers(_), number_of_clauses(N)), N > 0
    ->  forall(M:ele_forget_blockers(Clock), true)
    ;   true
    ).

%!  rtl_blockers_due(+Step, +Partner, +Clock, -Before) is semidet.
%
%   The sweep of the blockers of Step, a negation whose right operand is an event of type
%   Partner (Name/Arity), is due at Clock; Before is the time before which a negated event
%   that ended can block nothing more: no later Partner starts before it (the delay bound and
%   the longest interval of a Partner seen so far) and it lies outside the retraction horizon.
%   That keeps a negated event Keep = Clock - Before seconds after its end. The compiled
%   sweep visits every stored negated event of Step, so it is due once the clock has moved on
%   by Keep / 2 since the last one (a global variable per step): a negated event is dropped at
%   most 1.5 Keep after its end and visited about twice. Keep depends on the Partner's own
%   intervals, not on those of other events (a derived event can span a thousand times the
%   delay bound). A Partner longer than any before it may start before Before: it is counted
%   late (note_duration/3).

rtl_blockers_due(Step, Partner, Clock, Before) :-
    rtl_flag(max_delay, Delay),
    Delay \== inf,
    rtl_horizon(Horizon),
    Horizon \== inf,
    nb_getval(rtl_longest_by_type, ByType),
    (   get_assoc(Partner, ByType, Longest) -> true ; Longest = 0 ),
    Keep is max(Delay + Longest, Horizon),
    atom_concat('rtl_blockers_due ', Step, Key),
    (   nb_current(Key, Due)
    ->  Clock >= Due
    ;   true
    ),
    Before is Clock - Keep,
    Due1 is Clock + Keep / 2,
    nb_setval(Key, Due1),
    nb_getval(rtl_blockers_swept_by_type, Swept0),
    (   get_assoc(Partner, Swept0, Before0), Before0 >= Before
    ->  true
    ;   put_assoc(Partner, Swept0, Before, Swept1),
        nb_setval(rtl_blockers_swept_by_type, Swept1)
    ).

forget_blocker_sweeps :-
    forall(( nb_current(Key, _), atom(Key), sub_atom(Key, 0, _, _, 'rtl_blockers_due ') ),
           nb_delete(Key)).

% The next sweep is due when the clock has moved on by half of the smallest window plus
% the delay bound: every stored match is then at most 1.5 times as old as it needs to be.
% A program without windowed stores that keeps records for deletions (consumption
% policies) sweeps them every half retraction horizon.
schedule_sweep :-
    rtl_flag(max_delay, Delay0),
    rtl_flag(retraction_horizon, HorizonFlag),
    (   nb_current(rtl_program, M0) -> true ; M0 = [] ),
    rtl_horizon_setup(M0, Delay0, HorizonFlag),
    schedule_next_sweep.

schedule_next_sweep :-
    (   nb_current(rtl_program, M), M \== [],
        rtl_flag(max_delay, Delay), Delay \== inf,
        sweep_period(M, Delay, Period, MinEvents)
    ->  nb_getval(rtl_clock, Clock),
        Step is max(Period / 2, 1.0e-3),
        (   Clock =:= -inf -> Next = -inf ; Next is Clock + Step )
    ;   Next = inf, MinEvents = 0
    ),
    nb_getval(rtl_stat_events, Events),
    SweepAfter is Events + MinEvents,
    nb_setval(rtl_sweep_after, SweepAfter),
    nb_setval(rtl_next_sweep, Next).

% A program with windowed stores sweeps every half of its smallest window plus the delay
% bound; one whose only forgettable stores are records kept for deletions (consumption
% policies without windows) every half retraction horizon, but only once 64 events came
% since the last sweep: its horizon may be as short as the delay bound, and a sweep per
% event would cost more than the few records it drops.
sweep_period(M, Delay, Period, MinEvents) :-
    (   aggregate_all(min(W), M:ele_store(_, _, W), MinWindow)
    ->  Period is MinWindow + Delay,
        MinEvents = 0
    ;   rtl_horizon(H), H \== inf
    ->  Period = H,
        MinEvents = 64
    ).

periodic_sweep :-
    nb_getval(rtl_stat_events, Events),
    nb_getval(rtl_sweep_after, After),
    (   Events >= After -> rtl_collect_garbage ; true ).
