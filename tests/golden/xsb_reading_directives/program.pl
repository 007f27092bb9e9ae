% Directives XSB and SWI-Prolog accept that do not change what the program means: the
% file's encoding, a flag for reading the text (double_quotes, applied to the clauses after
% it), a library (rule bodies use the definite builtins only: ignored with a note).
:- encoding(utf8).
:- set_prolog_flag(double_quotes, codes).
:- ensure_loaded(library(lists)).
:- dynamic word/2, pair/2.
word(1, "ab").
word(2, "straße").
word(3, [0'a, 0'b]).
pair(1, 2).
pair(1, 3).
same_text(X, Y) :- pair(X, Y), word(X, T), word(Y, T).
two_letters(N) :- word(N, [_, _]).
