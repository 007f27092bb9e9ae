% A rule added by the update script for a predicate that has stored facts only: under XSB's
% incremental tabling the dynamic predicate becomes a mixed one (facts and rules). Its facts
% stay facts: removing the rule keeps what they give, removing a fact keeps what the rule
% derives (DRed).
:- table reaches/2 as incremental.
:- dynamic p/1 as incremental.
:- dynamic f/2, link/2.
p(1).
f(1, 5). f(2, 7).
link(5, 6). link(6, 8).
big(X) :- p(X), X > 2.
reaches(X, Y) :- p(X), link(X, Y).
reaches(X, Z) :- reaches(X, Y), link(Y, Z).
