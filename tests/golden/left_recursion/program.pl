anc(X, Y) :- anc(X, Z), par(Z, Y).
anc(X, Y) :- par(X, Y).
par(a, b).
par(b, c).
par(c, d).
