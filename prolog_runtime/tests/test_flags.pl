/*  plunit tests of rtl_flags.pl, the runtime's flags and counters, loaded alone (it stands
    below rtl_ele.pl and needs none of the modules above it):

        swipl -g run_tests -t halt prolog_runtime/tests/test_flags.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).

:- prolog_load_context(directory, Dir),
   directory_file_path(Dir, '../rtl_flags', Flags),
   use_module(Flags).

:- dynamic changed/2, capped/1.

%   The hooks a module above defines: recorded here.
:- multifile rtl_flags:flag_changed_hook/2, rtl_event_types:capped_hook/1.
rtl_flags:flag_changed_hook(Flag, Value) :-
    assertz(user:changed(Flag, Value)).
rtl_event_types:capped_hook(Capped) :-
    assertz(user:capped(Capped)).

fresh :-
    rtl_default_flags,
    rtl_reset_counters,
    retractall(changed(_, _)),
    retractall(capped(_)).

:- begin_tests(rtl_flags, [setup(fresh), cleanup(fresh)]).

test(defaults, [setup(fresh)]) :-
    rtl_flag(max_delay, D), assertion(D =:= 1.0),
    rtl_flag(max_steps, S), assertion(S == 1000000),
    rtl_max_steps(S1), assertion(S1 == 1000000),
    rtl_flag(retraction_horizon, H), assertion(H == auto),
    assertion(\+ rtl_flag(no_such_flag, _)),
    findall(F, rtl_flag(F, _), Fs), length(Fs, N), assertion(N == 13).

test(set_and_hook, [setup(fresh), cleanup(fresh)]) :-
    rtl_set_flag(max_delay, 2.5),
    rtl_flag(max_delay, D), assertion(D == 2.5),
    assertion(changed(max_delay, 2.5)),
    rtl_set_flag(max_steps, inf),
    rtl_max_steps(S), assertion(S == inf),
    rtl_set_flag(echo_input, true),
    nb_getval(rtl_echo_input, E), assertion(E == true),
    rtl_default_flags,
    rtl_flag(max_delay, D0), assertion(D0 =:= 1.0),
    rtl_max_steps(S0), assertion(S0 == 1000000),
    nb_getval(rtl_echo_input, E0), assertion(E0 == false).

% A bad value raises an error and changes nothing; no hook runs.
test(bad_values_change_nothing, [setup(fresh), cleanup(fresh),
        forall(member(Flag-Value-Error, [ max_delay-(-1)-domain_error(max_delay, -1),
                                          max_steps-0-domain_error(max_steps, 0),
                                          echo_input-maybe-domain_error(echo_input, maybe),
                                          max_delay-_-instantiation_error,
                                          nosuch-1-domain_error(retalis_flag, nosuch) ]))]) :-
    catch(rtl_set_flag(Flag, Value), error(E, _), true),
    assertion(subsumes_term(Error, E)),
    assertion(\+ changed(_, _)),
    (   Flag == nosuch -> true ; rtl_flag(Flag, V), assertion(\+ V == Value) ).

test(valid_values) :-
    assertion(rtl_valid_flag_value(retraction_horizon, inf)),
    assertion(rtl_valid_flag_value(retraction_horizon, 3)),
    assertion(\+ rtl_valid_flag_value(retraction_horizon, never)),
    assertion(\+ rtl_valid_flag_value(query_time_limit, 0)),
    assertion(\+ rtl_valid_flag_value(max_timers, 1.5)).

% The cap on event types is set through its flag: rtl_event_types hears it and tells its
% hook; `inf` takes it off.
test(event_type_cap, [setup(fresh), cleanup(fresh)]) :-
    rtl_set_flag(max_event_types, 2),
    assertion(capped(true)),
    nb_getval(rtl_max_event_types, M), assertion(M == 2),
    rtl_set_flag(max_event_types, inf),
    assertion(capped(false)),
    nb_getval(rtl_max_event_types, M1), assertion(M1 == inf).

test(counters, [setup(fresh), cleanup(fresh)]) :-
    findall(N-V, rtl_stat(N, V), Stats),
    assertion(Stats == [events-0, retracted-0, derived-0, underived-0, late-0, rejected-0,
                        failed-0, too_late-0, timers_refused-0]),
    rtl_count(late), rtl_count(late), rtl_count(rejected),
    rtl_stat(late, L), assertion(L == 2),
    rtl_stat(rejected, R), assertion(R == 1),
    rtl_stat_global(late, Key), assertion(Key == rtl_stat_late),
    nb_getval(Key, L1), assertion(L1 == 2),
    rtl_reset_counters,
    rtl_stat(late, L0), assertion(L0 == 0).

% Every counter lives in a global variable with the runtime's prefix.
test(counter_globals_prefixed) :-
    forall(rtl_stat_global(_, Key), assertion(sub_atom(Key, 0, _, _, rtl_))).

test(unknown_counter, [error(domain_error(rtl_counter, nosuch))]) :-
    rtl_count(nosuch).

:- end_tests(rtl_flags).
