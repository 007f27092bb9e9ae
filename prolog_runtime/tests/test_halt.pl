/*  plunit tests of rtl_halt.pl: `halt` called by program code. While an event is processed
    (rtl_raise_busy), halt/0,1 is cancelled and recorded, with the action it was in, and
    rtl_halt_check/0 raises it once; outside an event and a program's load a halt is not
    touched (checked in a child process, which must end with the status it asked for).

        swipl -g run_tests -t halt prolog_runtime/tests/test_halt.pl
*/
:- use_module(library(plunit)).
:- use_module(library(process)).
:- use_module('../rtl_halt').

during_an_event(Goal) :-
    setup_call_cleanup(nb_setval(rtl_raise_busy, true),
                       Goal,
                       nb_setval(rtl_raise_busy, false)).

:- begin_tests(rtl_halt).

test(nothing_to_report) :-
    nb_setval(rtl_halt_event, []),
    rtl_halt_check,
    assertion(\+ rtl_take_halted(_)).

test(a_halt_in_an_event_is_cancelled_and_raised_once) :-
    nb_setval(rtl_halt_event, []),
    during_an_event(( catch(halt, _, true) -> true ; true )),
    catch(( rtl_halt_check, Raised = none ), rtl_halted(Reason), Raised = Reason),
    assertion(Raised == "the program called halt"),
    rtl_halt_check.                                   % taken: not raised again

test(a_halt_in_an_action_names_the_action) :-
    nb_setval(rtl_halt_event, []),
    during_an_event(( rtl_action_context(user:alarm(kitchen), halt(3)) -> true ; true )),
    catch(( rtl_halt_check, Raised = none ), rtl_halted(Reason), Raised = Reason),
    assertion(Raised == "the program called halt (in the action alarm(kitchen))").

test(the_action_context_is_left_after_the_action) :-
    nb_setval(rtl_halt_event, []),
    during_an_event(( rtl_action_context(a, true), ( catch(halt, _, true) -> true ; true ) )),
    catch(( rtl_halt_check, Raised = none ), rtl_halted(Reason), Raised = Reason),
    assertion(Raised == "the program called halt").

test(the_runtime_s_own_exit_and_other_halts_pass) :-
    runtime_dir(Dir),
    forall(member(Goal-Status, ["rtl_halt:rtl_exit(3)"-3,
                                "halt(4)"-4,                               % not in an event: passes
                                "nb_setval(rtl_raise_busy, true), rtl_halt:rtl_exit(5)"-5]),
           ( format(atom(G), "use_module(rtl_halt), ~w", [Goal]),
             process_create(path(swipl), ['--no-packs', '-f', none, '-g', G, '-t', 'halt(99)'],
                            [cwd(Dir), process(Pid), stdout(null), stderr(null)]),
             process_wait(Pid, exit(Code)),
             assertion(Code == Status) )).

:- end_tests(rtl_halt).

runtime_dir(Dir) :-
    source_file(runtime_dir(_), File),
    file_directory_name(File, Tests),
    file_directory_name(Tests, Dir).
