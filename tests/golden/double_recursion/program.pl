path(X, Y) :- path(X, Z), path(Z, Y).
path(X, Y) :- edge(X, Y).
edge(1, 2).
edge(2, 3).
edge(3, 4).
