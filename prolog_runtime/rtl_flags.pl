:- module(rtl_flags,
          [ rtl_set_flag/2,             % +Flag, +Value
            rtl_valid_flag_value/2,     % +Flag, @Value
            rtl_flag/2,                 % ?Flag, ?Value
            rtl_max_steps/1,            % -Steps
            rtl_default_flags/0,
            rtl_stat/2,                 % ?Name, ?Value
            rtl_count/1,                % +Name
            rtl_stat_global/2,          % ?Name, ?Key
            rtl_reset_counters/0
          ]).

/** <module> The runtime's flags and counters, below every module that reads them

The flags of the runtime (rtl_set_flag/2, rtl_flag/2) and its counters of events (rtl_stat/2,
rtl_count/1), in a module of their own so that the modules below rtl_ele.pl (rtl_timers.pl,
rtl_horizon.pl, rtl_io.pl) read them without calling up into a module that imports them.
rtl_ele.pl re-exports all of this: the interface is rtl_ele's as before.

A flag's value is a fact of flag_value/2 (state: rtl_state.pl) or its default; a counter is
the global variable `rtl_stat_<Name>` (rtl_stat_global/2; state too). The modules that must
react when a flag changes declare flag_changed_hook/2 (rtl_ele.pl reschedules its sweep when
`max_delay` or `retraction_horizon` changes); the cap on event types is set here
(rtl_event_types.pl, below this module).
*/

:- use_module(rtl_event_types, [rtl_cap_event_types/1, rtl_forget_event_types/0]).
:- use_module(rtl_run_options, [rtl_run_option/5]).   % the defaults of the run options

:- dynamic flag_value/2.

%!  flag_changed_hook(+Flag, +Value) is nondet.
%
%   Multifile: called, every solution, after Flag was set to Value (rtl_set_flag/2).

:- multifile flag_changed_hook/2.

% The flags that are run options (max_delay, echo_input, max_steps, retraction_horizon,
% flush_timers, max_timers, max_event_types, max_line_bytes, max_digits, max_future) have
% their defaults in the table of run options (rtl_run_options.pl, from retalisc/run_options.py).
flag_default(Flag, Default) :-
    rtl_run_option(_, _, _, Default, flag(Flag)).
flag_default(event_consumption_policy, unrestricted).
flag_default(query_time_limit, 10).          % seconds a query from outside may run
flag_default(max_term_depth, 1000).         % nesting of input event terms

%!  rtl_set_flag(+Flag, +Value) is det.
%!  rtl_flag(?Flag, ?Value) is nondet.
%
%   Flags: `max_delay` (seconds, a non-negative number; `inf` keeps every partial match),
%   `echo_input` (true or false), `event_consumption_policy` (unrestricted, recent,
%   chronological), `query_time_limit` (seconds, a positive number), `max_steps` (the
%   inferences one input event may take, everything it derives included; `inf` for no
%   limit; default 1,000,000) and `max_term_depth` (how deep an input event term may be
%   nested; default 1,000), `max_timers` (how many timers may be pending, absences and
%   alarms; `inf` for no limit; default 100,000), `max_line_bytes` (the longest input line,
%   default 1,048,576 bytes), `max_digits` (the longest run of digits in an input line or
%   event text, default 4,300), `max_future` (seconds an input event may end after the
%   clock or the wall clock, the later of the two; default 86,400; rtl_future_problem/2)
%   and `retraction_horizon` (`auto`, seconds or `inf`: how long
%   deletions stay exact, at least max_delay plus the largest window; rtl_horizon.pl). A bad value raises a type or domain error and changes nothing.

rtl_set_flag(Flag, Value) :-
    (   flag_default(Flag, _)
    ->  true
    ;   domain_error(retalis_flag, Flag)
    ),
    (   rtl_valid_flag_value(Flag, Value)
    ->  true
    ;   var(Value)
    ->  instantiation_error(Value)
    ;   domain_error(Flag, Value)
    ),
    retractall(flag_value(Flag, _)),
    assertz(flag_value(Flag, Value)),
    (   Flag == echo_input -> nb_setval(rtl_echo_input, Value) ; true ),   % read on every event
    (   Flag == max_steps -> nb_setval(rtl_max_steps, Value) ; true ),     % read on every event
    (   Flag == max_event_types -> rtl_cap_event_types(Value) ; true ),
    forall(flag_changed_hook(Flag, Value), true).

rtl_flag(Flag, Value) :-
    atom(Flag),
    flag_value(Flag, V),                        % a flag set (every one, after rtl_default_flags/0):
    !,                                          % no search of the defaults (the sweeps ask often)
    Value = V.
rtl_flag(Flag, Value) :-
    flag_default(Flag, Default),
    (   flag_value(Flag, V) -> Value = V ; Value = Default ).

%!  rtl_valid_flag_value(+Flag, @Value) is semidet.
%
%   Value is a value Flag may take.

rtl_valid_flag_value(max_delay, V) :-
    (   V == inf -> true ; number(V), V >= 0, V =\= inf ).
rtl_valid_flag_value(echo_input, V) :-
    ( V == true ; V == false ), !.
rtl_valid_flag_value(flush_timers, V) :-
    ( V == true ; V == false ), !.
rtl_valid_flag_value(event_consumption_policy, V) :-
    atom(V), memberchk(V, [unrestricted, recent, chronological]).
rtl_valid_flag_value(query_time_limit, V) :-
    number(V), V > 0, V =\= inf.
rtl_valid_flag_value(retraction_horizon, V) :-
    (   V == auto -> true ; V == inf -> true ; number(V), V >= 0, V =\= inf ).
rtl_valid_flag_value(max_steps, V) :-
    (   V == inf -> true ; integer(V), V > 0 ).
rtl_valid_flag_value(max_timers, V) :-
    (   V == inf -> true ; integer(V), V > 0 ).
rtl_valid_flag_value(max_event_types, V) :-
    (   V == inf -> true ; integer(V), V > 0 ).
rtl_valid_flag_value(max_line_bytes, V) :-
    (   V == inf -> true ; integer(V), V > 0 ).
rtl_valid_flag_value(max_future, V) :-
    (   V == inf -> true ; number(V), V >= 0, V =\= inf ).
rtl_valid_flag_value(max_digits, V) :-
    (   V == inf -> true ; integer(V), V > 0 ).
rtl_valid_flag_value(max_term_depth, V) :-
    (   V == inf -> true ; integer(V), V > 0 ).

%!  rtl_default_flags is det.
%
%   Every flag back to its default (a new Engine in a process where another ran).

rtl_default_flags :-
    retractall(flag_value(_, _)),
    nb_setval(rtl_echo_input, false),
    nb_setval(rtl_max_steps, []),
    rtl_forget_event_types.

%!  rtl_max_steps(-Steps) is det.
%
%   The flag `max_steps`, read on every input event.

rtl_max_steps(Steps) :-
    (   nb_current(rtl_max_steps, Steps0), Steps0 \== []
    ->  Steps = Steps0
    ;   rtl_flag(max_steps, Steps),
        nb_setval(rtl_max_steps, Steps)
    ).

%!  rtl_stat(?Name, ?Value) is nondet.
%
%   Counters: events, retracted, derived, underived, late, rejected (input lines refused),
%   failed (input events whose processing raised an error), too_late (deletions outside the
%   retraction horizon, not counted as retracted), timers_refused (timers not set because
%   `max_timers` were pending, rtl_timers.pl).

rtl_stat(Name, Value) :-
    rtl_stat_global(Name, Key),
    nb_getval(Key, Value).

%!  rtl_stat_global(?Name, ?Key) is nondet.
%
%   Key is the global variable of the counter Name (`rtl_stat_<Name>`), in the order
%   rtl_stat/2 gives the counters. rtl_ele.pl reads and sets the busiest ones in line.

rtl_stat_global(events, rtl_stat_events).
rtl_stat_global(retracted, rtl_stat_retracted).
rtl_stat_global(derived, rtl_stat_derived).
rtl_stat_global(underived, rtl_stat_underived).
rtl_stat_global(late, rtl_stat_late).
rtl_stat_global(rejected, rtl_stat_rejected).
rtl_stat_global(failed, rtl_stat_failed).
rtl_stat_global(too_late, rtl_stat_too_late).
rtl_stat_global(timers_refused, rtl_stat_timers_refused).

%!  rtl_count(+Name) is det.
%
%   One more of the counter Name.

rtl_count(Name) :-
    rtl_stat_global(Name, Key),
    !,
    nb_getval(Key, N0),
    N is N0 + 1,
    nb_linkval(Key, N).
rtl_count(Name) :-
    domain_error(rtl_counter, Name).

%!  rtl_reset_counters is det.
%
%   Every counter to 0.

rtl_reset_counters :-
    forall(rtl_stat_global(_, Key), nb_setval(Key, 0)).
