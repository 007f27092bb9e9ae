:- module(rtl_lines,
          [ rtl_read_line/2,            % +Stream, -Line
            rtl_read_line/3,            % +Stream, +MaxBytes, -Line
            rtl_split_lines/2,          % +Text, -Lines
            rtl_utf8_line/2,            % +Bytes, -Line
            rtl_long_line/4,            % +Line, +Bytes, +MaxBytes, -TooLong
            rtl_nul_problem/2,          % +Line, -Problem
            rtl_digits_problem/3        % +Text, +MaxDigits, -Problem
          ]).

/** <module> Event lines as text: UTF-8, and what a line that is not UTF-8 becomes

An event input is split into lines at each newline byte, and only there (SWI-Prolog's
read_line_to_string/2, read_string/5 and split_string/4 also end a line at a NUL byte:
they are not used for that); the carriage returns at the start and end of a line are
dropped, a carriage return inside a line stays in it. A line holding a NUL byte is
rejected (rtl_nul_problem/2), and so is a line longer than the flag `max_line_bytes`
(rtl_read_line/3 reads at most that much of a line, and skips the rest; rtl_long_line/4) and
one with a run of more than `max_digits` digits (rtl_digits_problem/3, checked before
anything reads a number: the reader takes time quadratic in the digits). Each line is then decoded as UTF-8 on its own (rtl_utf8_line/2): a line
that is not UTF-8 text is rejected, with the column of its first byte that is not, and the
lines after it are processed. The runtime's own loop (retalis.pl, the input read as ISO
Latin-1 bytes) and the Python driver (retalisc/driver/event_lines.py, which hands a batch
over as bytes when it is not all UTF-8) decode every line here, so both report the same
lines with the same numbers and reasons (docs/runtime.md, "Event input").

The reading and decoding are done in C by `foreign/rtl_utf8.so` (`c/rtl_utf8.c`) when the
set-up built it, else in Prolog, with the same results.
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
%!  rtl_read_line(+Stream, +MaxBytes, -Line) is det.
%
%   The next line of Stream (read as ISO Latin-1: one code per byte), without its newline and
%   the carriage returns at its ends, decoded by rtl_utf8_line/2; `end_of_file` at the end.
%   A line of more than MaxBytes bytes (its newline not counted, `inf`: no limit; /2) is
%   `too_long(Reason)`: at most MaxBytes bytes of it are held, the rest is read and dropped.

rtl_read_line(Stream, Line) :-
    rtl_read_line(Stream, inf, Line).

rtl_read_line(Stream, MaxBytes, Line) :-
    (   c_decoder
    ->  ( MaxBytes == inf -> Max = -1 ; Max = MaxBytes ),
        rtl_read_line_bytes(Stream, Max, Read)
    ;   get_code(Stream, C0),
        line_codes(C0, Stream, MaxBytes, Codes0, Read0),
        (   var(Read0) -> Read = Codes0 ; Read = Read0 )
    ),
    (   Read == end_of_file
    ->  Line = end_of_file
    ;   Read == too_long
    ->  long_line_reason(MaxBytes, Reason),
        Line = too_long(Reason)
    ;   ( string(Read) -> string_codes(Read, Codes0) ; Codes0 = Read ),
        without_carriage_returns(Codes0, Codes),
        string_codes(Bytes, Codes),
        rtl_utf8_line(Bytes, Line)
    ).

% line_codes(+Code, +Stream, +Left, -Codes, -Read): the codes of a line from Code on; Read
% is bound to `end_of_file` at the end of the input, `too_long` after more than Left codes
% (the rest of the line read and dropped).
line_codes(-1, _, _, [], end_of_file) :- !.
line_codes(C0, Stream, Left, Codes, Read) :-
    line_rest(C0, Stream, Left, Codes, Read).

line_rest(-1, _, _, [], _) :- !.
line_rest(0'\n, _, _, [], _) :- !.
line_rest(_, Stream, 0, [], too_long) :- !,
    skip(Stream, 0'\n).
line_rest(C, Stream, Left, [C|Cs], Read) :-
    ( Left == inf -> Left1 = inf ; Left1 is Left - 1 ),
    get_code(Stream, C1),
    line_rest(C1, Stream, Left1, Cs, Read).

long_line_reason(MaxBytes, Reason) :-
    format(string(Reason), "line longer than ~D bytes (max_line_bytes)", [MaxBytes]).

%!  rtl_long_line(+Line, +Bytes:boolean, +MaxBytes, -TooLong) is semidet.
%
%   Line (a string; of bytes, codes 0..255, when Bytes is `true`, else of characters,
%   counted as their UTF-8 bytes) is longer than MaxBytes bytes: TooLong is the line as
%   rtl_read_line/3 reads it, `too_long(Reason)`.

rtl_long_line(Line, Bytes, MaxBytes, too_long(Reason)) :-
    MaxBytes \== inf,
    string_length(Line, Length),
    (   Length > MaxBytes
    ->  true
    ;   Bytes \== true,
        Length * 4 > MaxBytes,
        string_code_bytes(Line, N),
        N > MaxBytes
    ),
    long_line_reason(MaxBytes, Reason).

% The UTF-8 bytes of the characters of a string.
string_code_bytes(Line, N) :-
    string_codes(Line, Codes),
    foldl(code_bytes, Codes, 0, N).

code_bytes(C, N0, N) :-
    (   C < 0x80 -> N is N0 + 1
    ;   C < 0x800 -> N is N0 + 2
    ;   C < 0x10000 -> N is N0 + 3
    ;   N is N0 + 4
    ).

%!  rtl_digits_problem(+Text:string, +MaxDigits, -Problem:string) is semidet.
%
%   Text holds a run of more than MaxDigits digits 0-9 (`inf`: no limit), a number too
%   long to read, or digits in a text; Problem says where: `more than 4,300 digits in a row
%   at column 12 (max_digits)`.

rtl_digits_problem(Text, MaxDigits, Problem) :-
    MaxDigits \== inf,
    string_length(Text, Length),
    Length > MaxDigits,
    string_codes(Text, Codes),
    long_digit_run(Codes, 1, 0, MaxDigits, Column),
    format(string(Problem), "more than ~D digits in a row at column ~d (max_digits)", [MaxDigits, Column]).

long_digit_run([C|Cs], Column, Run, Max, Start) :-
    (   C >= 0'0, C =< 0'9
    ->  Run1 is Run + 1,
        (   Run1 > Max
        ->  Start is Column - Run
        ;   Column1 is Column + 1,
            long_digit_run(Cs, Column1, Run1, Max, Start)
        )
    ;   Column1 is Column + 1,
        long_digit_run(Cs, Column1, 0, Max, Start)
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
