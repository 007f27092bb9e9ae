% Issue: with e(0, 1) listed twice the Optimized transformation created a second table for the
% state waiting on q(1, Y) and crashed (trie_insert/3: No permission to modify trie_key).
p(X, Y) :- e(X, Z), q(Z, Y).
q(X, Y) :- e(X, Y).
e(0, 1).
e(0, 1).
e(1, 2).
