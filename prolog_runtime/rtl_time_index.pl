:- module(rtl_time_index,
          [ time_index_add/4,           % +Index, +Key, +Time, +Item
            time_index_remove/4,        % +Index, +Key, +Time, +Item
            time_index_take/5,          % +Index, +Key, +Order, +Limit, -Items
            time_index_count/3,         % +Index, +Key, -Count
            time_index_clear/1          % +Index
          ]).

/** <module> Items waiting for a time, found by the time that has come (rtl_sync's waits)

A time index holds items, each under a Key with a Time, and answers one question fast: which
items of Key have a time before a limit (`<` or `=<`)? rtl_sync asks it for the postponed
matches a new memory record wakes (waiting for a record that ends after their time) and for
those whose deadline the clock has passed. With thousands of waiting matches and thousands
of records per second, a scan of all waiting items per record costs what the thesis says
synchronization must not cost (5.2.2); here a question costs what it returns.

Items are stored in buckets of 10 ms of time (`entry(Bucket, Index, Key, Time, Item)`: the
bucket comes first, so first-argument indexing finds a bucket's few items). For each Key the
index keeps a *low bucket*: no item of Key lies in a bucket below it. A question with limit L
visits the buckets from the low bucket to L's bucket and then moves the low bucket there;
when that range is longer than the number of items of Key (times far apart), it scans the
items of Key instead. So the empty buckets visited add up to at most the span of time the
low bucket moves over, plus one scan per question of at most the items there are.
*/

:- dynamic entry/5.         % entry(Bucket, Index, Key, Time, Item)
:- dynamic low_bucket/4.    % low_bucket(Index, Key, Bucket, Count)

buckets_per_second(100).

bucket(T, B) :-
    (   T =:= inf -> B = inf
    ;   T =:= -inf -> B = -inf
    ;   buckets_per_second(R),
        B is floor(T * R)
    ).

%!  time_index_add(+Index, +Key, +Time, +Item) is det.
%
%   Store Item under Key with Time (a number, possibly infinite).

time_index_add(Index, Key, T, Item) :-
    bucket(T, B),
    assertz(entry(B, Index, Key, T, Item)),
    (   retract(low_bucket(Index, Key, Low0, C0))
    ->  earliest_bucket(Low0, B, Low),
        C is C0 + 1
    ;   Low = B, C = 1
    ),
    assertz(low_bucket(Index, Key, Low, C)).

%!  time_index_remove(+Index, +Key, +Time, +Item) is det.
%
%   Remove Item stored under Key with Time, if it is there.

time_index_remove(Index, Key, T, Item) :-
    bucket(T, B),
    (   retract(entry(B, Index, Key, T, Item))
    ->  retract(low_bucket(Index, Key, Low, C0)),
        C is C0 - 1,
        (   C =:= 0 -> true ; assertz(low_bucket(Index, Key, Low, C)) )
    ;   true
    ).

%!  time_index_take(+Index, +Key, +Order, +Limit, -Items:list) is det.
%
%   Remove and return the items of Key whose time is before Limit: Order is `<` (time <
%   Limit) or `=<`. Items are ordered by time.

time_index_take(Index, Key, Order, Limit, Items) :-
    (   low_bucket(Index, Key, Low, Count),
        bucket(Limit, LimitBucket),
        LimitBucket >= Low
    ->  (   \+ ( integer(Low), integer(LimitBucket), LimitBucket - Low < Count )
        ->  findall(taken(T, Item, B), ( entry(B, Index, Key, T, Item), before(Order, T, Limit) ), Taken0)
        ;   findall(taken(T, Item, B), ( between(Low, LimitBucket, B),
                                         entry(B, Index, Key, T, Item),
                                         before(Order, T, Limit) ), Taken0)
        ),
        msort(Taken0, TakenEntries),
        forall(member(taken(T, Item, B), TakenEntries), retract(entry(B, Index, Key, T, Item))),
        length(TakenEntries, Taken),
        retract(low_bucket(Index, Key, Low, Count)),
        Left is Count - Taken,
        (   Left =:= 0
        ->  true
        ;   latest_bucket(Low, LimitBucket, NewLow),   % every item below Limit's bucket was taken
            assertz(low_bucket(Index, Key, NewLow, Left))
        ),
        findall(Item, member(taken(_, Item, _), TakenEntries), Items)
    ;   Items = []
    ).

earliest_bucket(B1, B2, B) :-
    (   B1 == -inf -> B = -inf
    ;   B2 == -inf -> B = -inf
    ;   B1 == inf -> B = B2
    ;   B2 == inf -> B = B1
    ;   B is min(B1, B2)
    ).

latest_bucket(B1, B2, B) :-
    (   B1 == inf -> B = inf
    ;   B2 == inf -> B = inf
    ;   B1 == -inf -> B = B2
    ;   B2 == -inf -> B = B1
    ;   B is max(B1, B2)
    ).

before(<, T, Limit) :- T < Limit.
before(=<, T, Limit) :- T =< Limit.

%!  time_index_count(+Index, +Key, -Count) is det.

time_index_count(Index, Key, Count) :-
    (   low_bucket(Index, Key, _, C) -> Count = C ; Count = 0 ).

%!  time_index_clear(+Index) is det.
%
%   Remove every item of Index.

time_index_clear(Index) :-
    retractall(entry(_, Index, _, _, _)),
    retractall(low_bucket(Index, _, _, _)).
