suffix(L, L) :- list(L).
suffix(T, L) :- suffix(S, L), S = [_|T].
member_(X, L) :- suffix([X|_], L).
has(Box, X) :- box(Box, L), member_(X, L), item(X).
wrapped(f(g(X), [X, Y])) :- pair(X, Y), X < Y.
item(a). item(b). item(c). item(f(1)).
list([a, b, c]).
list([f(1), c]).
box(b1, [a, b, c]).
box(b2, [f(1), c]).
pair(1, 2).
pair(3, 2).
