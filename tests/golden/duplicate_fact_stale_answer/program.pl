% Issue: a fact listed twice left t(0) an answer after e(0) was retracted (tabled and
% optimized): the state waiting on g(1) was created once per copy of e(0), DRed removed it once.
:- dynamic e/1, g/1.
t(Y) :- e(Y), g(1).
e(0).
e(0).
g(1).
