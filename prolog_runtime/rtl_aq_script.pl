:- module(rtl_aq_script,
          [ aq_run_script/1,        % +File
            aq_script_main/1,       % +File
            aq_script_batch/6       % +File, +From, +Max, -Output, -Next, -Status
          ]).

/** <module> Active queries: the update-script interpreter and its output

An *update script* drives the active queries of a loaded program (rtl_aq.pl) from a file,
one command a line (`retalisc aq PROGRAM SCRIPT`, docs/active_queries.md):

  - `?Id Goal.` registers Goal as active query Id;
  - `+Fact.` asserts a fact, `-Fact.` retracts one;
  - `+(Head :- Body).` adds a rule, `-(Head :- Body).` removes a rule the script added;
  - `!Id.` unregisters query Id;
  - blank lines and lines starting with `%` are skipped; a quoted atom or string left open
    at the end of a line goes on on the next ones.

After each command the notifications it made are printed, sorted, one JSON object a line:
`{"query": Id, "op": "answer"|"add"|"delete", "answer": Text}`, Text the answer written with
writeq. A line that does not parse, or a command the runtime refuses before it changes
anything (an unknown or already registered id, a goal that is not of a query predicate, a
fact of a predicate that is not stored, a rule the script did not add), is a *script error*
(exit status 2); a command that raises an error or fails while it runs is a *runtime error*
(exit status 1). Both name the line the command starts on.

This module stands on rtl_aq.pl's exported predicates alone: the checks before a command
(aq_registered/1, aq_check_query_goal/1, aq_check_fact/1, aq_rule_added/1, and
rtl_aq_rules:aq_rule_check/2 for a rule) and the commands themselves. A compiled
active-query program loads it next to rtl_aq.pl; rtl_aq_api.pl runs a script in batches for
a run that survives a crash (aq_script_batch/6).
*/

:- use_module(rtl_load, []).              % first: out-of-date .qlf files are not used
:- use_module(library(lists)).
:- use_module(library(readutil)).
:- use_module(rtl_error_text, [rtl_error_text/2]).
:- use_module(rtl_io, [rtl_json_string_escape/2]).
:- use_module(rtl_aq_rules, [aq_rule_check/2]).
:- use_module(rtl_aq, [aq_set_notify/1, aq_events/1, aq_register/2, aq_unregister/1,
                       aq_assert/1, aq_retract/1, aq_add_rule/1, aq_remove_rule/1,
                       aq_registered/1, aq_check_query_goal/1, aq_check_fact/1,
                       aq_rule_added/1]).

%!  aq_run_script(+File) is det.
%
%   Run an update script: lines `?Id Goal.` (register), `+Fact.` (assert),
%   `-Fact.` (retract), `!Id.` (unregister); blank lines and lines starting
%   with `%` are skipped.  Prints one JSON object per notification:
%   {"query": Id, "op": "answer"|"add"|"delete", "answer": Text}, Text being
%   the goal instance written with writeq.  Throws aq_script_error(Line,
%   Message) on a malformed line (one that does not parse, or a command the
%   runtime refuses: an unknown or already registered query id, a goal
%   that is not a query predicate, a fact of a predicate that is not
%   dynamic), and aq_runtime_error(Line, Error) when a well-formed command
%   fails while it runs.

aq_run_script(File) :-
    script_lines(File, Lines),
    aq_set_notify(none),
    run_lines(Lines, 1, inf, _).

%!  aq_script_batch(+File, +From, +Max, -Output, -Next, -Status) is det.
%
%   Run at most Max commands of the update script File, from its line From
%   (1 is the first) on, as aq_run_script/1 runs them, for a run that
%   survives a crash (`retalisc aq --state`, retalisc/driver/recovery.py):
%   the caller snapshots the state between two batches and, after a crash,
%   goes on from the line a snapshot names.  Output is what the commands
%   print; Next the line after the last command run; Status is `more`,
%   `done` (the script has no command after Next), or error(Exit, Message)
%   after a bad line or a failed command (Output holds what the commands
%   before it printed; Message is the line aq_script_main/1 prints, Exit its
%   exit status).  The lines of File are read again only when it changed
%   (its modification time or size).

aq_script_batch(File, From, Max, Output, Next, Status) :-
    must_be(positive_integer, From),
    must_be(nonneg, Max),
    time_file(File, Modified),
    size_file(File, Size),
    (   nb_current('$aq_script_lines', script(File, Modified, Size, Lines))
    ->  true
    ;   script_lines(File, Lines),
        nb_setval('$aq_script_lines', script(File, Modified, Size, Lines))
    ),
    aq_set_notify(none),
    with_output_to(string(Output),
                   catch(( run_lines(Lines, From, Max, Next),
                           (   functor(Lines, _, Count), Next > Count
                           ->  Status = done
                           ;   Status = more
                           ) ),
                         E,
                         ( Next = From,
                           script_error_text(File, E, Exit, Message),
                           Status = error(Exit, Message) ))).

%   The lines of a script file as the arguments of one term (arg/3 reaches
%   any line at once).
script_lines(File, Lines) :-
    read_file_to_string(File, Text, []),
    split_string(Text, "\n", "\r", List),
    compound_name_arguments(Lines, lines, List).

%   run_lines(+Lines, +N, +Max, -Next): run the commands from line N on, at
%   most Max of them (inf: all); Next is the line after the last one run
%   (the number of lines + 1 at the end of the script).  A command whose
%   quoted atom or string is not closed on its line goes on on the next
%   lines (a quoted item may contain newlines, as in programs); errors name
%   the line the command starts on.
run_lines(Lines, N, Max, Next) :-
    functor(Lines, _, Count),
    (   ( N > Count ; Max == 0 )
    ->  Next = N
    ;   arg(N, Lines, Line0),
        strip(Line0, Line),
        (   ( Line == "" ; sub_string(Line, 0, 1, _, "%") )
        ->  N1 is N + 1,
            run_lines(Lines, N1, Max, Next)
        ;   sub_string(Line, 0, 1, _, C),
            sub_string(Line, 1, _, 0, Rest0),
            strip(Rest0, Rest1),
            command_text(Rest1, Lines, N, N, C, T, N1),
            run_command_line(C, T, N, Line),
            (   Max == inf -> Max1 = inf ; Max1 is Max - 1 ),
            run_lines(Lines, N1, Max1, Next)
        )
    ).

strip(Text, Stripped) :-
    split_string(Text, "", " \t", [Stripped]).

%   Parse the command's text (starting on line N, taken up to line Last),
%   taking further lines while a quoted item is open at the end of the
%   text; N1 is the line after the last one taken.
command_text(Rest, Lines, N, Last, C, T, N1) :-
    catch(parse_command(C, Rest, T0), E, true),
    (   var(E)
    ->  T = T0, N1 is Last + 1
    ;   E = error(syntax_error(end_of_file_in_quoted(_)), _),
        Last1 is Last + 1,
        functor(Lines, _, Count),
        Last1 =< Count
    ->  arg(Last1, Lines, Next),
        string_concat(Rest, "\n", Rest2),
        string_concat(Rest2, Next, Rest3),
        command_text(Rest3, Lines, N, Last1, C, T, N1)
    ;   parse_error(N, E)
    ).

run_command_line(C, T, N, Line) :-
        catch(check_command(C, T, N), E2, line_error(N, E2)),
        (   catch(run_command(C, T), E3, throw(aq_runtime_error(N, E3)))
        ->  true
        ;   throw(aq_runtime_error(N, format("~s failed", [Line])))
        ),
        aq_events(Evs0),
        msort(Evs0, Evs),
        forall(member(ev(Id, Op, A), Evs), print_event(Id, Op, A)).

%   `?Id Goal.`: the id is the text up to the first space.
parse_command("?", Rest, Id-Goal) :- !,
    (   sub_string(Rest, B, 1, _, " ")
    ->  sub_string(Rest, 0, B, _, IdText),
        sub_string(Rest, B, _, 0, GoalText),
        term_string(Id, IdText),
        term_string(Goal, GoalText)
    ;   throw(aq_script_error(0, 'expected ?Id Goal.'))
    ),
    (   atomic(Id) -> true ; throw(aq_script_error(0, 'the query id must be an atom or a number')) ).
parse_command(_, Rest, T) :-
    term_string(T, Rest).

parse_error(N, aq_script_error(_, Msg)) :- !,
    throw(aq_script_error(N, Msg)).
parse_error(N, E) :-
    rtl_error_text(E, Msg),
    throw(aq_script_error(N, Msg)).

%   Every error of check_command/3 is a bad script line.
line_error(N, aq_script_error(_, Msg)) :- !,
    throw(aq_script_error(N, Msg)).
line_error(N, E) :-
    rtl_error_text(E, Msg),
    throw(aq_script_error(N, Msg)).


%   What the runtime refuses before it changes anything: the errors that
%   aq_register/3, aq_assert/1, aq_retract/1 and aq_unregister/1 raise for
%   such a command.  Any error while the command runs is a runtime failure.
check_command("?", Id-Goal, _) :- !,
    (   aq_registered(Id) -> permission_error(register, active_query, Id) ; true ),
    aq_check_query_goal(Goal).
check_command("+", (H :- B), _) :- !,
    catch(aq_rule_check((H :- B), _), aq_rule_error(Msg), throw(aq_script_error(0, Msg))).
check_command("-", (H :- B), _) :- !,
    (   aq_rule_added((H :- B))
    ->  true
    ;   throw(aq_script_error(0, 'no such rule was added (only rules added by the script can be removed)'))
    ).
check_command("+", F, _) :- !, aq_check_fact(F).
check_command("-", F, _) :- !, aq_check_fact(F).
check_command("!", Id, _) :- !,
    (   aq_registered(Id) -> true ; existence_error(active_query, Id) ).
check_command(C, _, N) :-
    format(atom(Msg), 'unknown command ~w (expected ?, +, - or !)', [C]),
    throw(aq_script_error(N, Msg)).

run_command("?", Id-Goal) :- aq_register(Id, Goal).
run_command("+", (H :- B)) :- !, aq_add_rule((H :- B)).
run_command("-", (H :- B)) :- !, aq_remove_rule((H :- B)).
run_command("+", F) :- aq_assert(F).
run_command("-", F) :- aq_retract(F).
run_command("!", Id) :- aq_unregister(Id).

print_event(Id, Op, A) :-
    format(string(AT), '~q', [A]),
    json_text(Id, IdT),
    json_string(AT, AJ),
    format('{"query": ~w, "op": "~w", "answer": ~w}~n', [IdT, Op, AJ]).

json_text(Id, T) :-
    (   number(Id) -> format(string(T), '~w', [Id])
    ;   format(string(S), '~w', [Id]), json_string(S, T)
    ).

json_string(Text, J) :-
    rtl_json_string_escape(Text, Escaped),
    format(string(J), '"~w"', [Escaped]).

%!  aq_script_main(+File) is det.
%
%   Run aq_run_script/1 as a program: halt(0) on success, halt(2) with
%   `File:Line: error: message` on a malformed script line, halt(1) with
%   `File:Line: runtime error: message` (one line) when a command fails
%   while it runs, and with `error: message` on any other error.

aq_script_main(File) :-
    (   catch(( aq_run_script(File), flush_output, Status = 0 ), E, script_error(File, E, Status))
    ->  true
    ;   script_error(File, format("running ~w failed", [File]), Status)
    ),
    halt(Status).

script_error(File, E, Status) :-
    flush_output,
    script_error_text(File, E, Status, Text),
    format(user_error, '~w~n', [Text]).

%   The message of a script error and the exit status that goes with it.
script_error_text(File, aq_script_error(Line, Msg), 2, Text) :- !,
    format(string(Text), '~w:~w: error: ~w', [File, Line, Msg]).
script_error_text(File, aq_runtime_error(Line, E), 1, Text) :- !,
    rtl_error_text(E, Msg),
    format(string(Text), '~w:~w: runtime error: ~w', [File, Line, Msg]).
script_error_text(_, E, 1, Text) :-
    rtl_error_text(E, Msg),
    format(string(Text), 'error: ~w', [Msg]).
