:- module(rtl_horizon,
          [ rtl_late/1,                 % +End
            rtl_swept/1,                % +Clock
            rtl_kept_generation/1,      % ?Generation
            rtl_horizon/1,              % -Seconds
            rtl_horizon_setup/3,        % +Module, +MaxDelay, +Flag
            rtl_horizon_reset/0,
            rtl_retire_store/5,         % +Module, +Name, +Arity, +Before, +Scan
            rtl_forget_kept/2,          % +Module, +Clock
            rtl_retraction_too_late/1,  % +End
            rtl_too_late_text/4,        % +End, +Retracted, +Derived, -Text
            rtl_warning/1,              % +Text
            rtl_take_warnings/1,        % -Texts
            rtl_warnings_pending/0,
            rtl_next_seq/1,             % -Seq
            rtl_take_instance/2,        % :Stored, +Own
            rtl_aggregate/4,            % +Function, +Acc0, -Acc, -Value
            rtl_aggregate_initial/2,    % +Function, -Value
            rtl_aggregate_values/3,     % +Items, -Acc, -Values
            rtl_aggregate_redo/5,       % +Items, +Removed, -Acc, -Retracts, -Adds
            rtl_aggregate_redo_numbered/5  % +Items, +Removed, -Acc, -Retracts, -Adds
          ]).

/** <module> The retraction horizon: what the runtime keeps so that deletions are exact

A windowed step forgets a partial match whose start lies more than `Window + max_delay`
before the clock: no event that respects the delay bound can complete it any more
(rtl_ele's sweep). A *deletion* (`"op": "retract"`), or an event later than the bound, may
still need it: deleting an event takes back every result it took part in, which the
compiled delete rules find by joining with the partners the event had.

So a swept partial match is not dropped but *kept* (in one of the step's two kept
generations `<store>_kept_a` and `<store>_kept_b`, named by `ele_kept_store/3`) until it can
no longer matter for a deletion inside the **retraction horizon** H: a deletion of an event
that ended at most H seconds before the clock is exact. H is

  - `inf` when the program forgets nothing (no window and the `unrestricted` policy) or the
    delay bound is `inf`;
  - otherwise `max_delay` plus the largest window of the program, or the flag
    `retraction_horizon` if that is larger.

A kept partial match of a step with window W is needed until its end lies H + W before the
clock. The same holds for the records kept only for deletions (`ele_record_store/3`, in two
generations too): the matches a consumption policy made (they consume their events, so the
partners are gone from the stores) and the occurrences an aggregate counted. The generations
are emptied in turn, in one retractall/1 each (much cheaper than erasing match by match):
what the runtime keeps stays between H + Wmax and twice that (Wmax: the largest window). Kept records are only searched for an instance that is *late* (ends more than
max_delay before the clock, rtl_late/1): an instance within the bound can never match them,
since their match would be longer than the window. An event up to H late is therefore
processed exactly too; a blocker (negation) that late takes back what it blocks.

A deletion of an event that ended more than H before the clock is *too late*: it changes
nothing (the runtime may have forgotten part of what the event derived). It is counted apart
and reported with the number of derived events it took part in that the runtime can still
find, by a dry run of the deletion inside snapshot/1 (rtl_ele:rtl_dry_run/3): outputs, hooks and
actions are off, the counters tell what it would have retracted or derived again, and every
change to the database is undone. The count is exact when the runtime has forgotten nothing
that the deletion of the event could need (rtl_too_late_text/4 says "at least" otherwise).

Aggregates (`A seq aggregate(F, P, V)`) follow the order in which the P's are processed:
every instance gets a processing sequence number (rtl_next_seq/1), each P is kept as a
record, and deleting an A or a P replays the P's of the affected accumulators
(rtl_aggregate_values/3, rtl_aggregate_redo/5).
*/

:- use_module(library(pairs), [pairs_values/2]).
:- use_module(rtl_time, [rtl_beyond_bound/3]).

:- meta_predicate rtl_take_instance(:, +).

:- dynamic warning_text/1.

%!  rtl_late(+End:number) is semidet.
%
%   An instance that ended at End may match kept partial matches: it ended more than
%   max_delay before the clock of the last sweep (every kept match was retired by a sweep
%   at that clock or before, so its start lies more than Window + max_delay before it, and
%   a match with an instance that ended later would be longer than the window). Called by
%   compiled rules of windowed steps, once per arriving instance: one comparison.

rtl_late(End) :-
    nb_getval(rtl_late_before, swept(Clock, Delay)),
    rtl_beyond_bound(End, Clock, Delay).

%!  rtl_swept(+Clock) is det.
%
%   A sweep at Clock retired partial matches: instances that ended more than max_delay
%   before it (rtl_time:rtl_beyond_bound/3) are late from now on.

rtl_swept(Clock) :-
    nb_getval(rtl_late_delay, Delay),
    nb_getval(rtl_late_before, swept(Clock0, Delay0)),
    (   number(Delay), number(Clock),
        (   Clock0 =:= -inf -> true ; Clock - Delay > Clock0 - Delay0 )   % the latest, if the bound changed
    ->  nb_setval(rtl_late_before, swept(Clock, Delay))
    ;   true
    ).

%!  rtl_horizon(-Seconds) is det.
%
%   The retraction horizon of the current program (`inf` or a number of seconds).

rtl_horizon(H) :-
    (   nb_current(rtl_horizon, H0) -> H = H0 ; H = inf ).

%!  rtl_horizon_setup(+Module, +MaxDelay, +Flag) is det.
%
%   Compute the horizon of program Module for the delay bound MaxDelay and the value of the
%   flag `retraction_horizon` (`auto`, `inf` or seconds). Called whenever one of them changes
%   (program loaded, rules added or removed, flags set).

rtl_horizon_setup(M, Delay, Flag) :-
    nb_setval(rtl_late_delay, Delay),
    (   nb_current(rtl_late_before, _) -> true ; rtl_horizon_reset ),
    (   aggregate_all(max(W), program_fact(M, ele_store(_, _, W)), Wmax)
    ->  true
    ;   Wmax = 0
    ),
    (   Delay == inf
    ->  H = inf
    ;   \+ forgets(M)
    ->  H = inf
    ;   Base is Delay + Wmax,
        (   Flag == auto -> H = Base
        ;   Flag == inf -> H = inf
        ;   H is max(Flag, Base)
        )
    ),
    nb_setval(rtl_horizon, H),
    nb_setval(rtl_largest_window, Wmax),
    findall(Arity-Kept,
            (   program_fact(M, ele_kept_store(Live, Kept, _)),
                program_fact(M, ele_partial_store(Live, Arity))
            ;   program_fact(M, ele_record_store(_, Arity, Kept))
            ),
            Generations),
    nb_setval(rtl_kept_generations, Generations).

% The program forgets something: a windowed store, or records kept for deletions.
forgets(M) :-
    (   program_fact(M, ele_store(_, _, _))
    ->  true
    ;   program_fact(M, ele_record_store(_, _, _))
    ->  true
    ;   atom(M),
        predicate_property(M:ele_forget_blockers(_), number_of_clauses(N)), N > 0
    ->  true
    ).

% Facts of a compiled program; a program compiled without them has none.
program_fact(M, Goal) :-
    atom(M),
    functor(Goal, Name, Arity),
    current_predicate(M:Name/Arity),
    M:Goal.

%!  rtl_horizon_reset is det.
%
%   Nothing was retired or forgotten yet (the clock starts again).

rtl_horizon_reset :-
    NoClock is -inf,
    nb_setval(rtl_late_before, swept(NoClock, 0)),
    nb_setval(rtl_complete_since, NoClock),
    nb_setval(rtl_kept_generation, a),
    nb_setval(rtl_kept_rotated, none).

%!  rtl_retire_store(+Module, +Name, +Arity, +Before, +Scan) is det.
%
%   The sweep of live store Name/Arity: every partial match starting before Before moves to
%   the current kept generation of the store (rtl_forget_kept/2), or is dropped when the
%   store has none. Scan is `stored_order` (the clock-driven sweep: an oldest-first store is
%   scanned to its first match that stays) or `whole` (the sweep of late events, rtl_ele.pl:
%   every match is looked at, and one that ends more than H + the largest window before the
%   clock is dropped, not kept: no deletion inside the horizon can need it. Such matches come
%   from events later than the horizon; kept, they would pile up while the clock stands,
%   after an event far in the future, and every late event would search them all).
%
%   Kept generations: a store's retired matches go to one of its two kept generations
%   (`_kept_a`, `_kept_b`; the same one for every store) until the kept matches are rotated,
%   every H + the largest window: then the other generation is emptied at once (retractall/1,
%   much cheaper than erasing match by match) and receives the matches from then on. A kept
%   match thus stays between one and two rotation periods, at least as long as a deletion
%   inside the horizon may need it.

rtl_retire_store(M, Name, Arity, Before, Scan) :-
    functor(Head, Name, Arity),
    StartArg is Arity - 1,
    arg(StartArg, Head, Start),
    (   program_fact(M, ele_kept_store(Name, kept(KeptA, KeptB), Order))
    ->  nb_getval(rtl_kept_generation, Generation),
        ( Generation == a -> Kept = KeptA ; Kept = KeptB ),
        Head =.. [_|Args],
        KeptHead =.. [Kept|Args],               % instantiated by each clause found
        (   Scan == whole
        ->  forget_before(Forget),
            ( Order == oldest_first -> Keep = assertz ; Keep = asserta ),
            retire_every(M, Head, Start, Before, Forget, KeptHead, Keep)
        ;   retire(Order, M, Head, Start, Before, KeptHead)
        )
    ;   forall(( clause(M:Head, true, Ref), Start < Before ), erase(Ref))
    ).

% The retired matches are newer than every kept one: oldest-first stores get them at the
% end, in their order; newest-first stores in front, the newest of them first.
%
% An oldest-first store holds its matches in the order they were stored, and a match starts
% no later than the clock when it was stored: the scan stops at the first match that stays
% (one behind it that could go is retired at a later sweep, at most the window plus the
% delay bound after it was stored), so a sweep costs what it retires, not the store's size.
retire(oldest_first, M, Head, Start, Before, KeptHead) :-
    forall(( clause(M:Head, true, Ref), ( Start < Before -> true ; !, fail ) ),
           ( erase(Ref), assertz(M:KeptHead) )).
retire(newest_first, M, Head, Start, Before, KeptHead) :-
    retire_every(M, Head, Start, Before, -inf, KeptHead, asserta).

% Every match of the store starting before Before, wherever it is, kept by Keep (asserta/1
% or assertz/1: in the order of the store) unless it ends before Forget.
retire_every(M, Head, Start, Before, Forget, KeptHead, Keep) :-
    findall(KeptHead-Ref, ( clause(M:Head, true, Ref), Start < Before ), Retired),
    ( Keep == asserta -> reverse(Retired, Ordered) ; Ordered = Retired ),
    forall(member(K-Ref, Ordered), ( erase(Ref), kept(K, M, Forget, Keep) )).

kept(K, M, Forget, Keep) :-
    functor(K, _, Arity),
    arg(Arity, K, End),
    (   End < Forget -> true ; call(Keep, M:K) ).

% Matches ending before Forget are dropped by the sweep of late events, not kept.
forget_before(Forget) :-
    rtl_horizon(H),
    (   H == inf
    ->  Forget = -inf
    ;   nb_getval(rtl_clock, Clock),
        nb_getval(rtl_largest_window, Wmax),
        Forget is Clock - H - Wmax
    ).

%!  rtl_forget_kept(+Module, +Clock) is det.
%
%   Once a rotation period (H + the largest window) has passed since the last rotation,
%   empty the older generation of every kept store and record store: what it holds was
%   retired or recorded before the last rotation, at least a rotation period ago, so no
%   deletion inside the horizon needs it. It then receives from now on.

rtl_forget_kept(M, Clock) :-
    rtl_horizon(H),
    nb_getval(rtl_kept_rotated, Last),
    (   H == inf
    ->  true
    ;   Last == none
    ->  nb_setval(rtl_kept_rotated, Clock)
    ;   nb_getval(rtl_largest_window, Wmax),
        Clock - Last >= H + Wmax
    ->  nb_getval(rtl_kept_generation, Generation),
        ( Generation == a -> Older = b ; Older = a ),
        nb_getval(rtl_kept_generations, Generations),
        forall(member(Arity-Kept, Generations), empty_generation(M, Arity, Kept, Older, Last + Wmax)),
        nb_setval(rtl_kept_generation, Older),
        nb_setval(rtl_kept_rotated, Clock)
    ;   true
    ).

% Every match or record of the emptied generation ended before the last rotation (Last): a
% deletion of an event that ended up to the largest window after it may have needed one;
% rtl_complete_since is the latest such time.
empty_generation(M, Arity, kept(KeptA, KeptB), Generation, CompleteAfter) :-
    ( Generation == a -> Kept = KeptA ; Kept = KeptB ),
    functor(Head, Kept, Arity),
    (   predicate_property(M:Head, number_of_clauses(N)), N > 0
    ->  retractall(M:Head),
        Needed is CompleteAfter,
        nb_getval(rtl_complete_since, C0),
        ( C0 >= Needed -> true ; nb_setval(rtl_complete_since, Needed) )
    ;   true
    ).

%!  rtl_kept_generation(?Generation) is semidet.
%
%   The generation (`a` or `b`) that receives retired matches and new records now. Called
%   by compiled rules when they record a match (consumption policies) or an occurrence
%   (aggregates).

rtl_kept_generation(Generation) :-
    nb_getval(rtl_kept_generation, Generation).

%!  rtl_retraction_too_late(+End:number) is semidet.
%
%   A deletion of an event that ended at End is outside the retraction horizon.

rtl_retraction_too_late(End) :-
    rtl_horizon(H),
    H \== inf,
    nb_getval(rtl_clock, Clock),
    number(Clock),
    rtl_beyond_bound(End, Clock, H).

%!  rtl_too_late_text(+End, +Retracted, +Derived, -Text:string) is det.
%
%   The warning for a deletion outside the horizon of an event that ended at End.

rtl_too_late_text(End, Retracted, Derived, Text) :-
    nb_getval(rtl_complete_since, Complete),
    (   number(Complete), End =< Complete -> AtLeast = "at least " ; AtLeast = "" ),
    (   Derived > 0
    ->  format(string(Again), ", ~D not derived again", [Derived])
    ;   Again = ""
    ),
    format(string(Text), "retraction too late: ~s~D derived events not retracted~s",
           [AtLeast, Retracted, Again]).

%!  rtl_warning(+Text) is det.
%!  rtl_take_warnings(-Texts:list(string)) is det.
%
%   Warnings about the input being processed, in order; the readers of event lines take them
%   after each line and report them with its number.

rtl_warning(Text) :-
    assertz(warning_text(Text)).

rtl_take_warnings(Texts) :-
    (   warning_text(_)                         % taken after every line; rarely any
    ->  findall(T, retract(warning_text(T)), Texts)
    ;   Texts = []
    ).

%!  rtl_warnings_pending is semidet.
%
%   Some warning waits to be taken (rtl_take_warnings/1).

rtl_warnings_pending :-
    warning_text(_),
    !.

%!  rtl_take_instance(:Stored, +Own) is semidet.
%
%   Remove one stored instance (live or kept) of the events Own (a term of the instance's
%   own variables, as they appear in Stored), in a rule where a partial match from one branch
%   of an `or` leaves the other branch's variables unbound: the instance taken has the same
%   unbound variables, not merely one that unifies with it (either way). Fails if there is
%   none.

rtl_take_instance(M:Stored, Own) :-
    Stored =.. [Name|Args],
    (   program_fact(M, ele_kept_store(Name, kept(KeptA, KeptB), _))
    ->  Names = [Name, KeptA, KeptB]
    ;   Names = [Name]
    ),
    member(N, Names),
    Head =.. [N|Args],
    copy_term(Own-Head, _-Pattern),
    clause(M:Pattern, true, Ref),
    copy_term(Own-Head, Found-Fresh),
    clause(M:Fresh, true, Ref),
    Found =@= Own,
    !,
    erase(Ref),
    Head = Fresh.                               % (binds what else Stored records: a number)

%!  rtl_next_seq(-Seq:integer) is det.
%
%   The next processing sequence number (aggregates follow the processing order; a policy
%   step numbers its instances with it). Kept in the global variable `rtl_processing_seq`
%   with the rest of the runtime's state (flag/3 costs five times as much: it is called for
%   every instance a policy step stores).

rtl_next_seq(Seq) :-
    (   nb_current(rtl_processing_seq, Seq) -> true ; Seq = 0 ),
    Next is Seq + 1,
    nb_linkval(rtl_processing_seq, Next).        % (a number: nb_setval/2 without the copy)

%!  rtl_aggregate(+Function, +Acc0, -Acc, -Value) is det.
%
%   One step of an ETALIS aggregate: Function is `count`, `sum(X)`, `min(X)`, `max(X)` or
%   `avg(X)` with X bound to the new occurrence's value; Acc0 is `none` at the start.

%!  rtl_aggregate_initial(+Function, -Value) is semidet.
%
%   The value of an ETALIS aggregate over the empty set, given when the start event opens
%   it: 0 for `count` and `sum(X)`; `min(X)`, `max(X)` and `avg(X)` have none (ETALIS
%   gives 100000, -100000: numbers no occurrence had), so they fail and give nothing until
%   the first occurrence.

rtl_aggregate_initial(count, 0).
rtl_aggregate_initial(sum(_), 0).

rtl_aggregate(count, Acc0, N, N) :-
    ( Acc0 == none -> N = 1 ; N is Acc0 + 1 ).
rtl_aggregate(sum(X), Acc0, S, S) :-
    ( Acc0 == none -> S = X ; S is Acc0 + X ).
rtl_aggregate(min(X), Acc0, M, M) :-
    ( Acc0 == none -> M = X ; M is min(Acc0, X) ).
rtl_aggregate(max(X), Acc0, M, M) :-
    ( Acc0 == none -> M = X ; M is max(Acc0, X) ).
rtl_aggregate(avg(X), Acc0, Sum-N, Avg) :-
    (   Acc0 == none
    ->  Sum = X, N = 1
    ;   Acc0 = Sum0-N0, Sum is Sum0 + X, N is N0 + 1
    ),
    Avg is Sum / N.

%!  rtl_aggregate_values(+Items, -Acc, -Values) is det.
%
%   Items are `Seq-(Function-Start-End)` for the occurrences counted by one accumulator, in
%   any order; fold them in Seq order from the empty accumulator. Acc is the final
%   accumulator (`none` for no item), Values the value after each one as `Seq-(Value-End)`.

rtl_aggregate_values(Items, Acc, Values) :-
    keysort(Items, Sorted),
    fold(Sorted, none, Acc, Values).

fold([], Acc, Acc, []).
fold([Seq-(F-_-End)|Items], Acc0, Acc, [Seq-(V-End)|Values]) :-
    rtl_aggregate(F, Acc0, Acc1, V),
    fold(Items, Acc1, Acc, Values).

%!  rtl_aggregate_redo(+Items, +Removed, -Acc, -Retracts, -Adds) is det.
%
%   An accumulator counted Items plus Removed (`Seq-(Function-Start-End)`), which is deleted:
%   Retracts are the values to take back (from Removed on), Adds the new values of the items
%   after it, each `Value-End`; Acc is the new accumulator.

rtl_aggregate_redo(Items, Removed, Acc, Retracts, Adds) :-
    rtl_aggregate_redo_numbered(Items, Removed, Acc, NumberedRetracts, NumberedAdds),
    pairs_values(NumberedRetracts, Retracts),
    pairs_values(NumberedAdds, Adds).

%!  rtl_aggregate_redo_numbered(+Items, +Removed, -Acc, -Retracts, -Adds) is det.
%
%   As rtl_aggregate_redo/5, each value with the Seq of the occurrence that gave it
%   (`Seq-(Value-End)`): for an aggregate whose values a policy step takes (rtl_policy.pl).

rtl_aggregate_redo_numbered(Items, Removed, Acc, Retracts, Adds) :-
    Removed = From-_,
    rtl_aggregate_values([Removed|Items], _, Old),
    rtl_aggregate_values(Items, Acc, New),
    findall(S-(V-E), ( member(S-(V-E), Old), S >= From ), Retracts),
    findall(S-(V-E), ( member(S-(V-E), New), S > From ), Adds).
