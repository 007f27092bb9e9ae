a(X, Z) :- b(X, Y), c(Y, Z), d(Z).
c(Y, Z) :- e(Y, Z).
b(1, 2).
c(2, 3).
d(3).
e(2, 4).
