% XSB-style rule bodies: disjunction and if-then-else (normalised into clauses by aq_normalise)
:- dynamic person/2, knows/2.
person(ann, 34).
person(bob, 17).
person(cid, 70).
knows(ann, bob).
knows(bob, cid).
linked(X, Y) :- ( knows(X, Y) ; knows(Y, X) ).
linked(X, Z) :- knows(X, Y), ( knows(Y, Z) ; knows(Z, Y) ), X \== Z.
group(P, G) :-
    person(P, A),
    (   A < 18 -> G = minor
    ;   A >= 65 -> G = senior
    ;   G = adult
    ).
contact(P, Q, G) :- linked(P, Q), group(Q, G).
