path(X, Y) :- edge(X, Z), path(Z, Y).
path(X, Y) :- edge(X, Y).
edge(0, 1).
edge(1, 2).
edge(2, 3).
edge(3, 4).
edge(4, 5).
