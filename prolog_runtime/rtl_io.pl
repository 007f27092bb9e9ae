:- module(rtl_io,
          [ rtl_parse_event_line/2,      % +LineString, -Parsed
            rtl_event_json/6,            % +Event, +Start, +End, +Consumer, +Op, -JsonString
            rtl_json_string_escape/2     % +Text, -Escaped
          ]).

/** <module> Event JSON Lines in and out (SPEC section 11)

Input, one object per line: `"event"` is a ground term in Prolog syntax (text); the time
is `"t"` (an atomic event) or `"start"` and `"end"`; `"op": "retract"` deletes a previously
added identical event. Times are numbers of seconds, or ROS stamps `[Secs, NSecs]`.

Output: `{"event": TEXT, "start": N, "end": N}`, plus `"consumer": NAME` for subscription
deliveries and `"op": "retract"` for deletions. Terms are written with writeq/1.

A JSON object is also a Prolog term (`{"k": V, ...}`), so the common case is read by the
Prolog reader in one call; lines it cannot read (JSON-only escapes such as `\/`, or bad
input) go through library(http/json), which also names the reason of a rejection.
*/

:- use_module(library(http/json)).
:- use_module(rtl_time).

%!  rtl_parse_event_line(+Line:string, -Parsed) is det.
%
%   Parsed is `blank`, `event(Op, Event, Start, End)` with Op `add` or `retract`,
%   `rule(add, RuleText)` or `rule(delete, Label)` for the control lines
%   `{"op": "add_rule", "rule": TEXT}` and `{"op": "delete_rule", "rule": LABEL}`, or
%   `error(Reason)` with Reason a string saying what is wrong with the line.

rtl_parse_event_line(Line, Parsed) :-
    (   blank_line(Line)
    ->  Parsed = blank
    ;   catch(line_fields(Line, Fields), _, fail)
    ->  fields_event(Fields, Parsed)
    ;   catch(json_fields(Line, Fields), error(Error, _), true)
    ->  (   var(Error)
        ->  fields_event(Fields, Parsed)
        ;   json_error_reason(Error, Reason),
            Parsed = error(Reason)
        )
    ;   Parsed = error("not a JSON object")
    ).

rule_change("add_rule", add).
rule_change("delete_rule", delete).

blank_line(Line) :-
    split_string(Line, "", " \t\r\n", [""]).

% Fast path: the Prolog reader. Only accept what is also JSON: an object of "key": value.
line_fields(Line, Fields) :-
    term_string(Term, Line, [variable_names(Vars)]),
    Vars == [],
    Term = {Body},
    comma_list(Body, Pairs),
    maplist(key_value, Pairs, Fields).

key_value(Key:Value, Key-Value) :-
    string(Key).

json_fields(Line, Fields) :-
    setup_call_cleanup(open_string(Line, In),
                       json_read(In, Term, [value_string_as(string)]),
                       close(In)),
    (   Term = json(Pairs)
    ->  true
    ;   throw(error(type_error(json_object, Term), _))
    ),
    maplist(json_pair, Pairs, Fields).

json_pair(Key=Value0, KeyString-Value) :-
    atom_string(Key, KeyString),
    json_value(Value0, Value).

json_value(@(true), true) :- !.
json_value(@(false), false) :- !.
json_value(@(null), null) :- !.
json_value(V, V).

json_error_reason(syntax_error(json(What)), Reason) :- !,
    format(string(Reason), "invalid JSON (~w)", [What]).
json_error_reason(syntax_error(What), Reason) :- !,
    format(string(Reason), "invalid JSON (~w)", [What]).
json_error_reason(type_error(_, _), "not a JSON object") :- !.
json_error_reason(Error, Reason) :-
    format(string(Reason), "invalid JSON (~q)", [Error]).

fields_event(Fields, Parsed) :-
    memberchk("op"-Op, Fields),
    rule_change(Op, Change),
    !,
    (   memberchk("rule"-Text, Fields), string(Text)
    ->  Parsed = rule(Change, Text)
    ;   format(string(Reason), "\"op\": ~q needs \"rule\": the rule text (add_rule) or label (delete_rule)",
               [Op]),
        Parsed = error(Reason)
    ).
fields_event(Fields, Parsed) :-
    (   field_problem(Fields, Reason)
    ->  Parsed = error(Reason)
    ;   memberchk("event"-Text, Fields),
        text_event(Text, Event, Problem),
        (   nonvar(Problem)
        ->  Parsed = error(Problem)
        ;   fields_op(Fields, Op),
            fields_interval(Fields, Start, End),
            Parsed = event(Op, Event, Start, End)
        )
    ).

field_problem(Fields, Reason) :-
    (   \+ memberchk("event"-_, Fields)
    ->  Reason = "missing \"event\""
    ;   memberchk("event"-Text, Fields), \+ string(Text)
    ->  Reason = "\"event\" must be a string holding a Prolog term"
    ;   memberchk("op"-Op, Fields), \+ memberchk(Op, ["add", "retract"])
    ->  format(string(Reason), "unknown \"op\" ~q (expected \"add\", \"retract\", \"add_rule\" or \"delete_rule\")", [Op])
    ;   interval_problem(Fields, Reason)
    ->  true
    ).

% Read the event text once; Problem stays unbound when it is a ground callable term.
text_event(Text, Event, Problem) :-
    catch(term_string(Event, Text, [variable_names(Vars)]), error(syntax_error(E), _),
          ( syntax_reason(E, Why),
            format(string(Problem), "\"event\" is not a Prolog term (syntax error: ~w)", [Why]) )),
    (   nonvar(Problem)
    ->  true
    ;   Vars \== []
    ->  Problem = "\"event\" must be ground (it has variables)"
    ;   \+ callable(Event)
    ->  Problem = "\"event\" must be an atom or a compound term"
    ;   true
    ).

syntax_reason(end_of_clause, "unexpected end of the term") :- !.
syntax_reason(end_of_clause_expected, "unexpected text after the term") :- !.
syntax_reason(operator_expected, "operator expected") :- !.
syntax_reason(cannot_start_term, "unexpected character") :- !.
syntax_reason(end_of_file, "unexpected end of the term") :- !.
syntax_reason(E, E).

interval_problem(Fields, Reason) :-
    (   memberchk("t"-_, Fields), ( memberchk("start"-_, Fields) ; memberchk("end"-_, Fields) )
    ->  Reason = "give either \"t\" or \"start\" and \"end\", not both"
    ;   memberchk("t"-T, Fields)
    ->  \+ rtl_time_seconds(T, _),
        Reason = "\"t\" must be a number of seconds or [secs, nsecs]"
    ;   memberchk("start"-S, Fields), memberchk("end"-E, Fields)
    ->  (   \+ rtl_time_seconds(S, _)
        ->  Reason = "\"start\" must be a number of seconds or [secs, nsecs]"
        ;   \+ rtl_time_seconds(E, _)
        ->  Reason = "\"end\" must be a number of seconds or [secs, nsecs]"
        ;   rtl_time_seconds(S, S1), rtl_time_seconds(E, E1), S1 > E1,
            Reason = "\"start\" is after \"end\""
        )
    ;   Reason = "missing time: give \"t\", or \"start\" and \"end\""
    ).

fields_op(Fields, Op) :-
    (   memberchk("op"-"retract", Fields)
    ->  Op = retract
    ;   Op = add
    ).

fields_interval(Fields, Start, End) :-
    (   memberchk("t"-T, Fields)
    ->  rtl_time_seconds(T, Start), End = Start
    ;   memberchk("start"-S, Fields), memberchk("end"-E, Fields),
        rtl_time_seconds(S, Start), rtl_time_seconds(E, End)
    ).

%!  rtl_event_json(+Event, +Start, +End, +Consumer, +Op, -Json:string) is det.
%
%   One output line (without the newline). Consumer is `-` for none; Op is `add` or
%   `retract`.

rtl_event_json(Event, Start, End, Consumer, Op, Json) :-
    format(string(Text), "~q", [Event]),
    rtl_json_string_escape(Text, Escaped),
    (   Consumer == (-)
    ->  ConsumerPart = ""
    ;   format(string(ConsumerText), "~w", [Consumer]),
        rtl_json_string_escape(ConsumerText, C),
        format(string(ConsumerPart), ", \"consumer\": \"~s\"", [C])
    ),
    (   Op == retract
    ->  OpPart = ", \"op\": \"retract\""
    ;   OpPart = ""
    ),
    json_number(Start, S),
    json_number(End, E),
    format(string(Json), "{\"event\": \"~s\", \"start\": ~w, \"end\": ~w~s~s}",
           [Escaped, S, E, ConsumerPart, OpPart]).

json_number(N, N) :- integer(N), !.
json_number(N, T) :-
    float(N),
    (   N =:= inf ; N =:= -inf ; N =\= N ), !,
    format(string(T), "\"~w\"", [N]).
json_number(N, N).

%!  rtl_json_string_escape(+Text, -Escaped:string) is det.
%
%   Text as the inside of a JSON string: `"` and `\` escaped, control characters as
%   `\u` and four hex digits.

rtl_json_string_escape(Text, Escaped) :-
    (   \+ sub_string(Text, _, _, _, "\""),
        \+ sub_string(Text, _, _, _, "\\"),
        \+ ( string_code(_, Text, C), C < 0x20 )
    ->  Escaped = Text
    ;   string_codes(Text, Codes),
        phrase(escaped(Codes), Out),
        string_codes(Escaped, Out)
    ).

escaped([]) --> [].
escaped([C|Cs]) --> escaped_code(C), escaped(Cs).

escaped_code(0'") --> !, "\\\"".
escaped_code(0'\\) --> !, "\\\\".
escaped_code(0'\n) --> !, "\\n".
escaped_code(0'\t) --> !, "\\t".
escaped_code(C) --> { C < 0x20 }, !,
    { format(codes(Hex), "\\u~|~`0t~16r~4+", [C]) }, Hex.
escaped_code(C) --> [C].
