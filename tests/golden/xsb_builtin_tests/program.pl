% XSB-style builtin tests written before the literals that bind their arguments: XSB
% evaluates them once their arguments are bound, the aq_join_order pass places them there.
:- table path/2 as incremental.
:- dynamic edge/2, weight/2, label/2.
edge(a, b). edge(b, c). edge(c, d). edge(b, d).
weight(a, 3). weight(b, 8). weight(c, 5). weight(d, 8).
label(a, x). label(b, y). label(c, x). label(d, f(z)).
path(X, Y) :- edge(X, Y).
path(X, Y) :- edge(X, Z), path(Z, Y).
% a path that leaves its start (\=), between differently labelled nodes (\==)
trip(X, Y) :- X \= Y, L1 \== L2, path(X, Y), label(X, L1), label(Y, L2).
% the same label (==), compound labels included
twin(X, Y) :- L == M, label(X, L), label(Y, M), X @< Y.
% comparisons and arithmetic over the weights of an edge's ends
heavier(X, Y) :- WX > WY, edge(X, Y), weight(X, WX), weight(Y, WY).
even_split(X, Y, S) :- S is WX + WY, S mod 2 =:= 0, edge(X, Y), weight(X, WX), weight(Y, WY).
at_least(X, K) :- W >= K, weight(X, W), label(X, _), member_of(K).
member_of(4). member_of(8).
% if-then-else over a test
rank(X, R) :- ( W >= 6 -> R = high ; R = low ), weight(X, W).
