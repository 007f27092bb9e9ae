:- module(retalis,
          [ rtl_program_loaded/1,       % +Module
            rtl_main/0,
            rtl_run_jsonl_file/1,       % +File
            rtl_run_event_file/4,       % +File, +AllowControl, +Strict, -Outcome
            rtl_feed_lines/3,           % +Text, +FirstLineNo, -Output
            rtl_feed_lines/4,           % +Text, +FirstLineNo, +Options, -Output
            rtl_process_line/3,         % +Line, +Options, -Outcome
            rtl_action/1,               % :Goal
            rtl_aggregate/4,            % +Function, +Acc0, -Acc, -Value
            rtl_aggregate_initial/2,    % +Function, -Value
            rtl_summary/1,              % -Text
            rtl_summary/2,              % +Seconds, -Text
            rtl_end_of_input/2,         % +Mode, -Output
            rtl_heartbeat/2             % +Time, -Output
          ]).
:- use_module(rtl_load, []).              % first: out-of-date .qlf files are not used
% The line loops (shared with rtl_api.pl): this module exports the ones above.
:- use_module(rtl_horizon, [rtl_aggregate/4, rtl_aggregate_initial/2]).   % exported here too
:- use_module(rtl_feed, [rtl_run_files/2, rtl_run_jsonl_file/1, rtl_run_event_file/4, rtl_feed_lines/3,
                         rtl_feed_lines/4, rtl_process_line/3, rtl_summary/1, rtl_summary/2,
                         rtl_end_of_input/2, rtl_heartbeat/2, rtl_output_gone/1, rtl_output_failed/2,
                         rtl_drop_output/0, rtl_stop_signal/2, error_text/2]).
:- reexport(rtl_ele).
:- reexport(rtl_io).
:- use_module(rtl_error_text, [rtl_error_text/2, rtl_term_text/2]).
:- use_module(rtl_guard, [rtl_is_reserved_ball/1]).
:- use_module(rtl_arguments, [rtl_read_arguments/2, rtl_usage_text/2]).
:- reexport(rtl_time).
:- reexport(rtl_raise).
:- reexport(rtl_subscriptions).
:- reexport(rtl_library).
:- reexport(rtl_rules).
:- reexport(rtl_slr).
:- reexport(rtl_query).
:- reexport(rtl_math).
:- reexport(rtl_sync).
:- reexport(rtl_api).
:- reexport(rtl_seen).
:- reexport(rtl_halt).
:- reexport(rtl_horizon).
:- reexport(rtl_policy).
:- reexport(rtl_timers).
:- reexport(rtl_sliding).
:- reexport(rtl_tf).

/** <module> Retalis runtime: the entry points of a compiled program

A compiled program (`retalisc compile P.rtl -o P.pl`) loads this module. It then runs in
two ways:

  - as a script, `swipl P.pl EVENTS.jsonl [...]`: rtl_main/0 reads the event files (or
    standard input for `-`) and writes the output JSON Lines to standard output, with
    rejected lines and a summary on standard error;
  - embedded (the Python driver): rtl_feed_lines/3 takes a batch and returns its outputs as
    data (rtl_output_data/2) and the lines not processed, as one string.
*/

:- meta_predicate rtl_action(0).

%!  rtl_program_loaded(+Module) is det.
%
%   Called by a compiled program when it has been loaded.

rtl_program_loaded(Module) :-
    get_time(Now),
    nb_setval(rtl_loaded_at, Now),
    rtl_use_program(Module),
    forall(Module:ele_declaration(Goal), run_declaration(Module, Goal)).

%!  rtl_declaration_handler(?Name, ?Arity, ?Module) is nondet.
%
%   Multifile: runtime modules that implement a start-up declaration Name/Arity (written as
%   a fact or directive in a program) add a clause; the goal is called as Module:Goal.

:- multifile rtl_declaration_handler/3.

run_declaration(Program, '$directive'(Where, Goal)) :-
    !,
    % a directive that calls the runtime, run here (after the runtime has taken the program
    % in) in program order; reported as the loader reports a directive
    (   catch(Program:Goal, Error, true)
    ->  (   var(Error)
        ->  true
        ;   error_text(Error, Text),
            format(user_error, "ERROR: ~w: directive raised: ~s~n", [Where, Text])
        )
    ;   format(user_error, "Warning: ~w: directive failed: ~q~n", [Where, Goal])
    ).
run_declaration(Program, Goal) :-
    functor(Goal, Name, Arity),
    (   rtl_declaration_handler(Name, Arity, Handler)
    ->  Handler:Goal
    ;   print_message(error, format("~w/~w is not supported by this runtime (in ~w)", [Name, Arity, Program]))
    ).

%!  rtl_main is det.
%
%   Script entry: process the event files named on the command line, in order. Does
%   nothing when the program is loaded by the Python driver (flag `retalis_embedded`).
%   The options (`--echo-input`, `--max-delay=SECONDS`, `--strict`, ...; docs/runtime.md,
%   "Running a compiled program") stand anywhere among the files; which there are and how
%   each is read is the table of run options (rtl_run_options.pl, written from
%   retalisc/run_options.py), read by rtl_arguments.pl. `--detections=L1,L2,...` writes the
%   detections per rule before the summary, the rules labelled L1, L2, ... first
%   (`retalisc run` hands its runs over with it). Exit status: 0 when the input was
%   processed (rejected and failed lines included), 1 when the run was stopped
%   (`--strict`, `halt` in program code, standard output cannot be written), 2 for usage
%   errors, 128 + N when the signal N (SIGTERM, SIGINT) ended it (stop_on_signal/1).

rtl_main :-
    current_prolog_flag(retalis_embedded, true),
    !.
rtl_main :-
    get_time(T0),
    nb_setval(rtl_run_started, T0),
    current_prolog_flag(argv, Argv),
    set_stream(user_output, encoding(utf8)),
    set_stream(user_error, encoding(utf8)),
    nb_setval(rtl_stream_options, []),
    catch(rtl_read_arguments(Argv, Files), error(Formal, _), (usage_error(Formal), rtl_exit(2))),
    (   Files == []
    ->  usage_error(no_event_file), rtl_exit(2)
    ;   true
    ),
    (   rtl_take_halted(Where)
    ->  format(user_error, "~s~n", [Where]),
        main_finish(1)
    ;   true
    ),
    forall(rtl_stop_signal(Signal, _), on_signal(Signal, _, retalis:stop_on_signal)),
    catch(rtl_run_files(Files, Status),
          Error,
          ( rtl_output_gone(Error)
          ->  output_gone_exit
          ;   rtl_output_failed(Error, Why)
          ->  output_failed_exit(Why)
          ;   error_text(Error, Text), format(user_error, "error: ~s~n", [Text]), Status = 1 )),
    main_finish(Status).

%   stop_on_signal(+Signal): SIGTERM or SIGINT ends the run as the end of the input would,
%   without the rest of the input: the event being processed is dropped where it is (the
%   handler runs between Prolog calls, and each output line is written by one call, so only
%   whole lines are in the output buffer), the output written so far is flushed, the summary
%   printed, and the process ends with status 128 + the signal's number, as a shell reports
%   a process the signal killed.

stop_on_signal(Signal) :-
    rtl_stop_signal(Signal, Number),
    Status is 128 + Number,
    catch(main_finish(Status), _, rtl_exit(Status)).

signal_while_finishing(_).              % the run ends already: the summary is not cut

%   output_failed_exit(+Why): writing standard output failed otherwise than by its reader
%   going away (rtl_output_failed/2: a full disk, `swipl OUT.pl FILE > /dev/full`). The run
%   ends with the line `retalis: cannot write standard output: Why`, the summary and status 1.

output_failed_exit(Why) :-
    format(user_error, "retalis: cannot write standard output: ~w~n", [Why]),
    rtl_drop_output,
    rtl_close_consumer_files,
    rtl_close_action_output,
    rtl_summary(Summary),
    format(user_error, "~s~n", [Summary]),
    rtl_exit(1).

output_gone_exit :-
    rtl_close_consumer_files,
    rtl_close_action_output,
    rtl_exit(1).

main_finish(Status) :-
    forall(rtl_stop_signal(Signal, _), on_signal(Signal, _, retalis:signal_while_finishing)),
    rtl_close_consumer_files,
    rtl_close_action_output,
    flush_output(user_output),
    get_time(T1),
    nb_getval(rtl_run_started, T0),
    Seconds is T1 - T0,
    print_detections,
    rtl_summary(Seconds, Summary),
    format(user_error, "~s~n", [Summary]),
    rtl_exit(Status).

%   print_detections: with --detections=LABELS, the line `retalis: detections per rule: r1 3,
%   r2 0` before the summary, as `retalisc run` writes it: the rules LABELS (the program's,
%   in program order) with their counts, 0 included, then the other rules that detected
%   something (added by control lines), in the order of their labels; no line when there
%   are none.

print_detections :-
    nb_current(rtl_detection_labels, Labels),
    !,
    rtl_detections(Counted),
    findall(Label-N, ( member(Label, Labels), ( memberchk(Label-N, Counted) -> true ; N = 0 ) ), Listed),
    findall(Rule-N, ( member(Rule-N, Counted), \+ memberchk(Rule, Labels) ), Added),
    append(Listed, Added, Counts),
    (   Counts == []
    ->  true
    ;   findall(Part, ( member(Rule-N, Counts), format(string(Part), "~w ~D", [Rule, N]) ), Parts),
        atomic_list_concat(Parts, ', ', Text),
        format(user_error, "retalis: detections per rule: ~w~n", [Text])
    ).
print_detections.

% A usage error of the command line (rtl_arguments.pl reads it by the table of run options).
usage_error(Formal) :-
    rtl_usage_text(Formal, Text),
    format(user_error, "~s~n", [Text]).

%!  rtl_action(:Goal) is det.
%
%   Run the action of a `Head do Goal <- Pattern` rule. An action that fails or raises
%   an error is reported on standard error; event processing goes on. What it prints goes
%   to the action output (standard error by default; rtl_set_action_output/1).

rtl_action(_) :-
    rtl_dry_running,                          % a deletion outside the horizon, counted only
    !.
rtl_action(Goal) :-
    (   rtl_action_context(Goal, catch(Goal, Error, action_error(Error)))
    ->  true
    ;   rtl_halt_check,                         % a halt in the action made it fail
        rtl_term_text(Goal, Text),
        print_message(warning, format("action failed: ~s", [Text]))
    ).

% The step limit and halts are not the action's own errors: they end the event.
action_error(Error) :-
    (   rtl_is_reserved_ball(Error)
    ->  throw(Error)
    ;   rtl_error_text(Error, Text),
        print_message(warning, format("~s", [Text])),
        fail
    ).
