/*  plunit tests of rtl_sliding.pl: sliding aggregates by group. Matches arrive in a random
    order, some are deleted again, and each arrival or deletion refreshes the stretch
    [E, E + D] it can change; what has been shown then is, whatever the order, exactly the
    changes a brute-force model of the matches left gives (the value at t is F over the
    matches that ended in (t - D, t]; a change is shown where it differs from the value just
    before t).

        swipl -g run_tests -t halt prolog_runtime/tests/test_sliding.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(random)).
:- use_module('../rtl_sliding').

:- dynamic match/2, shown/2.          % match(X, End), shown(Value, Time)

clear :- retractall(match(_, _)), retractall(shown(_, _)).

show(V, T) :- assertz(shown(V, T)).
unshow(V, T) :- once(retract(shown(V, T))).

refresh(F, D, E) :-
    To is E + D,
    rtl_sliding_refresh(F, D, E, To, match, shown, show, unshow).

arrive(F, D, X-E) :- assertz(match(X, E)), refresh(F, D, E).
take_back(F, D, X-E) :- once(retract(match(X, E))), refresh(F, D, E).

% The model: values from the definition, at every time a value may change.
model(F, D, Items, Changes) :-
    findall(T, ( member(_-E, Items), ( T = E ; T is E + D ) ), Ts0),
    sort(Ts0, Ts),
    findall(T-V, ( member(T, Ts), value_at(F, D, Items, T, V), \+ value_before(F, D, Items, T, V) ), Changes0),
    msort(Changes0, Changes).

value_at(F, D, Items, T, V) :-
    findall(X, ( member(X-E, Items), E > T - D, E =< T ), Xs),
    model_value(F, Xs, V).
value_before(F, D, Items, T, V) :-
    findall(X, ( member(X-E, Items), E >= T - D, E < T ), Xs),
    model_value(F, Xs, V).

model_value(count, Xs, N) :- length(Xs, N).
model_value(sum(_), Xs, S) :- msort(Xs, Sorted), foldl([X, A0, A]>>(A is A0 + X), Sorted, 0, S).
model_value(max(_), [X|Xs], M) :- foldl([Y, M0, M1]>>(M1 is max(M0, Y)), Xs, X, M).
model_value(min(_), [X|Xs], M) :- foldl([Y, M0, M1]>>(M1 is min(M0, Y)), Xs, X, M).
model_value(avg(_), [X|Xs], A) :- msort([X|Xs], S), foldl([Y, A0, A1]>>(A1 is A0 + Y), S, 0, Sum),
                                  length([X|Xs], N), A is Sum / N.

shown_changes(Changes) :-
    findall(T-V, shown(V, T), C0),
    msort(C0, Changes).

random_items(N, Items) :-
    length(Items, N),
    maplist([X-E]>>( random_between(0, 12, E), random_between(1, 5, X) ), Items).

:- begin_tests(rtl_sliding).

test(one_match_enters_and_leaves) :-
    clear,
    arrive(count, 5, 1-10),
    shown_changes(C),
    assertion(C == [10-1, 15-0]).

test(a_sum_over_two_matches) :-
    clear,
    arrive(sum(x), 5, 2-10), arrive(sum(x), 5, 3-12),
    shown_changes(C),
    assertion(C == [10-2, 12-5, 15-3, 17-0]).

test(max_of_no_match_shows_nothing_when_the_last_leaves) :-
    clear,
    arrive(max(x), 5, 4-1),
    shown_changes(C),
    assertion(C == [1-4]).

test(any_order_and_deletions_give_the_model) :-
    set_random(seed(36)),
    forall(( between(1, 150, _), random_member(F, [count, sum(x), max(x), min(x), avg(x)]) ),
           ( clear,
             random_between(1, 4, D),
             random_between(0, 8, N),
             random_items(N, Items),
             random_permutation(Items, Order),
             maplist(arrive(F, D), Order),
             random_between(0, N, K), length(Deleted, K), append(Deleted, Kept, Order),
             random_permutation(Deleted, DeleteOrder),
             maplist(take_back(F, D), DeleteOrder),
             model(F, D, Kept, Expected),
             shown_changes(Shown),
             assertion(Shown == Expected) )).

test(an_empty_stretch_changes_nothing) :-
    clear,
    arrive(count, 5, 1-10),
    shown_changes(Before),
    rtl_sliding_refresh(count, 5, 20, 19, match, shown, show, unshow),
    shown_changes(After),
    assertion(After == Before).

:- end_tests(rtl_sliding).
