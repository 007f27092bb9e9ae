notify(User, Artist, Price, [LX, LY]) :-
    show(Artist, Price, [LX, LY]),
    likes(User, Artist, MaxPrice, MaxDistance),
    Price < MaxPrice,
    loc(User, [Lx, Ly]),
    sqrt((LX - Lx) * (LX - Lx) + (LY - Ly) * (LY - Ly)) < MaxDistance.
loc(1, [6, 5]).
loc(2, [2, 6]).
show(1, 10, [2, 8]).
show(1, 4, [5, 5]).
show(2, 2, [4, 2]).
likes(1, 1, 9, 13.237514377220565).
likes(1, 2, 3, 5.851154344003308).
likes(2, 2, 5, 2.5).
likes(2, 1, 11, 4).
