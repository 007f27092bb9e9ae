sg(X, X) :- person(X).
sg(X, Y) :- par(X, XP), sg(XP, YP), par(Y, YP).
person(a). person(b). person(c). person(d). person(e). person(f).
par(b, a).
par(c, a).
par(d, b).
par(e, c).
par(f, e).
