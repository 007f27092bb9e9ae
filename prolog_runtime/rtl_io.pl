:- module(rtl_io,
          [ rtl_parse_event_line/2,      % +LineString, -Parsed
            rtl_parse_event_line/3,      % +LineString, +MaxDepth, -Parsed
            rtl_read_event_text/4,       % +Text, +MaxDepth, -Event, -Problem
            rtl_buffered_lines/3,        % +Stream, +MaxDepth, -Items
            rtl_event_json/6,            % +Event, +Start, +End, +Consumer, +Op, -JsonString
            rtl_write_event_line/4,      % +Stream, +Event, +Start, +End
            rtl_output_data/2,           % +Records, -JsonString
            rtl_output_record_line/2,    % +Record, -JsonString
            rtl_json_string_escape/2,    % +Text, -Escaped
            rtl_use_fast_reader/1,       % +Bool
            rtl_fast_reader_used/0,
            rtl_too_deep_text/2          % +Text, +MaxDepth
          ]).

/** <module> Event JSON Lines in and out (docs/runtime.md, "Event input" and "Output")

Input, one object per line: `"event"` is a ground term in Prolog syntax (text); the time
is `"t"` (an atomic event) or `"start"` and `"end"`; `"op": "retract"` deletes a previously
added identical event. Times are numbers of seconds, or ROS stamps `[Secs, NSecs]`.

Output: `{"event": TEXT, "start": N, "end": N}`, plus `"consumer": NAME` for subscription
deliveries and `"op": "retract"` for deletions. Terms are written with writeq/1.

The common case (plain keys, an event text of identifiers, numbers, quoted atoms without
escapes and lists) is read in C by `foreign/rtl_fastread.so` when the set-up built it
(`c/rtl_fastread.c`); it takes only lines whose reading is beyond doubt and fails for the
others. A JSON object is also a Prolog term (`{"k": V, ...}`), so the remaining lines are
read by the Prolog reader in one call; lines it cannot read (JSON-only escapes such as
`\/`, or bad input) go through library(http/json) (loaded by the first such line), which
also names the reason of a rejection. Without the C reader, every line takes the Prolog road, with the same results.
*/

:- use_module(rtl_time).
:- use_module(rtl_lines, [rtl_nul_problem/2, rtl_digits_problem/3, rtl_long_line/4]).
:- use_module(rtl_event_types, [rtl_event_text_refused/2, rtl_event_type_refused/2]).
:- use_module(rtl_foreign).
:- use_module(rtl_flags, [rtl_flag/2]).

:- dynamic fast_reader/0, fast_writer/0, fast_data_writer/0.

% The C reader is optional: a runtime without it (not built, another platform) reads
% every line in Prolog.
load_fast_reader :-
    (   rtl_load_foreign(rtl_fastread, rtl_fast_event_line/8)
    ->  retractall(fast_reader),
        assertz(fast_reader),
        fast_writer_present
    ;   true
    ).

% The C helpers for output lines (rtl_event_json/6) and output data (rtl_output_data/2)
% come with the reader.
fast_writer_present :-
    retractall(fast_writer),
    (   current_predicate(rtl_fast_event_json/4)
    ->  assertz(fast_writer)
    ;   true
    ),
    retractall(fast_data_writer),
    (   current_predicate(rtl_fast_output_data/2)
    ->  assertz(fast_data_writer)
    ;   true
    ).

:- load_fast_reader.

%!  rtl_use_fast_reader(+Bool) is det.
%
%   Read the common case of event lines and write the common case of output lines in C
%   (`true`, the default when the C helpers are built) or everything in Prolog (`false`).
%   For tests comparing the two.

rtl_use_fast_reader(true) :-
    (   current_predicate(rtl_fast_event_line/8)
    ->  retractall(fast_reader),
        assertz(fast_reader),
        fast_writer_present
    ;   existence_error(foreign_library, rtl_fastread)
    ).
rtl_use_fast_reader(false) :-
    retractall(fast_reader),
    retractall(fast_writer),
    retractall(fast_data_writer).

% While the cap on event types is set, lines are read in Prolog (rtl_event_types.pl: the C
% reader makes the event's term before its type could be checked); the C reader is back
% when the cap is taken off.
:- dynamic reader_held_back/0.
:- multifile rtl_event_types:capped_hook/1.
rtl_event_types:capped_hook(false) :-
    (   retract(reader_held_back) -> rtl_use_fast_reader(true) ; true ).
rtl_event_types:capped_hook(true) :-
    (   fast_reader
    ->  rtl_use_fast_reader(false),
        assertz(reader_held_back)
    ;   true
    ).

%!  rtl_fast_reader_used is semidet.
%
%   The common case of event lines is read in C now (rtl_use_fast_reader/1).

rtl_fast_reader_used :-
    fast_reader.

%!  rtl_parse_event_line(+Line:string, -Parsed) is det.
%!  rtl_parse_event_line(+Line:string, +MaxDepth:integer, -Parsed) is det.
%
%   Parsed is `blank`, `event(Op, Event, Start, End)` with Op `add` or `retract`,
%   `rule(add, RuleText)` or `rule(delete, Label)` for the control lines
%   `{"op": "add_rule", "rule": TEXT}` and `{"op": "delete_rule", "rule": LABEL}`,
%   `clock(Time)` for a clock line `{"op": "clock", "t": T}` (a heartbeat), or
%   `error(Reason)` with Reason a string saying what is wrong with the line (one holding a
%   NUL byte is). Line may also be `not_text(Reason)`, a line that is not UTF-8 text,
%   or `too_long(Reason)`, a line longer than the flag `max_line_bytes` (rtl_lines.pl):
%   either is `error(Reason)`; so is a Line longer than that. A line with a run of more than `max_digits` digits
%   (rtl_digits_problem/3) is rejected before anything of it is read.
%
%   The line must be one JSON object and nothing else; the event a ground term and nothing
%   else (a final full stop is allowed), nested at most MaxDepth levels deep (default
%   1,000; list tails do not count); times finite JSON numbers of seconds or ROS stamps
%   `[Secs, NSecs]` with integers and 0 =< NSecs < 10^9, `start` not after `end`.

rtl_parse_event_line(Line, Parsed) :-
    rtl_parse_event_line(Line, 1000, Parsed).

rtl_parse_event_line(not_text(Reason), _, Parsed) :- !,
    Parsed = error(Reason).
rtl_parse_event_line(too_long(Reason), _, Parsed) :- !,
    Parsed = error(Reason).
rtl_parse_event_line(Line, _, Parsed) :-        % a line given whole (rtl_feed_lines/4)
    input_limit(max_line_bytes, MaxBytes),
    rtl_long_line(Line, false, MaxBytes, too_long(Reason)),
    !,
    Parsed = error(Reason).
rtl_parse_event_line(Line, MaxDepth, Parsed) :-
    fast_reader,
    c_limit(max_digits, MaxDigits),
    rtl_fast_event_line(Line, MaxDepth, MaxDigits, Event, T, S, E, Op),
    (   number(T), var(S), var(E)               % "t": a finite number (the C reader checks)
    ->  Start = T, End = T
    ;   rtl_input_interval(T, S, E, Start, End, Problem),
        var(Problem)
    ),
    !,
    ( Op == retract -> Op1 = retract ; Op1 = add ),
    Parsed = event(Op1, Event, Start, End).
rtl_parse_event_line(Line, MaxDepth, Parsed) :-
    string_length(Line, Length),
    (   Length > MaxDepth                       % only a long text can be deep
    ->  Depth = MaxDepth
    ;   Depth = short
    ),
    input_limit(max_digits, MaxDigits),
    (   rtl_nul_problem(Line, Reason)          % first: split_string/4 takes NUL for layout
    ->  Parsed = error(Reason)
    ;   rtl_digits_problem(Line, MaxDigits, Reason)
    ->  Parsed = error(Reason)
    ;   blank_line(Line)
    ->  Parsed = blank
    ;   Depth \== short, too_deep_text(Line, MaxDepth)
    ->  depth_reason(MaxDepth, Reason),
        Parsed = error(Reason)
    ;   catch(line_fields(Line, Length, Record), _, fail)
    ->  record_event(Record, Depth, Parsed)
    ;   catch(json_fields(Line, Fields), error(Error, _), true)
    ->  (   var(Error)
        ->  fields_record(Fields, Record),
            record_event(Record, Depth, Parsed)
        ;   json_error_reason(Error, Reason),
            Parsed = error(Reason)
        )
    ;   Parsed = error("not a JSON object")
    ).

%!  rtl_buffered_lines(+Stream, +MaxDepth:integer, -Items:list) is det.
%
%   The lines already read into Stream's input buffer (at most 4,096), taken from the
%   stream without waiting for more input, by the C reader: each is `a(Event, T)`, an event
%   line with a time `"t"` only that rtl_parse_event_line/3 would read as
%   `event(add, Event, T, T)`, or `l(Line)`, any other line as read_line_to_string/2 would
%   read it (to go through rtl_parse_event_line/3). Items is `[]` when no complete line is
%   buffered, when the next line holds a byte outside 0x01..0x7f (read_line_to_string/2
%   decodes it) or when the C reader is not in use.

rtl_buffered_lines(Stream, MaxDepth, Items) :-
    (   fast_reader
    ->  c_limit(max_digits, MaxDigits),
        c_limit(max_line_bytes, MaxBytes),
        rtl_fast_read_lines(Stream, 4096, MaxDepth, MaxDigits, MaxBytes, Items)
    ;   Items = []
    ).

% The value of a limit flag for the C reader: -1 for none (`inf`).
c_limit(Flag, Limit) :-
    input_limit(Flag, Value),
    ( Value == inf -> Limit = -1 ; Limit = Value ).

% An input limit is a flag of the runtime (rtl_flags.pl).
input_limit(Flag, Value) :-
    rtl_flag(Flag, Value).

rule_change("add_rule", add).
rule_change("delete_rule", delete).

blank_line(Line) :-
    split_string(Line, "", " \t\r\n", [""]).

% Fast path: the Prolog reader, which reads a JSON object as a term `{"k": V, ...}`. Only
% what is also JSON is accepted here: string keys, values that are strings, JSON numbers
% (checked on their text: Prolog also reads 0x10, 0'a, 1.0Inf, 1_000...), true, false,
% null and arrays of those; nothing after the object. Anything else goes to the JSON reader.
line_fields(Line, Length, R) :-
    term_string(Term, Line, [subterm_positions(Pos)]),
    Term = {Body},                              % (a variable fails json_value_text/3)
    Pos = brace_term_position(_, To, BodyPos),
    (   To =:= Length
    ->  true
    ;   sub_string(Line, To, _, 0, Rest),
        blank_line(Rest)
    ),
    R = f(_, _, _, _, _, _),
    body_record(Body, BodyPos, Line, R).

% Walk the pairs `"key": Value, ...` and their positions, filling the record of fields.
body_record((Pair, Pairs), term_position(_, _, _, _, [Pos, PairsPos]), Line, R) :- !,
    pair_record(Pair, Pos, Line, R),
    body_record(Pairs, PairsPos, Line, R).
body_record(Pair, Pos, Line, R) :-
    pair_record(Pair, Pos, Line, R).

pair_record(Key:Value, term_position(_, _, _, _, [_, ValuePos]), Line, R) :-
    string(Key),
    json_value_text(Value, ValuePos, Line),
    record_field(Key, Value, R).

json_value_text(V, _, _) :- string(V), !.
json_value_text(V, From-To, Line) :- number(V), !,
    Length is To - From,
    (   integer(V)
    ->  atom_length(V, Length),                 % as many characters as digits (and sign)
        (   V =:= 0
        ->  true
        ;   ( V < 0 -> First is From + 2 ; First is From + 1 ),
            string_code(First, Line, C),        % a leading 0: 0x.., 0'c, 0b.., 010...
            C \== 0'0
        )
    ;   sub_string(Line, From, Length, _, Text),
        json_number_text(Text)
    ).
json_value_text(V, _, _) :- atom(V), !, memberchk(V, [true, false, null]).
json_value_text(V, list_position(_, _, Positions, none), Line) :-
    is_list(V),
    maplist(json_value_text_(Line), V, Positions).

json_value_text_(Line, V, Pos) :- json_value_text(V, Pos, Line).

% A JSON number: -?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)?. For a text Prolog read as a
% number, it is enough that it has only those characters (no digit groups, Inf, NaN, 0x...)
% and no leading zero.
json_number_text(Text) :-
    split_string(Text, "", "0123456789.eE+-", [""]),
    (   sub_string(Text, 0, 1, _, "-") -> Skip = 1 ; Skip = 0 ),
    \+ ( sub_string(Text, Skip, 2, _, Two), string_code(1, Two, 0'0), string_code(2, Two, D),
          between(0'0, 0'9, D) ).

json_number_codes(Codes) :-
    phrase(json_num, Codes).

json_num --> optional_minus, int_part, optional_fraction, optional_exponent.
optional_minus --> "-", !.
optional_minus --> [].
int_part --> "0", !.
int_part --> [D], { between(0'1, 0'9, D) }, digits0.
optional_fraction --> ".", !, digit, digits0.
optional_fraction --> [].
optional_exponent --> [E], { E == 0'e ; E == 0'E }, !, optional_sign, digit, digits0.
optional_exponent --> [].
optional_sign --> [S], { S == 0'+ ; S == 0'- }, !.
optional_sign --> [].
digit --> [D], { between(0'0, 0'9, D) }.
digits0 --> digit, !, digits0.
digits0 --> [].

json_fields(Line, Fields) :-
    json_reader_loaded,
    setup_call_cleanup(open_string(Line, In),
                       ( json:json_read(In, Term, [value_string_as(string)]),
                         read_string(In, _, Rest) ),
                       close(In)),
    (   Term = json(Pairs)
    ->  true
    ;   throw(error(type_error(json_object, Term), _))
    ),
    (   blank_line(Rest)
    ->  true
    ;   throw(error(syntax_error(json(text_after_the_object)), _))
    ),
    string_codes(Line, Codes),
    (   json_numbers_valid(Codes)
    ->  true
    ;   throw(error(syntax_error(json(illegal_number)), _))
    ),
    maplist(json_pair, Pairs, Fields).

% library(http/json) is loaded by the first line that needs it: most input never does, and
% loading it is a quarter of the runtime's start-up.
json_reader_loaded :-
    (   current_predicate(json:json_read/3)
    ->  true
    ;   use_module(library(http/json), [])
    ).

% The JSON reader accepts some numbers JSON does not (010): check every number outside
% strings against the JSON grammar.
json_numbers_valid([]).
json_numbers_valid([C|Cs]) :-
    (   C == 0'"
    ->  skip_string(Cs, Rest),
        json_numbers_valid(Rest)
    ;   ( C == 0'- ; between(0'0, 0'9, C) )
    ->  number_run(Cs, Run, Rest),
        json_number_codes([C|Run]),
        json_numbers_valid(Rest)
    ;   json_numbers_valid(Cs)
    ).

skip_string([], []).
skip_string([C|Cs], Rest) :-
    (   C == 0'"
    ->  Rest = Cs
    ;   C == 0'\\, Cs = [_|Cs1]
    ->  skip_string(Cs1, Rest)
    ;   skip_string(Cs, Rest)
    ).

number_run([C|Cs], [C|Run], Rest) :-
    ( between(0'0, 0'9, C) ; memberchk(C, `+-.eE`) ),
    !,
    number_run(Cs, Run, Rest).
number_run(Cs, [], Cs).

json_pair(Key=Value0, KeyString-Value) :-
    atom_string(Key, KeyString0),
    json_text(KeyString0, KeyString),
    json_value(Value0, Value).

json_value(@(true), true) :- !.
json_value(@(false), false) :- !.
json_value(@(null), null) :- !.
json_value(S0, S) :- string(S0), !, json_text(S0, S).
json_value(L0, L) :- is_list(L0), !, maplist(json_value, L0, L).
json_value(V, V).

%   json_text(+Read, -Text) is det.
%
%   A string as library(http/json) reads it, with each UTF-16 surrogate pair written as
%   two escapes (`\\ud83d\\udd25`, what Python's json.dumps writes for a character beyond
%   U+FFFF) made the one character it stands for, as the same text in UTF-8 reads. A lone
%   surrogate is no character: the line is rejected (`invalid JSON (a lone surrogate
%   \\uD83D)`).

json_text(Read, Text) :-
    string_codes(Read, Codes0),                 % (sub_string/5 cannot take a surrogate)
    (   member(C, Codes0), surrogate(C)
    ->  paired_surrogates(Codes0, Codes),
        string_codes(Text, Codes)
    ;   Text = Read
    ).

surrogate(C) :- C >= 0xD800, C =< 0xDFFF.

paired_surrogates([], []).
paired_surrogates([C|Cs0], [Char|Cs]) :-
    (   \+ surrogate(C)
    ->  Char = C, Rest = Cs0
    ;   C =< 0xDBFF, Cs0 = [Low|Rest], Low >= 0xDC00, Low =< 0xDFFF
    ->  Char is 0x10000 + ((C - 0xD800) << 10) + (Low - 0xDC00)
    ;   throw(error(syntax_error(json(lone_surrogate(C))), _))
    ),
    paired_surrogates(Rest, Cs).

json_error_reason(syntax_error(json(text_after_the_object)), Reason) :- !,
    Reason = "invalid JSON (text after the object)".
json_error_reason(syntax_error(json(lone_surrogate(Code))), Reason) :- !,
    format(string(Reason), "invalid JSON (a lone surrogate \\u~|~`0t~16R~4+)", [Code]).
json_error_reason(syntax_error(json(What)), Reason) :- !,
    format(string(Reason), "invalid JSON (~w)", [What]).
json_error_reason(syntax_error(What), Reason) :- !,
    format(string(Reason), "invalid JSON (~w)", [What]).
json_error_reason(type_error(_, _), "not a JSON object") :- !.
json_error_reason(evaluation_error(float_overflow), Reason) :- !,
    Reason = "\"t\" must be a finite number of seconds or [secs, nsecs] (float overflow)".
json_error_reason(Error, Reason) :-
    format(string(Reason), "invalid JSON (~q)", [Error]).

% The fields of a line in one record, f(Event, T, Start, End, Op, Rule), unset ones
% unbound (the first of duplicate keys counts; unknown keys are ignored).
fields_record(Fields, R) :-
    R = f(_, _, _, _, _, _),
    fill_record(Fields, R).

fill_record([], _).
fill_record([Key-Value|Fields], R) :-
    record_field(Key, Value, R),
    fill_record(Fields, R).

record_field(Key, Value, R) :-
    (   key_slot(Key, I)
    ->  arg(I, R, Slot),
        ( var(Slot) -> Slot = Value ; true )
    ;   true
    ).

key_slot("event", 1).
key_slot("t", 2).
key_slot("start", 3).
key_slot("end", 4).
key_slot("op", 5).
key_slot("rule", 6).

record_event(R, MaxDepth, Parsed) :-
    R = f(Text, T, S, E, Op, Rule),
    rtl_input_interval(T, S, E, Start, End, TimeProblem),
    (   nonvar(Op), rule_change(Op, Change)
    ->  (   string(Rule)
        ->  Parsed = rule(Change, Rule)
        ;   format(string(Reason), "\"op\": ~q needs \"rule\": the rule text (add_rule) or label (delete_rule)",
                   [Op]),
            Parsed = error(Reason)
        )
    ;   Op == "clock"                           % a clock line: the clock moves to "t"
    ->  (   nonvar(Text)
        ->  Parsed = error("a clock line (\"op\": \"clock\") has no \"event\"")
        ;   nonvar(TimeProblem)
        ->  Parsed = error(TimeProblem)
        ;   Parsed = clock(End)
        )
    ;   var(Text)
    ->  Parsed = error("missing \"event\"")
    ;   \+ string(Text)
    ->  Parsed = error("\"event\" must be a string holding a Prolog term")
    ;   nonvar(Op), Op \== "add", Op \== "retract"
    ->  format(string(Reason), "unknown \"op\" ~q (expected \"add\", \"retract\", \"clock\", \"add_rule\" or \"delete_rule\")", [Op]),
        Parsed = error(Reason)
    ;   nonvar(TimeProblem)
    ->  Parsed = error(TimeProblem)
    ;   rtl_read_event_text(Text, MaxDepth, Event, Problem),
        (   nonvar(Problem)
        ->  Parsed = error(Problem)
        ;   ( Op == "retract" -> Op1 = retract ; Op1 = add ),
            Parsed = event(Op1, Event, Start, End)
        )
    ).

%!  rtl_read_event_text(+Text:string, +MaxDepth, -Event, -Problem) is det.
%
%   Read the term of an event: Problem stays unbound when Text holds one ground callable
%   term (optionally followed by a full stop) nested at most MaxDepth levels deep, and is
%   a string saying what is wrong otherwise. MaxDepth `short` says that Text is known to
%   be shorter than the limit (so it cannot be deeper).

rtl_read_event_text(Text, MaxDepth, Event, Problem) :-
    (   MaxDepth \== short,
        too_deep_text(Text, MaxDepth)
    ->  depth_reason(MaxDepth, Problem)
    ;   rtl_event_text_refused(Text, Reason)          % --max-event-types, before a functor is made
    ->  Problem = Reason
    ;   catch(read_one_term(Text, Event, Problem), error(Formal, _), read_error(Formal, Problem))
    ->  (   nonvar(Problem)
        ->  true
        ;   \+ ground(Event)
        ->  Problem = "\"event\" must be ground (it has variables)"
        ;   \+ callable(Event)
        ->  Problem = "\"event\" must be an atom or a compound term"
        ;   rtl_event_type_refused(Event, Reason)
        ->  Problem = Reason
        ;   MaxDepth \== short,
            string_length(Text, Length), Length > MaxDepth,
            term_too_deep(Event, MaxDepth)
        ->  depth_reason(MaxDepth, Problem)
        ;   true
        )
    ;   Problem = "\"event\" is not a Prolog term"
    ).

% term_string/2 stops at the first full stop; text after it is an error. The reader only
% needs the positions when the text may hold a full stop followed by layout.
read_one_term(Text, Term, Problem) :-
    (   \+ split_string(Text, ".", "", [_]),      % it has a dot
        may_end_early(Text)
    ->  term_string(Term, Text, [subterm_positions(Pos)]),
        position_end(Pos, To),
        sub_string(Text, To, _, 0, Rest),
        split_string(Rest, "", " \t\r\n", [Left]),
        (   memberchk(Left, ["", "."])
        ->  true
        ;   Problem = "\"event\" has text after the term"
        )
    ;   term_string(Term, Text)
    ).

may_end_early(Text) :-
    sub_string(Text, Before, _, _, "."),
    After is Before + 1,
    (   sub_string(Text, After, 1, _, C)
    ->  memberchk(C, [" ", "\t", "\n", "\r", "%"])
    ;   true
    ),
    !.

position_end(_-To, To) :- !.
position_end(Pos, To) :- arg(2, Pos, To).

read_error(syntax_error(E), Problem) :- !,
    syntax_reason(E, Why),
    format(string(Problem), "\"event\" is not a Prolog term (syntax error: ~w)", [Why]).
read_error(resource_error(_), Problem) :- !,
    Problem = "\"event\" is too large to read".
read_error(Formal, Problem) :-
    format(string(Problem), "\"event\" cannot be read (~q)", [Formal]).

syntax_reason(end_of_clause, "unexpected end of the term") :- !.
syntax_reason(end_of_clause_expected, "unexpected text after the term") :- !.
syntax_reason(operator_expected, "operator expected") :- !.
syntax_reason(cannot_start_term, "unexpected character") :- !.
syntax_reason(end_of_file, "unexpected end of the term") :- !.
syntax_reason(E, E).

depth_reason(MaxDepth, Reason) :-
    format(string(Reason), "term nested deeper than ~D levels", [MaxDepth]).

%!  rtl_too_deep_text(+Text, +MaxDepth) is semidet.
%
%   Text opens more than MaxDepth brackets without closing them (quotes are not skipped,
%   so brackets in quoted text count too). Checked before reading: the reader recurses on
%   the C stack. A text no longer than MaxDepth cannot be that deep.

rtl_too_deep_text(Text, MaxDepth) :-
    too_deep_text(Text, MaxDepth).

too_deep_text(Text, MaxDepth) :-
    string_length(Text, Length),
    Length > MaxDepth,
    split_string(Text, "([{", "", Parts),           % fewer brackets than MaxDepth: not deep
    length(Parts, N),
    N > MaxDepth + 1,
    string_codes(Text, Codes),
    bracket_depth_exceeds(Codes, 0, MaxDepth).

bracket_depth_exceeds([C|Cs], D0, Max) :-
    (   ( C == 0'( ; C == 0'[ ; C == 0'{ )
    ->  D is D0 + 1,
        (   D > Max -> true ; bracket_depth_exceeds(Cs, D, Max) )
    ;   ( C == 0') ; C == 0'] ; C == 0'} )
    ->  D is D0 - 1,
        bracket_depth_exceeds(Cs, D, Max)
    ;   bracket_depth_exceeds(Cs, D0, Max)
    ).

%   term_too_deep(+Term, +MaxDepth) is semidet.
%
%   Term has compound terms nested more than MaxDepth deep; the tail of a list is not a
%   level deeper than the list (prefix and infix operators are: 1+1+...+1 is deep).

term_too_deep(Term, MaxDepth) :-
    \+ depth_within(Term, MaxDepth).

depth_within(Term, Left) :-
    (   compound(Term)
    ->  Left > 0,
        Left1 is Left - 1,
        (   Term = [H|T]
        ->  depth_within(H, Left1),
            list_tail_within(T, Left)
        ;   \+ ( arg(_, Term, Arg), \+ depth_within(Arg, Left1) )
        )
    ;   true
    ).

list_tail_within(T, Left) :-
    (   T = [H|T1]
    ->  Left1 is Left - 1,
        depth_within(H, Left1),
        list_tail_within(T1, Left)
    ;   depth_within(T, Left)
    ).

%!  rtl_event_json(+Event, +Start, +End, +Consumer, +Op, -Json:string) is det.
%
%   One output line (without the newline). Consumer is `-` for none, `echo(input)` for the
%   echo of an input event (the line then carries `"input": true`); Op is `add` or `retract`.

rtl_event_json(Event, Start, End, Consumer, Op, Json) :-
    Consumer == (-), Op \== retract,
    fast_writer,
    rtl_fast_event_json(Event, Start, End, Json),     % C: the common case (finite times)
    !.
rtl_event_json(Event, Start, End, Consumer, Op, Json) :-
    format(string(Text), "~q", [Event]),
    rtl_json_string_escape(Text, Escaped),
    json_number(Start, S),
    json_number(End, E),
    (   Consumer == (-), Op \== retract           % the common case: one format/3
    ->  format(string(Json), "{\"event\": \"~s\", \"start\": ~w, \"end\": ~w}", [Escaped, S, E])
    ;   (   Consumer == (-)
        ->  ConsumerPart = ""
        ;   Consumer == echo(input)                  % the echo of an input event (echo_input)
        ->  ConsumerPart = ", \"input\": true"
        ;   format(string(ConsumerText), "~w", [Consumer]),
            rtl_json_string_escape(ConsumerText, C),
            format(string(ConsumerPart), ", \"consumer\": \"~s\"", [C])
        ),
        (   Op == retract
        ->  OpPart = ", \"op\": \"retract\""
        ;   OpPart = ""
        ),
        format(string(Json), "{\"event\": \"~s\", \"start\": ~w, \"end\": ~w~s~s}",
               [Escaped, S, E, ConsumerPart, OpPart])
    ).

%!  rtl_output_record_line(+Record, -Json:string) is det.
%
%   The output line of a buffered output record (rtl_ele.pl): `event(Event, Start, End,
%   Consumer, Op)` is written by rtl_event_json/6, `json(Line)` (the result of a
%   synchronized query) is its line.

rtl_output_record_line(event(Event, Start, End, Consumer, Op), Line) :- !,
    rtl_event_json(Event, Start, End, Consumer, Op, Line).
rtl_output_record_line(json(Line), Line).

%!  rtl_output_data(+Records:list, -Json:string) is det.
%
%   Buffered output records (rtl_output_record_line/2) in the form in which outputs cross to
%   Python (docs/architecture.md, "The Python/Prolog boundary"; read by `read_answer` in
%   retalisc/driver/engine.py): two lines, each one JSON array with one element per record,
%   in order. The first holds the outputs:
%
%     - an event with no consumer and Op `add` (the common case): `[Text, Start, End]`;
%     - any other event: the object of its output line (`{"event": Text, "start": Start,
%       "end": End}` and `"input": true`, `"consumer": Name`, `"op": "retract"`);
%     - the result of a synchronized query: its JSON object (`{"query": ...}`), as its line.
%
%   Text is the term as writeq/1 writes it (the `"event"` of its output line); Start and End
%   as the line writes them. The second line holds each event's term as data (`null` for a
%   query's result), decoded by Python only when a term is asked for: an integer or a finite
%   float is a number, an atom a string, `[]` and a proper list `["l", Item...]`, a compound
%   `["c", Name, Arg...]`, a string `["s", Text]`, a float that is not finite `["f", "inf"]`
%   (`"-inf"`, `"nan"`), an unbound variable `["v", Name]` (Name as write/1 writes it), and
%   any other term (a blob) its writeq text as an atom. The C writer
%   (`rtl_fast_output_data/2`, c/rtl_fastread.c) writes the same bytes (tests/test_output_data_c.py).

rtl_output_data(Records, Json) :-
    fast_data_writer,
    rtl_fast_output_data(Records, Json0),
    !,
    Json = Json0.
rtl_output_data(Records, Json) :-
    with_output_to(string(Outputs),
                   ( write("["), separated(Records, output_element), write("]") )),
    with_output_to(string(Terms),
                   ( write("["), separated(Records, record_term), write("]") )),
    string_concat(Outputs, "\n", Json0),
    string_concat(Json0, Terms, Json).

separated([], _).
separated([X|Xs], Writer) :-
    call(Writer, X),
    (   Xs == []
    ->  true
    ;   write(","),
        separated(Xs, Writer)
    ).

output_element(event(Event, Start, End, Consumer, Op)) :- !,
    format(string(Text), "~q", [Event]),
    json_number(Start, S),
    json_number(End, E),
    (   Consumer == (-), Op \== retract
    ->  write("["), json_string_out(Text), format(",~w,~w]", [S, E])
    ;   write("{\"event\": "), json_string_out(Text),
        format(", \"start\": ~w, \"end\": ~w", [S, E]),
        (   Consumer == (-)
        ->  true
        ;   Consumer == echo(input)
        ->  write(", \"input\": true")
        ;   format(string(ConsumerText), "~w", [Consumer]),
            write(", \"consumer\": "), json_string_out(ConsumerText)
        ),
        (   Op == retract -> write(", \"op\": \"retract\"") ; true ),
        write("}")
    ).
output_element(json(Line)) :-
    write(Line).

record_term(event(Event, _, _, _, _)) :- !,
    term_data(Event).
record_term(json(_)) :-
    write(null).

json_string_out(Text) :-
    rtl_json_string_escape(Text, Escaped),
    format("\"~s\"", [Escaped]).

term_data(T) :-
    (   var(T)
    ->  format(string(Name), "~w", [T]),
        write("[\"v\","), json_string_out(Name), write("]")
    ;   integer(T)
    ->  write(T)
    ;   float(T)
    ->  (   T =\= T
        ->  write("[\"f\",\"nan\"]")
        ;   T =:= inf
        ->  write("[\"f\",\"inf\"]")
        ;   T =:= -inf
        ->  write("[\"f\",\"-inf\"]")
        ;   write(T)
        )
    ;   T == []
    ->  write("[\"l\"]")
    ;   atom(T)
    ->  json_string_out(T)
    ;   string(T)
    ->  write("[\"s\","), json_string_out(T), write("]")
    ;   is_list(T)
    ->  write("[\"l\""), data_items(T), write("]")
    ;   compound(T)
    ->  compound_name_arguments(T, Name, Args),
        write("[\"c\","), json_string_out(Name), data_items(Args), write("]")
    ;   format(string(Text), "~q", [T]),
        json_string_out(Text)
    ).

data_items([]).
data_items([X|Xs]) :-
    write(","),
    term_data(X),
    data_items(Xs).

%!  rtl_write_event_line(+Stream, +Event, +Start, +End) is semidet.
%
%   Write the output line of Event (no consumer, Op `add`) and a newline to Stream, in one
%   call, when the C writer can: Stream is UTF-8 and the times are finite. Fails without
%   writing anything otherwise (the caller then writes rtl_event_json/6's line).

rtl_write_event_line(Stream, Event, Start, End) :-
    fast_writer,
    rtl_fast_write_event(Stream, Event, Start, End).

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
    json_special(Special),
    (   split_string(Text, Special, "", [_]),      % one scan: nothing to escape
        \+ sub_string(Text, _, _, _, "\u0000")     % (split_string/4 misses a NUL at either end)
    ->  Escaped = Text
    ;   string_codes(Text, Codes),
        phrase(escaped(Codes), Out),
        string_codes(Escaped, Out)
    ).

% json_special(-Chars): the characters escaped in a JSON string, `"`, `\` and the control
% characters (NUL last: split_string/4 ignores the separators after a NUL).
:- dynamic json_special/1.
:- numlist(1, 0x1f, Controls),
   append([0'", 0'\\|Controls], [0], Codes),
   string_codes(Special, Codes),
   retractall(json_special(_)),
   assertz(json_special(Special)).

escaped([]) --> [].
escaped([C|Cs]) --> escaped_code(C), escaped(Cs).

escaped_code(0'") --> !, "\\\"".
escaped_code(0'\\) --> !, "\\\\".
escaped_code(0'\n) --> !, "\\n".
escaped_code(0'\t) --> !, "\\t".
escaped_code(C) --> { C < 0x20 }, !,
    { format(codes(Hex), "\\u~|~`0t~16r~4+", [C]) }, Hex.
escaped_code(C) --> [C].
