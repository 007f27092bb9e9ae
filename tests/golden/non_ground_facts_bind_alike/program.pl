% e(X, 1) and e(0, 1) both bind e(0, Y) to e(0, 1): the state after it has two derivations, and
% retracting either fact keeps t(1) (the state is re-derived from the other one).
:- dynamic e/2, g/2.
t(Y) :- e(0, Y), h(Y, W).
s(Y) :- e(0, Y), g(Y, W).
h(X, Y) :- g(X, Y).
e(X, 1).
e(0, 1).
g(1, 2).
