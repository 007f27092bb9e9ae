% XSB-only directives: accepted, ignored with a note.
:- import member/2, append/3 from basics.
:- export path/2.
:- table path/2 as incremental.
:- dynamic edge/2 as incremental.
:- dynamic([seen/1 as incremental]).
edge(1, 2). edge(2, 3).
seen(1).
path(X, Y) :- edge(X, Y).
path(X, Y) :- path(X, Z), edge(Z, Y).
seen_path(X, Y) :- seen(X), path(X, Y).
