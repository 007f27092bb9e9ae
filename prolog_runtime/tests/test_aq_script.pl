/*  plunit tests of rtl_aq_script.pl, the update-script interpreter of active queries.  Load
    a program compiled from Program 4 of the thesis (left recursion: `path/2` over the
    stored `edge(0, 1)`, `edge(1, 2)`) whose path is in the environment variable
    AQ_TEST_PROGRAM (tests/test_aq_script.py compiles it):

        AQ_TEST_PROGRAM=/tmp/p4.pl swipl -g run_tests -t halt prolog_runtime/tests/test_aq_script.pl

    The scripts are written to temporary files; what a script prints is compared line by
    line with the JSON objects the interpreter must write.
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(readutil)).

:- getenv('AQ_TEST_PROGRAM', File) -> consult(File) ; throw(error(existence_error(environment_variable, 'AQ_TEST_PROGRAM'), _)).

%   script_file(+Lines, -File): a temporary file holding Lines, one a line.
script_file(Lines, File) :-
    tmp_file_stream(text, File, Out),
    forall(member(L, Lines), format(Out, "~s~n", [L])),
    close(Out).

%   run_script(+Lines, -Output, -Error): aq_run_script/1 on Lines; Output the lines it
%   printed, Error `none` or the error it raised.
run_script(Lines, Output, Error) :-
    script_file(Lines, File),
    with_output_to(string(Text),
                   catch(( aq_run_script(File), Error = none ), E, Error = E)),
    delete_file(File),
    split_string(Text, "\n", "", Parts),
    exclude(==(""), Parts, Output).

fresh :-
    aq_reset,
    retractall(user:edge(_, _)),
    assertz(user:edge(0, 1)),
    assertz(user:edge(1, 2)).

:- begin_tests(rtl_aq_script, [setup(fresh), cleanup(fresh)]).

test(register_assert_retract_unregister, [setup(fresh), cleanup(fresh)]) :-
    run_script(["?q path(0, X).", "", "% a comment", "+edge(2, 3).", "-edge(1, 2).", "!q."], Out, Error),
    assertion(Error == none),
    assertion(Out == ["{\"query\": \"q\", \"op\": \"answer\", \"answer\": \"path(0,1)\"}",
                      "{\"query\": \"q\", \"op\": \"answer\", \"answer\": \"path(0,2)\"}",
                      "{\"query\": \"q\", \"op\": \"add\", \"answer\": \"path(0,3)\"}",
                      "{\"query\": \"q\", \"op\": \"delete\", \"answer\": \"path(0,2)\"}",
                      "{\"query\": \"q\", \"op\": \"delete\", \"answer\": \"path(0,3)\"}"]),
    aq_queries(Ids),
    assertion(Ids == []).

% A number is written as a JSON number; the events of one line are sorted.
test(numeric_id_and_sorted_events, [setup(fresh), cleanup(fresh)]) :-
    run_script(["?7 path(X, 2).", "+edge(2, 0)."], Out, Error),
    assertion(Error == none),
    assertion(Out == ["{\"query\": 7, \"op\": \"answer\", \"answer\": \"path(0,2)\"}",
                      "{\"query\": 7, \"op\": \"answer\", \"answer\": \"path(1,2)\"}",
                      "{\"query\": 7, \"op\": \"add\", \"answer\": \"path(2,2)\"}"]).

% A quoted atom open at the end of its line goes on on the next one; the answer text is
% writeq's, escaped for JSON.
test(quoted_atom_over_two_lines, [setup(fresh), cleanup(fresh)]) :-
    run_script(["?q path(1, X).", "+edge(2, 'a", "b')."], Out, Error),
    assertion(Error == none),
    assertion(Out == ["{\"query\": \"q\", \"op\": \"answer\", \"answer\": \"path(1,2)\"}",
                      "{\"query\": \"q\", \"op\": \"add\", \"answer\": \"path(1,'a\\\\nb')\"}"]).

test(rule_added_and_removed, [setup(fresh), cleanup(fresh)]) :-
    run_script(["?q path(0, X).", "+(path(X, Y) :- edge(Y, X)).", "-(path(X, Y) :- edge(Y, X))."], Out, Error),
    assertion(Error == none),
    assertion(Out == ["{\"query\": \"q\", \"op\": \"answer\", \"answer\": \"path(0,1)\"}",
                      "{\"query\": \"q\", \"op\": \"answer\", \"answer\": \"path(0,2)\"}"]).

test(removing_a_rule_not_added_is_a_script_error, [setup(fresh), cleanup(fresh)]) :-
    run_script(["-(path(X, Y) :- edge(Y, X))."], Out, Error),
    assertion(Out == []),
    assertion(Error = aq_script_error(1, _)).

% The errors name the line the command starts on; the commands before it ran.
test(script_errors, [setup(fresh), cleanup(fresh), forall(member(Line-Reason,
        [ "?q path(0, X)."-registered, "!nosuch."-unknown_id, "?r nosuch(X)."-not_a_query,
          "+path(5, 6)."-not_stored, "*edge(1, 2)."-unknown_command, "+edge(1, ."-no_parse ]))]) :-
    run_script(["?q path(0, X).", "", Line], Out, Error),
    assertion(length(Out, 2)),
    assertion(Error = aq_script_error(3, _)),
    Error = aq_script_error(_, Message),
    assertion(( atomic(Message), Message \== '' )),
    assertion(atom(Reason)).

% Batches: at most Max commands from line From; Next is the line after the last one run.
test(batches, [setup(fresh), cleanup(fresh)]) :-
    script_file(["?q path(0, X).", "% skipped", "+edge(2, 3).", "-edge(2, 3)."], File),
    aq_script_batch(File, 1, 1, Out1, Next1, Status1),
    assertion(Next1 == 2), assertion(Status1 == more),
    assertion(sub_string(Out1, _, _, _, "\"op\": \"answer\"")),
    aq_script_batch(File, Next1, 1, Out2, Next2, Status2),
    assertion(Next2 == 4), assertion(Status2 == more),
    assertion(Out2 == "{\"query\": \"q\", \"op\": \"add\", \"answer\": \"path(0,3)\"}\n"),
    aq_script_batch(File, Next2, 5, Out3, Next3, Status3),
    assertion(Next3 == 6), assertion(Status3 == done),      % the file ends with a newline: 5 lines
    assertion(Out3 == "{\"query\": \"q\", \"op\": \"delete\", \"answer\": \"path(0,3)\"}\n"),
    delete_file(File).

test(batch_stops_at_a_bad_line, [setup(fresh), cleanup(fresh)]) :-
    script_file(["?q path(0, X).", "+edge(2, 3).", "!nosuch."], File),
    aq_script_batch(File, 1, 10, Out, Next, Status),
    delete_file(File),
    assertion(Next == 1),
    assertion(Status = error(2, _)),
    Status = error(_, Message),
    assertion(sub_string(Message, _, _, _, ":3: error: ")),
    assertion(sub_string(Out, _, _, _, "path(0,3)")).

:- end_tests(rtl_aq_script).
