/*  plunit tests of rtl_arguments.pl: the command line of `swipl PROGRAM.pl`, read by the
    table of run options (rtl_run_options.pl). Every option of the table is read by its kind
    and reaches the runtime by its road (read back by rtl_run_setting/2); bad values and
    unknown options are usage errors with their text, and nothing is applied then.
    (tests/test_run_options.py checks the same table against retalisc run's own options.)

        swipl -g run_tests -t halt prolog_runtime/tests/test_arguments.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module('../retalis', []).
:- use_module('../rtl_run_options').
:- use_module('../rtl_arguments').

fresh :-
    retalis:rtl_reset,
    retalis:rtl_default_flags,
    nb_setval(rtl_stream_options, []),
    nb_setval(rtl_drop_pending, []),
    nb_setval(rtl_detection_labels, []),
    nb_setval(rtl_consumer_dir, []),
    retalis:rtl_close_action_output.

usage(Argv, Text) :-
    catch(( rtl_parse_arguments(Argv, _, _), Text = none ),
          error(Formal, _),
          rtl_usage_text(Formal, Text)).

% A value of each kind that is no option's default, its text and what the runtime holds.
sample(switch, _, true).
sample(count, '7', 7).
sample(seconds, '2.5', 2.5).
sample(limit, '12', 12).
sample(directory, Dir, Dir) :- tmp_file(consumers, Dir).
sample(file, File, File) :- tmp_file(actions, File).
sample(labels, 'r1,fire_alarm', [r1, fire_alarm]).

:- begin_tests(rtl_arguments, [setup(fresh), cleanup(fresh)]).

test(files_and_options_mixed) :-
    rtl_parse_arguments(['a.jsonl', '--strict', '-', '--max-delay=0.5', '--', 'b.jsonl'], Settings, Files),
    assertion(Settings == [strict=true, 'max-delay'=0.5]),
    assertion(Files == ['a.jsonl', -, '--', 'b.jsonl']).

test(every_option_of_the_table_reaches_the_runtime, [setup(fresh), cleanup(fresh)]) :-
    forall(rtl_run_option(Option, Kind, _, _, _),
           ( sample(Kind, Text, Value),
             (   Kind == switch
             ->  atom_concat('--', Option, Arg)
             ;   atomic_list_concat(['--', Option, '=', Text], Arg)
             ),
             rtl_read_arguments([Arg, 'e.jsonl'], Files),
             assertion(Files == ['e.jsonl']),
             rtl_run_setting(Option, Read),
             (   Kind == file                       % the file's absolute name
             ->  absolute_file_name(Value, Expected)
             ;   Expected = Value
             ),
             assertion(Read == Expected) )).

test(defaults_when_nothing_is_given, [setup(fresh), cleanup(fresh)]) :-
    rtl_read_arguments(['e.jsonl'], _),
    forall(( rtl_run_option(Option, _, _, Default, Road), Road \== action_output ),
           ( rtl_run_setting(Option, Value), assertion(Value == Default) )),
    rtl_run_setting('action-output', Out),
    assertion(Out == user_error).

test(flags_take_their_defaults_from_the_table) :-
    forall(rtl_run_option(_, _, _, Default, flag(Flag)),
           ( retalis:rtl_default_flags, retalis:rtl_flag(Flag, Value), assertion(Value == Default) )).

test(inf) :-
    rtl_parse_arguments(['--max-steps=inf', '--max-delay=inf', '--max-future=inf'], Settings, []),
    assertion(Settings == ['max-steps'=inf, 'max-delay'=inf, 'max-future'=inf]).

test(empty_labels) :-
    rtl_parse_arguments(['--detections='], Settings, []),
    assertion(Settings == [detections=[]]).

test(bad_values) :-
    usage(['--max-steps=0'], T1), assertion(T1 == "error: --max-steps=0: expected a positive integer or inf"),
    usage(['--max-timers=2.0'], T2), assertion(T2 == "error: --max-timers=2.0: expected a positive integer or inf"),
    usage(['--max-delay=-1'], T3), assertion(T3 == "error: --max-delay=-1: expected a number of seconds >= 0 or inf"),
    usage(['--max-delay=1.0Inf'], T4), assertion(T4 == "error: --max-delay=1.0Inf: expected a number of seconds >= 0 or inf"),
    usage(['--max-future=soon'], T5), assertion(T5 == "error: --max-future=soon: expected a number of seconds >= 0 or inf"),
    usage(['--max-digits=a(1)'], T6), assertion(T6 == "error: --max-digits=a(1): expected a positive integer or inf").

test(unknown_options) :-
    usage(['--nope'], T1), assertion(T1 == "error: unknown option --nope"),
    usage(['--strict=yes'], T2), assertion(T2 == "error: unknown option --strict=yes"),
    usage(['--max-steps'], T3), assertion(T3 == "error: unknown option --max-steps"),
    usage(['--=1'], T4), assertion(T4 == "error: unknown option --=1").

test(nothing_is_applied_on_a_usage_error, [setup(fresh), cleanup(fresh)]) :-
    catch(rtl_read_arguments(['--max-delay=3', '--max-steps=0'], _), error(_, _), true),
    retalis:rtl_flag(max_delay, Delay),
    assertion(Delay == 1.0).

test(a_value_is_never_read_as_a_term, [setup(fresh), cleanup(fresh)]) :-
    rtl_read_arguments(['--detections=halt,a(b)'], _),
    rtl_run_setting(detections, Labels),
    assertion(Labels == [halt, 'a(b)']).

test(an_action_output_that_cannot_be_opened) :-
    catch(( rtl_read_arguments(['--action-output=/nonexistent/dir/f'], _), fail ),
          error(Formal, _), true),
    rtl_usage_text(Formal, Text),
    assertion(sub_string(Text, 0, _, _, "error: --action-output=/nonexistent/dir/f: cannot open the action output file (")).

test(the_usage_line_lists_the_table) :-
    rtl_usage_text(no_event_file, Text),
    forall(rtl_run_option(Option, _, _, _, _),
           ( format(string(Part), "[--~w", [Option]), assertion(sub_string(Text, _, _, _, Part)) )).

:- end_tests(rtl_arguments).
