% Rules asserted and retracted at run time (update lines `+(H :- B).` and `-(H :- B).`).
:- dynamic edge/2.
edge(1, 2). edge(2, 3). edge(3, 4). edge(4, 2).
path(X, Y) :- edge(X, Y).
