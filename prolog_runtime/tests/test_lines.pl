/*  plunit tests of rtl_lines.pl: event lines as text. Random well-formed UTF-8 decodes to the
    characters it encodes (SWI-Prolog's own encoder is the oracle) and a byte that does not
    start a character is reported at its column, by the C decoder and by the Prolog one alike;
    lines are read up to the newline only (carriage returns at the ends dropped, a NUL kept),
    a line longer than the limit is read and skipped, and long runs of digits are found.

        swipl -g run_tests -t halt prolog_runtime/tests/test_lines.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(random)).
:- use_module(library(utf8)).
:- use_module(library(yall)).
:- use_module('../rtl_lines').

% The UTF-8 bytes of a list of codes, by SWI-Prolog's library(utf8).
utf8_bytes(Codes, Bytes) :-
    phrase(utf8_codes(Codes), Bytes).

random_code(C) :-
    random_member(Range, [0x20-0x7e, 0xa0-0x7ff, 0x800-0xd7ff, 0xe000-0xfffd, 0x10000-0x10ffff]),
    Range = Lo-Hi,
    random_between(Lo, Hi, C).

% Both decoders: the C one when it was built, and the Prolog one.
with_each_decoder(Goal) :-
    \+ \+ call(Goal),
    (   rtl_lines:c_decoder
    ->  setup_call_cleanup(retract(rtl_lines:c_decoder), \+ \+ call(Goal), assertz(rtl_lines:c_decoder))
    ;   true
    ).

decode(Bytes, Line) :-
    string_codes(S, Bytes),
    rtl_utf8_line(S, Line).

:- begin_tests(rtl_lines).

test(random_utf8_decodes_to_its_characters) :-
    set_random(seed(36)),
    with_each_decoder(
        forall(between(1, 300, _),
               ( random_between(0, 12, N), length(Codes, N), maplist(random_code, Codes),
                 utf8_bytes(Codes, Bytes),
                 decode(Bytes, Line),
                 string_codes(Expected, Codes),
                 assertion(Line == Expected) ))).

test(a_bad_byte_is_reported_at_its_column) :-
    set_random(seed(7)),
    with_each_decoder(
        forall(between(1, 300, _),
               ( random_between(0, 6, N), length(Before, N), maplist(random_code, Before),
                 random_member(Bad, [0x80, 0xbf, 0xc0, 0xc1, 0xf5, 0xff]),
                 utf8_bytes(Before, Bytes0),
                 append(Bytes0, [Bad, 0x61], Bytes),
                 decode(Bytes, Line),
                 Column is N + 1,
                 format(string(Reason), "not UTF-8 text (byte 0x~16R at column ~d)", [Bad, Column]),
                 assertion(Line == not_text(Reason)) ))).

test(ill_formed_sequences) :-
    with_each_decoder(
        forall(member(Bytes-Byte, [[0xe0, 0x80, 0x80]-0xe0,      % overlong
                                   [0xed, 0xa0, 0x80]-0xed,      % a surrogate
                                   [0xf4, 0x90, 0x80, 0x80]-0xf4, % beyond U+10FFFF
                                   [0xe2, 0x82]-0xe2]),          % cut short
               ( decode(Bytes, Line),
                 assertion(Line = not_text(_)),
                 Line = not_text(Reason),
                 format(string(Hex), "0x~16R", [Byte]),
                 assertion(sub_string(Reason, _, _, _, Hex)) ))).

test(lines_end_at_newlines_only) :-
    char_code(Nul, 0),
    format(string(Text), "a\r\nb~wc\n\n\rd", [Nul]),
    rtl_split_lines(Text, Lines),
    atomic_list_concat(["b", Nul, "c"], BNC), atom_string(BNC, BNCs),
    assertion(Lines == ["a\r", BNCs, "", "\rd"]),
    rtl_split_lines("x\ny", XY), assertion(XY == ["x", "y"]).

test(read_line_drops_carriage_returns_at_the_ends) :-
    with_each_decoder(
        ( open_string("\r\ra\rb\r\r\nnext\n", In),
          set_stream(In, encoding(iso_latin_1)),
          rtl_read_line(In, L1), rtl_read_line(In, L2), rtl_read_line(In, L3),
          close(In),
          assertion(L1 == "a\rb"), assertion(L2 == "next"), assertion(L3 == end_of_file) )).

test(a_long_line_is_skipped_and_the_next_read) :-
    with_each_decoder(
        ( open_string("0123456789\nok\n", In),
          set_stream(In, encoding(iso_latin_1)),
          rtl_read_line(In, 5, L1), rtl_read_line(In, 5, L2),
          close(In),
          assertion(L1 == too_long("line longer than 5 bytes (max_line_bytes)")),
          assertion(L2 == "ok") )).

test(long_lines_counted_in_utf8_bytes) :-
    assertion(rtl_long_line("ééé", false, 5, too_long(_))),          % 6 bytes
    assertion(\+ rtl_long_line("ééé", false, 6, _)),
    assertion(\+ rtl_long_line("ééé", true, 5, _)),                  % 3 bytes already
    assertion(\+ rtl_long_line("anything", false, inf, _)).

test(nul_problem) :-
    char_code(Nul, 0),
    atomic_list_concat([abc, Nul, d], A), atom_string(A, S),
    rtl_nul_problem(S, P), assertion(P == "a NUL byte at column 4"),
    assertion(\+ rtl_nul_problem("abc", _)).

test(digit_runs) :-
    rtl_digits_problem("{\"t\": 123456}", 5, P),
    assertion(P == "more than 5 digits in a row at column 7 (max_digits)"),
    assertion(\+ rtl_digits_problem("{\"t\": 12345, \"x\": 12345}", 5, _)),
    assertion(\+ rtl_digits_problem("1234567890", inf, _)).

% Against a model: the first run of more than Max digits, on random texts.
test(digit_runs_against_a_model) :-
    set_random(seed(3)),
    forall(between(1, 500, _),
           ( random_between(0, 30, N), length(Cs, N),
             maplist([C]>>random_member(C, `0123456789a, `), Cs),
             string_codes(S, Cs), random_between(1, 6, Max),
             (   first_long_run(Cs, Max, Column)
             ->  format(string(P), "more than ~D digits in a row at column ~d (max_digits)", [Max, Column]),
                 assertion(rtl_digits_problem(S, Max, P))
             ;   assertion(\+ rtl_digits_problem(S, Max, _))
             ) )).

first_long_run(Codes, Max, Column) :-
    Len is Max + 1, length(Run, Len),
    append(Before, Rest, Codes),
    append(Run, _, Rest),
    maplist([C]>>code_type(C, digit), Run),
    \+ ( last(Before, B), code_type(B, digit) ),
    !,
    length(Before, K),
    Column is K + 1.

:- end_tests(rtl_lines).
