:- module(rtl_sliding,
          [ rtl_sliding_refresh/8,      % +Function, +Seconds, +From, +To, :Matches, :Shown, :Show, :Unshow
            rtl_sliding_refresh_numbered/10, % +Function, +Seconds, +From, +To, +Op, :Matches, :Shown,
                                            % :Reached, :Show, :Unshow
            rtl_sliding_change/5        % +Function, +Seconds, +Items, +Time, ?Value
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

Under a consumption policy that takes the values (rtl_policy.pl), a change has a position: the
arrival number of the event it was given at (the match that entered, or the timer that
reached a leave time, whose number is recorded), plus a fraction that grows with the change's
time (changes given at one event are given in time order). A deletion gives each change of the
stretch it refreshes the position the run without the deleted match gives it: the time's
events replayed in arrival order (rtl_sliding_refresh_numbered/10).
*/

:- use_module(library(lists)).
:- use_module(library(pairs), [pairs_values/2]).

:- meta_predicate rtl_sliding_refresh(+, +, +, +, 2, 2, 2, 2),
                  rtl_sliding_refresh_numbered(+, +, +, +, +, 3, 3, 2, 3, 2).

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
        desired_changes(F, D, Items, From, To, Desired),
        findall(T-V, ( call(Shown, V, T), T >= From, T =< To ), Output0),
        msort(Output0, Output),
        difference(Output, Desired, Stale),
        difference(Desired, Output, Fresh),
        forall(member(T-V, Stale), call(Unshow, V, T)),
        forall(member(T-V, Fresh), call(Show, V, T))
    ).

%!  rtl_sliding_refresh_numbered(+Function, +Seconds, +From, +To, +Op, :Matches, :Shown,
%!                               :Reached, :Show, :Unshow) is det.
%
%   As rtl_sliding_refresh/8 for a sliding aggregate whose changes a policy step takes: each
%   change has a position. call(Matches, X, E, P) enumerates the group's matches with their
%   arrival numbers, call(Shown, V, T, P) the changes output, call(Reached, T, P) the arrival
%   number of the timer that reached time T (if one did), call(Show, V, T, P) outputs a change
%   at position P, call(Unshow, V, T) takes one back. Op is `at(P)`, the arrival number of the
%   event refreshing (a match or a timer): the changes it gives are given there. Op
%   `deleted` (a match deleted): every change in [From, To] gets the position the run without
%   that match gives it, and a change shown elsewhere is taken back and given there.

rtl_sliding_refresh_numbered(F, D, From, To, Op, Matches, Shown, Reached, Show, Unshow) :-
    (   From > To
    ->  true
    ;   Low is From - D,
        findall(E-X-P, ( call(Matches, X, E, P), E >= Low, E =< To ), Numbered),
        findall(E-X, member(E-X-_, Numbered), Items),
        desired_changes(F, D, Items, From, To, Desired),
        findall(T-V-P, ( call(Shown, V, T, P), T >= From, T =< To ), Output0),
        msort(Output0, Output),
        (   Op = at(At)
        ->  findall(T-V, member(T-V-_, Output), Plain0),
            msort(Plain0, Plain),
            difference(Plain, Desired, Stale),
            difference(Desired, Plain, Fresh0),
            findall(T-V-P, ( member(T-V, Fresh0), fraction(T, Fraction), P is At + Fraction ), Fresh)
        ;   findall(T-V-P, ( member(T-V, Desired), replayed_position(F, D, Numbered, Reached, T, V, P) ),
                    Placed0),
            msort(Placed0, Placed),
            difference(Output, Placed, Stale0),
            findall(T-V, member(T-V-_, Stale0), Stale),
            difference(Placed, Output, Fresh)
        ),
        forall(member(T-V, Stale), call(Unshow, V, T)),
        positions_first(Fresh, InOrder),
        forall(member(T-V-P, InOrder), call(Show, V, T, P))
    ).

%   The fraction of its event's arrival number a change at T adds: in (0, 1), growing with T.
fraction(T, Fraction) :-
    Q is rational(T),
    Fraction is (1 rdiv 2) + Q rdiv (2 * (1 + abs(Q))).

positions_first(Changes, InOrder) :-
    findall(P-(T-V-P), member(T-V-P, Changes), Keyed),
    keysort(Keyed, Sorted),
    pairs_values(Sorted, InOrder).

%   replayed_position(+F, +D, +Numbered, :Reached, +T, +V, -P)
%
%   The position the change V at T has in a run of the matches present, in arrival order:
%   the events that can change the value at T (the matches that ended in [T - D, T], and the
%   timer that reached T, before which T was not visible unless a match ending at T had
%   arrived) are replayed in arrival order; the change is given at the first event after
%   which it holds to the end.
replayed_position(F, D, Numbered, Reached, T, V, P) :-
    Low is T - D,
    findall(Pm-match(E, X), ( member(E-X-Pm, Numbered), E >= Low, E =< T ), Arrivals),
    (   call(Reached, T, R)
    ->  Events0 = [R-reached|Arrivals], Visible0 = false
    ;   Events0 = Arrivals, Visible0 = true
    ),
    keysort(Events0, Events),
    replay_events(Events, F, D, T, V, Visible0, [], none, Since),
    (   Since == none                       % (not reached: the value holds at the end)
    ->  last(Events, P0-_)
    ;   P0 = Since
    ),
    fraction(T, Fraction),
    P is P0 + Fraction.

%   Walk the events; Since is the arrival number of the event after which the value has
%   been V since (none while it is not).
replay_events([], _, _, _, _, _, _, Since, Since).
replay_events([Pe-Event|Events], F, D, T, V, Visible0, Items0, Since0, Since) :-
    (   Event = match(E, X)
    ->  Items = [E-X|Items0],
        (   E =:= T -> Visible = true ; Visible = Visible0 )
    ;   Items = Items0,
        Visible = true
    ),
    (   Visible == true, change(F, D, Items, T, V)
    ->  (   Since0 == none -> Since1 = Pe ; Since1 = Since0 )
    ;   Since1 = none
    ),
    replay_events(Events, F, D, T, V, Visible, Items, Since1, Since).

%   desired_changes(+F, +D, +Items, +From, +To, -Desired): the changes (`T-V`, sorted) the
%   matches Items give in [From, To]: a value can change only when a match enters or leaves.
desired_changes(F, D, Items, From, To, Desired) :-
    findall(T, ( member(E-_, Items), ( T = E ; T is E + D ), T >= From, T =< To ), Times0),
    sort(Times0, Times),
    findall(T-V, ( member(T, Times), change(F, D, Items, T, V) ), Desired0),
    msort(Desired0, Desired).

%!  rtl_sliding_change(+Function, +Seconds, +Items, +Time, ?Value) is semidet.
%
%   Value is the value at Time of the sliding aggregate over the matches Items (`End-X`
%   pairs, X the value Function aggregates), and it differs from the value just before Time:
%   a change the compiled rule outputs at Time. `retalisc explain` (rtl_trace.pl) accounts
%   for a derived value with it.

rtl_sliding_change(F, D, Items, T, V) :-
    change(F, D, Items, T, V).

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
