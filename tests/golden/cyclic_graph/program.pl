reach(X, Y) :- edge(X, Y).
reach(X, Y) :- reach(X, Z), edge(Z, Y).
reach(X, Y) :- edge(Y, X), reach(X, Y).
edge(1, 2).
edge(2, 3).
edge(3, 1).
edge(3, 4).
edge(5, 5).
