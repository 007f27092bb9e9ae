:- module(retalis,
          [ rtl_program_loaded/1,       % +Module
            rtl_main/0,
            rtl_run_jsonl_file/1,       % +File
            rtl_feed_lines/3,           % +Text, +FirstLineNo, -Output
            rtl_feed_events/2,          % +Events, -Output
            rtl_action/1,               % :Goal
            rtl_aggregate/4,            % +Function, +Acc0, -Acc, -Value
            rtl_summary/1,              % -Text
            rtl_end_of_input/2          % +Mode, -Output
          ]).
:- reexport(rtl_ele).
:- reexport(rtl_io).
:- reexport(rtl_time).
:- reexport(rtl_raise).
:- reexport(rtl_subscriptions).
:- reexport(rtl_library).
:- reexport(rtl_rules).
:- reexport(rtl_slr).
:- reexport(rtl_query).
:- reexport(rtl_math).
:- reexport(rtl_sync).
:- reexport(rtl_horizon).

/** <module> Retalis runtime: the entry points of a compiled program

A compiled program (`retalisc compile P.rtl -o P.pl`) loads this module. It then runs in
two ways:

  - as a script, `swipl P.pl EVENTS.jsonl [...]`: rtl_main/0 reads the event files (or
    standard input for `-`) and writes the output JSON Lines to standard output, with
    rejected lines and a summary on standard error;
  - embedded (the Python driver): rtl_feed_lines/3 and rtl_feed_events/2 take a batch and
    return the output lines as one string.
*/

:- meta_predicate rtl_action(0).

%!  rtl_program_loaded(+Module) is det.
%
%   Called by a compiled program when it has been loaded.

rtl_program_loaded(Module) :-
    rtl_use_program(Module),
    forall(Module:ele_declaration(Goal), run_declaration(Module, Goal)).

%!  rtl_declaration_handler(?Name, ?Arity, ?Module) is nondet.
%
%   Multifile: runtime modules that implement a start-up declaration Name/Arity (written as
%   a fact or directive in a program) add a clause; the goal is called as Module:Goal.

:- multifile rtl_declaration_handler/3.

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
%   Options: `--echo-input` also writes the input events; `--max-delay=SECONDS`;
%   `--retraction-horizon=SECONDS` (or `inf`);
%   `--consumer-dir=DIR` writes subscription deliveries to `DIR/<consumer>.jsonl`.

rtl_main :-
    current_prolog_flag(retalis_embedded, true),
    !.
rtl_main :-
    current_prolog_flag(argv, Argv),
    set_stream(user_output, encoding(utf8)),
    set_stream(user_error, encoding(utf8)),
    catch(main_args(Argv, Files), error(Formal, _), (usage_error(Formal), halt(2))),
    (   Files == []
    ->  usage_error(no_event_file), halt(2)
    ;   true
    ),
    catch(( rtl_flush_raised,
            forall(member(File, Files), rtl_run_jsonl_file(File)),
            ( nb_current(rtl_drop_pending, true) -> rtl_sync_finish(drop) ; rtl_sync_finish(run) ) ),
          Error,
          ( print_message(error, Error), halt(1) )),
    rtl_close_consumer_files,
    flush_output,
    rtl_summary(Summary),
    format(user_error, "~s~n", [Summary]),
    halt(0).

main_args([], []).
main_args([Arg|Args], Files) :-
    (   Arg == '--echo-input'
    ->  rtl_set_flag(echo_input, true), Files = Rest
    ;   Arg == '--drop-pending'
    ->  nb_setval(rtl_drop_pending, true), Files = Rest
    ;   atom_concat('--consumer-dir=', Dir, Arg)
    ->  rtl_consumer_dir(Dir), Files = Rest
    ;   atom_concat('--max-delay=', D, Arg)
    ->  ( D == inf -> Delay = inf ; atom_number(D, Delay) ),
        rtl_set_flag(max_delay, Delay), Files = Rest
    ;   atom_concat('--retraction-horizon=', H, Arg)
    ->  ( H == inf -> Horizon = inf ; atom_number(H, Horizon), Horizon >= 0 ),
        rtl_set_flag(retraction_horizon, Horizon), Files = Rest
    ;   sub_atom(Arg, 0, _, _, '--'), Arg \== '--'
    ->  domain_error(option, Arg)
    ;   Files = [Arg|Rest]
    ),
    main_args(Args, Rest).

usage_error(Formal) :-
    (   Formal = domain_error(option, Opt)
    ->  format(user_error, "error: unknown option ~w~n", [Opt])
    ;   format(user_error, "usage: swipl PROGRAM.pl [--echo-input] [--max-delay=SECONDS] [--retraction-horizon=SECONDS] [--consumer-dir=DIR] [--drop-pending] EVENTS.jsonl...~n", [])
    ).

%!  rtl_run_jsonl_file(+File) is det.
%
%   Process every line of an event file (`-` for standard input).

rtl_run_jsonl_file(-) :- !,
    set_stream(user_input, encoding(utf8)),
    run_stream(user_input, '<stdin>').
rtl_run_jsonl_file(File) :-
    setup_call_cleanup(open(File, read, In, [encoding(utf8)]),
                       run_stream(In, File),
                       close(In)).

run_stream(In, Name) :-
    read_line_to_string(In, Line0),
    run_lines(Line0, In, Name, 1).

run_lines(end_of_file, _, _, _) :- !.
run_lines(Line, In, Name, N) :-
    process_line(Line, Name, N),
    read_line_to_string(In, Next),
    N1 is N + 1,
    run_lines(Next, In, Name, N1).

process_line(Line, Name, N) :-
    handle_line(Line, Reason),
    (   var(Reason)
    ->  true
    ;   format(user_error, "~w:~w: rejected: ~s~n", [Name, N, Reason])
    ),
    rtl_take_warnings(Warnings),
    forall(member(W, Warnings), format(user_error, "~w:~w: warning: ~s~n", [Name, N, W])).

%   handle_line(+Line, -Reason) is det.
%
%   Process one input line: an event, its deletion, or a rule change. Reason stays unbound
%   unless the line is rejected (then it is counted).

handle_line(Line, Reason) :-
    rtl_parse_event_line(Line, Parsed),
    (   Parsed = event(Op, Event, Start, End)
    ->  process_event(Op, Event, Start, End)
    ;   Parsed = rule(Change, Text)
    ->  change_rules(Change, Text, Reason)
    ;   Parsed = error(Reason)
    ->  true
    ;   true
    ),
    (   nonvar(Reason) -> rtl_count(rejected) ; true ).

change_rules(Change, Text, Reason) :-
    rtl_program(M),
    catch(( Change == add -> ins_event_rule(M:Text) ; atom_string(Label, Text), del_event_rule(M:Label) ),
          Error,
          error_text(Error, Reason)).

% One line of text for an error term, as print_message/2 would say it.
error_text(Error, Text) :-
    (   catch('$messages':translate_message(Error, Lines, []), _, fail)
    ->  with_output_to(string(S), print_message_lines(current_output, '', Lines)),
        split_string(S, "\n", " ", Parts0),
        exclude(==(""), Parts0, Parts),
        atomic_list_concat(Parts, " ", Text0),
        atom_string(Text0, Text)
    ;   format(string(Text), "~q", [Error])
    ).

process_event(Op, Event, Start, End) :-
    rtl_input(Op, Event, Start, End).         % then the events raised meanwhile (rtl_raise)

%!  rtl_feed_lines(+Text:string, +FirstLineNo:integer, -Output:string) is det.
%
%   Process a batch of input JSON Lines. Output holds the output lines, each ended by a
%   newline; a rejected input line shows up as `!N<TAB>Reason` with its line number N, a
%   warning about line N (a deletion outside the retraction horizon) as `?N<TAB>Text`.

rtl_feed_lines(Text, First, Output) :-
    rtl_output_to(buffer),
    split_string(Text, "\n", "", Lines),
    feed_lines(Lines, First, Rejections),
    rtl_take_output(Out),
    append(Out, Rejections, All0),
    exclude(==(""), All0, All),
    atomic_list_concat(All, "\n", Joined),
    (   All == [] -> Output = "" ; string_concat(Joined, "\n", Output) ).

feed_lines([], _, []).
feed_lines([Line|Lines], N, Rejections) :-
    handle_line(Line, Reason),
    (   var(Reason)
    ->  Rejections = Rest0
    ;   format(string(R), "!~w\t~s", [N, Reason]),
        Rejections = [R|Rest0]
    ),
    rtl_take_warnings(Warnings),
    findall(W, ( member(T, Warnings), format(string(W), "?~w\t~s", [N, T]) ), Ws),
    append(Ws, Rest, Rest0),
    N1 is N + 1,
    feed_lines(Lines, N1, Rest).

%!  rtl_feed_events(+Events:list, -Output:string) is det.
%
%   Process a batch of `event(Op, Event, Start, End)` terms; Output as for rtl_feed_lines/3,
%   with the warnings as `?<TAB>Text` (no line number).

rtl_feed_events(Events, Output) :-
    rtl_output_to(buffer),
    forall(member(event(Op, Event, Start, End), Events),
           process_event(Op, Event, Start, End)),
    rtl_take_output(Lines0),
    rtl_take_warnings(Warnings),
    findall(W, ( member(T, Warnings), format(string(W), "?\t~s", [T]) ), Ws),
    append(Lines0, Ws, Lines),
    (   Lines == []
    ->  Output = ""
    ;   atomic_list_concat(Lines, "\n", Joined),
        string_concat(Joined, "\n", Output)
    ).

%!  rtl_action(:Goal) is det.
%
%   Run the action of a `Head do Goal <- Pattern` rule. An action that fails or raises
%   an error is reported on standard error; event processing goes on.

rtl_action(_) :-
    rtl_dry_running,                          % a deletion outside the horizon, counted only
    !.
rtl_action(Goal) :-
    (   catch(Goal, Error, (print_message(warning, Error), fail))
    ->  true
    ;   print_message(warning, format("action failed: ~q", [Goal]))
    ).

%!  rtl_aggregate(+Function, +Acc0, -Acc, -Value) is det.
%
%   One step of an ETALIS aggregate: Function is `count`, `sum(X)`, `min(X)`, `max(X)` or
%   `avg(X)` with X bound to the new occurrence's value; Acc0 is `none` at the start.

rtl_aggregate(count, Acc0, N, N) :-
    ( Acc0 == none -> N = 1 ; N is Acc0 + 1 ).
rtl_aggregate(sum(X), Acc0, S, S) :-
    ( Acc0 == none -> S = X ; S is Acc0 + X ).
rtl_aggregate(min(X), Acc0, M, M) :-
    ( Acc0 == none -> M = X ; M is min(Acc0, X) ).
rtl_aggregate(max(X), Acc0, M, M) :-
    ( Acc0 == none -> M = X ; M is max(Acc0, X) ).
rtl_aggregate(avg(X), Acc0, Sum-N, Avg) :-
    (   Acc0 == none
    ->  Sum = X, N = 1
    ;   Acc0 = Sum0-N0, Sum is Sum0 + X, N is N0 + 1
    ),
    Avg is Sum / N.

%!  rtl_end_of_input(+Mode, -Output:string) is det.
%
%   The input has ended: run (Mode `run`) or discard (`drop`) the postponed synchronized
%   matches (rtl_sync_finish/1); Output as for rtl_feed_lines/3.

rtl_end_of_input(Mode, Output) :-
    rtl_output_to(buffer),
    rtl_sync_finish(Mode),
    rtl_take_output(Lines),
    (   Lines == []
    ->  Output = ""
    ;   atomic_list_concat(Lines, "\n", Joined),
        string_concat(Joined, "\n", Output)
    ).

%!  rtl_summary(-Text:string) is det.

rtl_summary(Text) :-
    rtl_stat(events, Events),
    rtl_stat(retracted, Retracted),
    rtl_stat(derived, Derived),
    rtl_stat(rejected, Rejected),
    rtl_stat(late, Late),
    rtl_stat(too_late, TooLate),
    format(string(Text),
           "retalis: ~D events, ~D retracted, ~D too late to retract, ~D rejected, ~D late, ~D derived",
           [Events, Retracted, TooLate, Rejected, Late, Derived]).
