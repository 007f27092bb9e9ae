:- module(rtl_sliding,
          [ rtl_sliding_refresh/8       % +Function, +Seconds, +From, +To, :Matches, :Shown, :Show, :Unshow
          ]).

/** <module> Sliding aggregates by group: the values as they change

`sliding(F, P, Group, D, V)` (docs/language.md): for each group, the value at time t is F over
the matches of P of that group that ended in `(t - D, t]`. It can change only when a match
ends (enters) or D seconds after (leaves); a change is output as one event at that time. The
compiled rule keeps the matches and the changes it has output (windowed stores, kept for the
retraction horizon like partial matches) and calls rtl_sliding_refresh/8 for the stretch of
time an arrival or a deletion can change (`[E, E + D]` for a match that ended at E, up to the
clock), and from a timer when the clock reaches `E + D`. The refresh computes the changes
that stretch must show from the matches present and outputs the difference with what it
shows: so the output nets to the values of the events present, whatever the arrival order,
late events and deletions (inside the retraction horizon) included.

Values: count and sum of no match are 0; min, max and avg of no match have no value (nothing
is output when the last match leaves). Sums add the values in standard order, so that a value
computed again is the same float.
*/

:- meta_predicate rtl_sliding_refresh(+, +, +, +, 2, 2, 2, 2).

%!  rtl_sliding_refresh(+Function, +Seconds, +From, +To, :Matches, :Shown, :Show, :Unshow) is det.
%
%   Make the changes output for times in [From, To] those of the matches of one group:
%   call(Matches, X, E) enumerates the group's matches (aggregated value X, end E),
%   call(Shown, V, T) the changes it has output, call(Show, V, T) outputs and records one,
%   call(Unshow, V, T) takes one back.

rtl_sliding_refresh(F, D, From, To, Matches, Shown, Show, Unshow) :-
    (   From > To
    ->  true
    ;   Low is From - D,
        findall(E-X, ( call(Matches, X, E), E >= Low, E =< To ), Items),
        findall(T, ( member(E-_, Items), ( T = E ; T is E + D ), T >= From, T =< To ), Times0),
        sort(Times0, Times),
        findall(T-V, ( member(T, Times), change(F, D, Items, T, V) ), Desired0),
        msort(Desired0, Desired),
        findall(T-V, ( call(Shown, V, T), T >= From, T =< To ), Output0),
        msort(Output0, Output),
        difference(Output, Desired, Stale),
        difference(Desired, Output, Fresh),
        forall(member(T-V, Stale), call(Unshow, V, T)),
        forall(member(T-V, Fresh), call(Show, V, T))
    ).

% The value at T, when it differs from the value just before T.
change(F, D, Items, T, V) :-
    findall(X, ( member(E-X, Items), E > T - D, E =< T ), Now),
    findall(X, ( member(E-X, Items), E >= T - D, E < T ), Before),
    value(F, Now, V),
    \+ value(F, Before, V).

value(count, Xs, N) :-
    length(Xs, N).
value(sum(_), Xs, S) :-
    msort(Xs, Sorted),
    sum_list(Sorted, S).
value(min(_), Xs, M) :-
    Xs \== [],
    min_list(Xs, M).
value(max(_), Xs, M) :-
    Xs \== [],
    max_list(Xs, M).
value(avg(_), Xs, A) :-
    Xs \== [],
    msort(Xs, Sorted),
    sum_list(Sorted, S),
    length(Xs, N),
    A is S / N.

% Ordered lists as multisets: the items of the first not in the second.
difference([], _, []).
difference([X|Xs], Ys, Zs) :-
    (   selectchk(X, Ys, Ys1)
    ->  difference(Xs, Ys1, Zs)
    ;   Zs = [X|Zs1],
        difference(Xs, Ys, Zs1)
    ).
