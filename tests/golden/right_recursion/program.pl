anc(X, Y) :- par(X, Z), anc(Z, Y).
anc(X, Y) :- par(X, Y).
par(a, b).
par(b, c).
par(c, d).
