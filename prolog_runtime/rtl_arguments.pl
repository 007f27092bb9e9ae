:- module(rtl_arguments,
          [ rtl_read_arguments/2,       % +Argv, -Files
            rtl_parse_arguments/3,      % +Argv, -Settings, -Files
            rtl_apply_setting/1,        % +Option=Value
            rtl_run_setting/2,          % ?Option, -Value
            rtl_usage_text/2            % +Formal, -Text
          ]).
:- use_module(library(lists)).
:- use_module(rtl_run_options, [rtl_run_option/5]).
:- use_module(rtl_ele, [rtl_set_flag/2, rtl_flag/2, rtl_set_action_output/1, rtl_action_stream/1]).
:- use_module(rtl_subscriptions, [rtl_consumer_dir/1]).
:- use_module(rtl_error_text, [rtl_error_text/2]).

/** <module> The command line of `swipl PROGRAM.pl`, read by the table of run options

`swipl PROGRAM.pl [OPTION...] EVENTS.jsonl...` (retalis.pl, rtl_main/0): an option is
`--name` (a switch) or `--name=VALUE`, anywhere among the event files. Which options there
are, the kind of each one's value and how each reaches the runtime are the facts of
rtl_run_options.pl, written from the one table of run options (retalisc/run_options.py),
the one `retalisc run` makes its options and its hand-over to `swipl` from: this module
knows the kinds and the roads, not the options.

The arguments are data: a value is read as a number (atom_number/2) or kept as an atom,
never as a term or a goal.
*/

%!  rtl_read_arguments(+Argv:list, -Files:list) is det.
%
%   Read the command line Argv (atoms), apply its options in order (rtl_apply_setting/1) and
%   give the event files left. Raises `error(Formal, _)` for a usage error
%   (rtl_usage_text/2): nothing is applied then, unless an option could not be applied
%   (`--action-output=FILE` that cannot be opened), which raises after the ones before it.

rtl_read_arguments(Argv, Files) :-
    rtl_parse_arguments(Argv, Settings, Files),
    maplist(rtl_apply_setting, Settings).

%!  rtl_parse_arguments(+Argv:list, -Settings:list, -Files:list) is det.
%
%   Settings are `Option=Value`, Option the name after `--` (`'max-delay'`), Value its value
%   as the runtime holds it (`true` for a switch, a number or `inf`, an atom for a path, a
%   list of atoms for labels), in the order given; Files the other arguments. `--` alone is
%   a file name. Raises `error(domain_error(option, Arg), _)` for an unknown option (or a
%   switch given a value, or an option with a value given none), and
%   `error(domain_error(run_option(Option, Kind), Text), _)` for a value its kind does not take.

rtl_parse_arguments([], [], []).
rtl_parse_arguments([Arg|Args], Settings, Files) :-
    (   option_argument(Arg, Option, Value)
    ->  Settings = [Option=Value|Settings1], Files = Files1
    ;   Settings = Settings1, Files = [Arg|Files1]
    ),
    rtl_parse_arguments(Args, Settings1, Files1).

option_argument(Arg, Option, Value) :-
    atom(Arg),
    atom_concat('--', Rest, Arg),
    Rest \== '',
    (   sub_atom(Rest, Before, _, After, '=')
    ->  sub_atom(Rest, 0, Before, _, Option),
        sub_atom(Rest, _, After, 0, Text),
        Given = value(Text)
    ;   Option = Rest,
        Given = none
    ),
    (   rtl_run_option(Option, Kind, _, _, _),
        takes(Kind, Given)
    ->  true
    ;   domain_error(option, Arg)
    ),
    (   Given = value(Text)
    ->  (   kind_value(Kind, Text, Value)
        ->  true
        ;   domain_error(run_option(Option, Kind), Text)
        )
    ;   Value = true
    ).

takes(switch, none) :- !.
takes(Kind, value(_)) :- Kind \== switch.

%   kind_value(+Kind, +Text, -Value) is semidet: the value of an option of Kind written Text.
kind_value(count, Text, Value) :-
    (   Text == inf
    ->  Value = inf
    ;   text_number(Text, Value), integer(Value), Value > 0
    ).
kind_value(seconds, Text, Value) :-
    seconds(Text, Value).
kind_value(limit, Text, Value) :-
    seconds(Text, Value).
kind_value(directory, Text, Text).
kind_value(file, Text, Text).
kind_value(labels, Text, Labels) :-
    (   Text == ''
    ->  Labels = []
    ;   atomic_list_concat(Labels, ',', Text)
    ).

seconds(Text, Value) :-
    (   Text == inf
    ->  Value = inf
    ;   text_number(Text, Value), Value >= 0, Value =\= inf
    ).

text_number(Text, Number) :-
    catch(atom_number(Text, Number), _, fail),
    number(Number),
    \+ Number =\= Number.                       % not NaN

%!  rtl_apply_setting(+Setting) is det.
%
%   Setting is `Option=Value` (rtl_parse_arguments/3): Value reaches the runtime by the
%   option's road.

rtl_apply_setting(Option=Value) :-
    rtl_run_option(Option, _, _, _, Road),
    !,
    apply(Road, Value).

apply(flag(Flag), Value) :-
    rtl_set_flag(Flag, Value).
apply(stream(Name), Value) :-
    Term =.. [Name, Value],
    (   nb_current(rtl_stream_options, Options0), is_list(Options0)
    ->  true
    ;   Options0 = []
    ),
    nb_setval(rtl_stream_options, [Term|Options0]).
apply(global(Key), Value) :-
    nb_setval(Key, Value).
apply(consumer_dir, Dir) :-
    rtl_consumer_dir(Dir).
apply(action_output, File) :-
    catch(rtl_set_action_output(File), error(E, _), throw(error(action_output(File, E), _))).

%!  rtl_run_setting(?Option, -Value) is nondet.
%
%   The value the runtime holds for the run option Option, read back where its road put it:
%   the flag, the line loop's option, the global variable, the consumer directory, the file
%   of the action output (user_error when there is none); the option's default when nothing
%   was set.

rtl_run_setting(Option, Value) :-
    rtl_run_option(Option, _, _, Default, Road),
    setting(Road, Default, Value).

setting(flag(Flag), _, Value) :-
    rtl_flag(Flag, Value).
setting(stream(Name), Default, Value) :-
    Term =.. [Name, V],
    (   nb_current(rtl_stream_options, Options), is_list(Options), memberchk(Term, Options)
    ->  Value = V
    ;   Value = Default
    ).
setting(global(Key), Default, Value) :-
    (   nb_current(Key, V), V \== []
    ->  Value = V
    ;   Value = Default
    ).
setting(consumer_dir, Default, Value) :-
    (   nb_current(rtl_consumer_dir, Dir), Dir \== []
    ->  Value = Dir
    ;   Value = Default
    ).
setting(action_output, _, Value) :-
    rtl_action_stream(Stream),
    (   Stream == user_error
    ->  Value = user_error
    ;   stream_property(Stream, file_name(Value))
    ).

%!  rtl_usage_text(+Formal, -Text:string) is det.
%
%   The line `swipl PROGRAM.pl` prints for the usage error `error(Formal, _)`: the unknown
%   option, the value an option does not take and what it takes, the action output that
%   cannot be opened, else the usage line (every option of the table).

rtl_usage_text(domain_error(option, Arg), Text) :- !,
    format(string(Text), "error: unknown option ~w", [Arg]).
rtl_usage_text(domain_error(run_option(Option, Kind), Value), Text) :- !,
    kind_expected(Kind, Expected),
    format(string(Text), "error: --~w=~w: expected ~w", [Option, Value, Expected]).
rtl_usage_text(action_output(File, E), Text) :-
    !,
    rtl_error_text(error(E, _), Why),
    format(string(Text), "error: --action-output=~w: cannot open the action output file (~s)", [File, Why]).
rtl_usage_text(_, Text) :-
    findall(Part,
            ( rtl_run_option(Option, Kind, Metavar, _, _),
              (   Kind == switch
              ->  format(string(Part), "[--~w]", [Option])
              ;   format(string(Part), "[--~w=~w]", [Option, Metavar])
              ) ),
            Parts),
    atomic_list_concat(Parts, ' ', Options),
    format(string(Text), "usage: swipl PROGRAM.pl ~w EVENTS.jsonl... (- for standard input)", [Options]).

kind_expected(count, "a positive integer or inf").
kind_expected(seconds, "a number of seconds >= 0 or inf").
kind_expected(limit, "a number of seconds >= 0 or inf").
kind_expected(labels, "rule labels, separated by commas").
kind_expected(directory, "a directory").
kind_expected(file, "a file").
