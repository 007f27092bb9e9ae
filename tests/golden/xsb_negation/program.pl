% Stratified negation (\+, not/1, tnot/1) over tabled predicates: an added fact can remove
% answers and a deleted one can add answers.
:- table reach/2.
:- dynamic edge/2, node/1, blocked/1.
node(a). node(b). node(c). node(d).
edge(a, b). edge(b, c).
blocked(d).
reach(X, Y) :- edge(X, Y).
reach(X, Y) :- edge(X, Z), reach(Z, Y).
unreachable(X, Y) :- node(X), node(Y), X \== Y, \+ reach(X, Y).
isolated(X) :- node(X), not(edge(X, _)), tnot(has_in(X)).
has_in(X) :- edge(_, X).
open_sink(X) :- isolated(X), \+ (blocked(X), node(X)).
