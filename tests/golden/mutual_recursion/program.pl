even(X) :- zero(X).
even(Y) :- succ_(X, Y), odd(X).
odd(Y) :- succ_(X, Y), even(X).
zero(0).
succ_(0, 1).
succ_(1, 2).
succ_(2, 3).
succ_(3, 4).
