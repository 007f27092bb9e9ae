/*  plunit tests of rtl_time_index.pl: items taken by time, against a plain list model on
    random sequences of adds, removes and takes (times close together, far apart, equal,
    infinite).

        swipl -g run_tests -t halt prolog_runtime/tests/test_time_index.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(random)).
:- use_module('../rtl_time_index').

:- begin_tests(rtl_time_index).

test(take_strict_and_inclusive) :-
    time_index_clear(t),
    time_index_add(t, k, 1.0, a),
    time_index_add(t, k, 1.005, b),
    time_index_add(t, k, 2.5, c),
    time_index_add(t, other, 0.5, z),
    time_index_take(t, k, <, 1.005, Strict),
    assertion(Strict == [a]),
    time_index_take(t, k, =<, 1.005, Incl),
    assertion(Incl == [b]),
    time_index_count(t, k, 1),
    time_index_count(t, other, 1),
    time_index_take(t, k, <, inf, Rest),
    assertion(Rest == [c]),
    time_index_count(t, k, 0).

test(infinite_times) :-
    time_index_clear(t),
    time_index_add(t, k, inf, never),
    time_index_add(t, k, -inf, first),
    time_index_take(t, k, <, 1.0e12, Taken),
    assertion(Taken == [first]),
    time_index_count(t, k, 1).

test(random_against_model, [forall(between(1, 40, Seed))]) :-
    set_random(seed(Seed)),
    time_index_clear(t),
    length(Ops, 300),
    foldl(random_step, Ops, []-0.0, Model-_),
    findall(T-I, member(k(T, I), Model), Expected0),
    msort(Expected0, Expected),
    time_index_take(t, k, =<, inf, Left),
    pairs_values(Expected, ExpectedItems),
    assertion(Left == ExpectedItems).

% One random operation on the index and on the model (a list of k(Time, Item)); times
% mostly move forward, with jumps of hours and steps back.
random_step(_, Model0-Now0, Model-Now) :-
    random_between(0, 9, Op),
    random_member(Step, [0.0, 0.001, 0.004, 0.013, 0.5, -0.02, 3600.0]),
    Now is Now0 + Step,
    (   Op =< 4
    ->  random_between(0, 30, Ms), T is Now + Ms / 1000,
        flag(item, I, I + 1),
        time_index_add(t, k, T, I),
        Model = [k(T, I)|Model0]
    ;   Op =< 5, Model0 \== []
    ->  random_member(k(T, I), Model0),
        time_index_remove(t, k, T, I),
        selectchk(k(T, I), Model0, Model)
    ;   random_member(Order, [<, =<]),
        random_between(-20, 20, Ms), Limit is Now + Ms / 1000,
        time_index_take(t, k, Order, Limit, Taken),
        partition(due(Order, Limit), Model0, Due, Model),
        findall(T-I, member(k(T, I), Due), Pairs0),
        msort(Pairs0, Pairs),
        pairs_values(Pairs, Expected),
        assertion(Taken == Expected)
    ).

due(<, Limit, k(T, _)) :- T < Limit.
due(=<, Limit, k(T, _)) :- T =< Limit.

:- end_tests(rtl_time_index).
