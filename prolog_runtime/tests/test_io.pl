/*  plunit tests of rtl_io.pl: event JSON Lines in and out. Random events written as JSON by
    library(http/json) (the oracle writer, keys in any order, with escapes) are read back as
    the same term and times by the C reader and by the Prolog one alike; the output lines,
    read by library(http/json), hold the event's writeq text and its times, and so does the
    output data (rtl_output_data/2), with the term as data; bad lines are rejected with a
    reason.

        swipl -g run_tests -t halt prolog_runtime/tests/test_io.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(random)).
:- use_module(library(http/json)).
:- use_module('../retalis', []).
:- use_module('../rtl_io').

random_atom(A) :-
    random_member(A, [a, door, 'Big', 'with space', 'x,y', 'it''s', 'é', 'rauch_ü', '"q"', 'back\\slash',
                      'tab\there', [], '{}', '/']).

random_arg(D, A) :-
    random_between(0, 5, K0), ( D > 2 -> K = 0 ; K = K0 ),
    (   K =:= 0 -> random_between(-1000, 1000, A)
    ;   K =:= 1 -> random_atom(A)
    ;   K =:= 2 -> random_member(A, [1.5, -0.25, 1.0e10, "a string", "with \"quotes\""])
    ;   K =:= 3 -> D1 is D + 1, random_event(D1, A)
    ;   K =:= 4 -> D1 is D + 1, random_arg(D1, X), random_arg(D1, Y), A = [X, Y]
    ;   A = f(-1)
    ).

random_event(D, E) :-
    random_member(Name, [a, door, 'x y', 'é', p]),
    random_between(0, 3, N), length(Args, N), maplist(random_arg(D), Args),
    (   Args == [] -> E = Name ; compound_name_arguments(E, Name, Args) ).

json_line(Dict, Line) :-
    with_output_to(string(Line), json_write_dict(current_output, Dict, [width(0)])).

with_each_reader(Goal) :-
    \+ \+ call(Goal),
    (   rtl_fast_reader_used
    ->  setup_call_cleanup(rtl_use_fast_reader(false), \+ \+ call(Goal), rtl_use_fast_reader(true))
    ;   true
    ).

:- begin_tests(rtl_io).

test(random_events_read_back_by_both_readers) :-
    set_random(seed(36)),
    with_each_reader(
        forall(between(1, 300, _),
               ( random_event(0, E),
                 format(string(Text), "~q", [E]),
                 random_between(0, 100, S), random_between(0, 3, Dt), End is S + Dt,
                 random_member(Dict, [_{event: Text, t: S}, _{t: S, event: Text},
                                      _{event: Text, start: S, end: End}, _{event: Text, start: S, end: End, op: retract}]),
                 json_line(Dict, Line),
                 rtl_parse_event_line(Line, Parsed),
                 (   get_dict(t, Dict, T) -> Start = T, Stop = T ; Start = S, Stop = End ),
                 ( get_dict(op, Dict, retract) -> Op = retract ; Op = add ),
                 assertion(Parsed =@= event(Op, E, Start, Stop)) ))).

test(output_lines_are_json_with_the_writeq_text) :-
    set_random(seed(7)),
    forall(between(1, 200, _),
           ( random_event(0, E),
             random_member(Consumer-Op, [(-)-add, (-)-retract, "c/1"-add, echo(input)-add]),
             rtl_event_json(E, 1, 2.5, Consumer, Op, Json),
             atom_json_dict(Json, Dict, [value_string_as(string)]),
             term_string(Back, Dict.event),
             assertion(Back =@= E),
             assertion(Dict.start =:= 1), assertion(Dict.end =:= 2.5),
             ( Op == retract -> assertion(Dict.op == "retract") ; assertion(\+ get_dict(op, Dict, _)) ),
             (   Consumer == (-) -> assertion(\+ get_dict(consumer, Dict, _))
             ;   Consumer == echo(input) -> assertion(Dict.input == true)
             ;   assertion(Dict.consumer == Consumer)
             ) )).

test(output_data_reads_back_as_the_records) :-
    set_random(seed(11)),
    findall(event(E, S, 2.5, Consumer, Op),
            ( between(1, 200, S), random_event(0, E),
              random_member(Consumer-Op, [(-)-add, (-)-retract, c1-add, echo(input)-add]) ),
            Records),
    with_each_reader(( rtl_output_data(Records, Data),
                       split_string(Data, "\n", "", [OutputsText, TermsText]),
                       atom_string(OutputsAtom, OutputsText), atom_string(TermsAtom, TermsText),
                       atom_json_term(OutputsAtom, Outputs, [value_string_as(string)]),
                       atom_json_term(TermsAtom, Terms, [value_string_as(string)]),
                       maplist(output_reads_back, Records, Outputs, Terms) )).

test(output_data_of_a_query_result) :-
    Line = "{\"query\": \"q1\", \"at\": 5, \"status\": \"answered\", \"answers\": [], \"message\": \"\"}",
    with_each_reader(( rtl_output_data([json(Line)], Data),
                       assertion(Data == "[{\"query\": \"q1\", \"at\": 5, \"status\": \"answered\", \"answers\": [], \"message\": \"\"}]\n[null]") )).

test(json_string_escapes_a_nul_at_either_end) :-
    forall(member(Codes, [[0], [0, 0'a], [0'a, 0], [0'a, 0, 0'b]]),
           ( string_codes(Text, Codes),
             rtl_json_string_escape(Text, Escaped),
             format(atom(Json), "\"~s\"", [Escaped]),
             atom_json_term(Json, Back, [value_string_as(string)]),
             assertion(Back == Text) )).

test(json_string_escapes_read_back) :-
    forall(member(Text, ["plain", "quote \" back \\ slash", "tab\tnew\nline", "é ü \u2603", "\u0001"]),
           ( rtl_json_string_escape(Text, Escaped),
             format(atom(Json), "\"~s\"", [Escaped]),
             atom_json_term(Json, Back, [value_string_as(string)]),   % JSON text: the oracle reader
             assertion(Back == Text) )).

test(bad_lines_are_rejected_with_a_reason) :-
    forall(member(Line, ["not json", "{\"event\": \"a(\", \"t\": 1}", "{\"event\": \"a(X)\", \"t\": 1}",
                         "{\"event\": \"a\"}", "{\"event\": \"a\", \"t\": \"soon\"}",
                         "{\"event\": \"a\", \"start\": 3, \"end\": 2}", "{\"event\": \"a\", \"t\": 1} x",
                         "{\"event\": \"a. b\", \"t\": 1}", "[1, 2]"]),
           ( with_each_reader(( rtl_parse_event_line(Line, Parsed),
                                assertion(Parsed = error(_)),
                                Parsed = error(Reason), assertion(string(Reason)) )) )).

test(control_and_clock_lines) :-
    rtl_parse_event_line("{\"op\": \"clock\", \"t\": 5}", C), assertion(C == clock(5)),
    rtl_parse_event_line("{\"op\": \"add_rule\", \"rule\": \"r(X) <- a(X).\"}", R), assertion(R == rule(add, "r(X) <- a(X).")),
    rtl_parse_event_line("{\"op\": \"delete_rule\", \"rule\": \"r1\"}", D), assertion(D = rule(delete, _)),
    rtl_parse_event_line("", B), assertion(B == blank).

test(too_deep_events) :-
    length(L, 50), maplist(=(f), L),
    foldl([F, In, Out]>>(Out =.. [F, In]), L, x, Deep),
    format(string(Text), "~q", [Deep]),
    format(string(Line), "{\"event\": \"~s\", \"t\": 1}", [Text]),
    rtl_parse_event_line(Line, 10, P1), assertion(P1 = error(_)),
    rtl_parse_event_line(Line, 100, P2), assertion(P2 = event(add, Deep, 1, 1)).

:- end_tests(rtl_io).

% One element of each line of rtl_output_data/2 against its record: the writeq text and times,
% and the term as data (an atom a string, ["c", Name, Args...], ["l", Items...], ["s", Text]).
output_reads_back(event(E, S, T, Consumer, Op), Output, Data) :-
    (   Consumer == (-), Op == add
    ->  assertion(Output = [_, S, T]),
        Output = [Text|_]
    ;   assertion(Output = json(_)),
        Output = json(Pairs),
        memberchk(event=Text, Pairs), assertion(memberchk(start=S, Pairs)), assertion(memberchk(end=T, Pairs)),
        ( Op == retract -> assertion(memberchk(op="retract", Pairs)) ; assertion(\+ memberchk(op=_, Pairs)) ),
        (   Consumer == echo(input) -> assertion(memberchk(input= @(true), Pairs))
        ;   Consumer == (-) -> true
        ;   atom_string(Consumer, C), assertion(memberchk(consumer=C, Pairs))
        )
    ),
    term_string(Back, Text),
    assertion(Back =@= E),
    data_term(Data, FromData),
    assertion(FromData =@= E).

data_term(Data, Term) :-
    (   string(Data) -> atom_string(Term, Data)
    ;   number(Data) -> Term = Data
    ;   Data = ["l"|Items] -> maplist(data_term, Items, Term)
    ;   Data = ["s", Text] -> Term = Text
    ;   Data = ["c", Name|Args] -> maplist(data_term, Args, Ts), atom_string(N, Name), compound_name_arguments(Term, N, Ts)
    ).

