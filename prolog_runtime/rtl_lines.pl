:- module(rtl_lines,
          [ rtl_read_line/2,            % +Stream, -Line
            rtl_split_lines/2,          % +Text, -Lines
            rtl_utf8_line/2,            % +Bytes, -Line
            rtl_nul_problem/2           % +Line, -Problem
          ]).

/** <module> Event lines as text: UTF-8, and what a line that is not UTF-8 becomes

An event input is split into lines at each newline byte, and only there (SWI-Prolog's
read_line_to_string/2, read_string/5 and split_string/4 also end a line at a NUL byte:
they are not used for that); the carriage returns at the start and end of a line are
dropped, a carriage return inside a line stays in it. A line holding a NUL byte is
rejected (rtl_nul_problem/2). Each line is then decoded as UTF-8 on its own (rtl_utf8_line/2): a line
that is not UTF-8 text is rejected, with the column of its first byte that is not, and the
lines after it are processed. The runtime's own loop (retalis.pl, the input read as ISO
Latin-1 bytes) and the Python driver (retalisc/driver/event_lines.py, which hands a batch
over as bytes when it is not all UTF-8) decode every line here, so both report the same
lines with the same numbers and reasons (docs/runtime.md, "Event input").

The decoding is done in C by `foreign/rtl_utf8.so` (`c/rtl_utf8.c`) when the set-up built
it, else in Prolog, with the same results.
*/

:- use_module(rtl_foreign).

:- dynamic c_decoder/0.

load_c_decoder :-
    retractall(c_decoder),
    (   rtl_load_foreign(rtl_utf8, rtl_utf8_decode/2)
    ->  assertz(c_decoder)
    ;   true
    ).

:- load_c_decoder.

%!  rtl_read_line(+Stream, -Line) is det.
%
%   The next line of Stream (read as ISO Latin-1: one code per byte), without its newline and
%   the carriage returns at its ends, decoded by rtl_utf8_line/2; `end_of_file` at the end.

rtl_read_line(Stream, Line) :-
    read_line_to_codes(Stream, Codes0),
    (   Codes0 == end_of_file
    ->  Line = end_of_file
    ;   without_carriage_returns(Codes0, Codes),
        string_codes(Bytes, Codes),
        rtl_utf8_line(Bytes, Line)
    ).

without_carriage_returns(Codes0, Codes) :-
    drop_returns(Codes0, Codes1),
    reverse(Codes1, Reversed0),
    drop_returns(Reversed0, Reversed),
    reverse(Reversed, Codes).

drop_returns([0'\r|Cs0], Cs) :- !, drop_returns(Cs0, Cs).
drop_returns(Cs, Cs).

%!  rtl_split_lines(+Text:string, -Lines:list(string)) is det.
%
%   The lines of Text, split at each newline and only there (a NUL byte stays in its line).

rtl_split_lines(Text, Lines) :-
    (   nul(Nul), sub_string(Text, _, 1, _, Nul)
    ->  atomic_list_concat(Parts, '\n', Text),
        maplist(atom_string, Parts, Lines)
    ;   split_string(Text, "\n", "", Lines)
    ).

nul(Nul) :- char_code(Nul, 0).

%!  rtl_nul_problem(+Line:string, -Problem:string) is semidet.
%
%   Line holds a NUL byte (no JSON text does); Problem says where: `a NUL byte at column 7`.

rtl_nul_problem(Line, Problem) :-
    string(Line),
    nul(Nul),
    sub_string(Line, Before, 1, _, Nul),
    !,
    Column is Before + 1,
    format(string(Problem), "a NUL byte at column ~d", [Column]).

%!  rtl_utf8_line(+Bytes, -Line) is det.
%
%   Line is the line Bytes (a string of codes 0..255; or `end_of_file`, itself) decoded as
%   UTF-8, or `not_text(Reason)` when Bytes is not well-formed UTF-8 (The Unicode
%   Standard, table 3-7): Reason is `not UTF-8 text (byte 0xFF at column 12)`, the first
%   byte that does not start a character and its column (1 + the characters before it).

rtl_utf8_line(end_of_file, Line) :- !,
    Line = end_of_file.
rtl_utf8_line(Bytes, Line) :-
    (   c_decoder
    ->  rtl_utf8_decode(Bytes, Decoded)
    ;   string_codes(Bytes, Codes),
        utf8_codes(Codes, 1, Chars, Decoded),
        (   var(Decoded) -> string_codes(Decoded, Chars) ; true )
    ),
    (   Decoded = bad(Column, Byte)
    ->  format(string(Reason), "not UTF-8 text (byte 0x~16R at column ~d)", [Byte, Column]),
        Line = not_text(Reason)
    ;   Line = Decoded
    ).

% utf8_codes(+Bytes, +Column, -Codes, ?Bad): Bad is bound to bad(Column, Byte) at the first
% byte that does not start a well-formed character.
utf8_codes([], _, [], _).
utf8_codes([B|Bs], Column, Codes, Bad) :-
    (   B < 0x80
    ->  Codes = [B|Cs], Rest = Bs
    ;   utf8_sequence(B, Bs, C, Rest0)
    ->  Codes = [C|Cs], Rest = Rest0
    ;   Bad = bad(Column, B), Codes = [], Rest = none
    ),
    (   Rest == none
    ->  true
    ;   Column1 is Column + 1,
        utf8_codes(Rest, Column1, Cs, Bad)
    ).

% A lead byte, the range of the byte after it, and how many bytes 0x80..0xBF follow that one.
utf8_sequence(B, [B1|Bs], C, Rest) :-
    lead(B, Lo, Hi, More, Bits),
    between(Lo, Hi, B1),
    C0 is (Bits << 6) \/ (B1 /\ 0x3f),
    continuations(More, Bs, C0, C, Rest).

lead(B, 0x80, 0xbf, 0, Bits) :- between(0xc2, 0xdf, B), !, Bits is B /\ 0x1f.
lead(0xe0, 0xa0, 0xbf, 1, 0) :- !.
lead(0xed, 0x80, 0x9f, 1, 0xd) :- !.
lead(B, 0x80, 0xbf, 1, Bits) :- between(0xe1, 0xef, B), !, Bits is B /\ 0x0f.
lead(0xf0, 0x90, 0xbf, 2, 0) :- !.
lead(0xf4, 0x80, 0x8f, 2, 4) :- !.
lead(B, 0x80, 0xbf, 2, Bits) :- between(0xf1, 0xf3, B), Bits is B /\ 0x07.

continuations(0, Bs, C, C, Bs) :- !.
continuations(N, [B|Bs], C0, C, Rest) :-
    between(0x80, 0xbf, B),
    C1 is (C0 << 6) \/ (B /\ 0x3f),
    N1 is N - 1,
    continuations(N1, Bs, C1, C, Rest).
