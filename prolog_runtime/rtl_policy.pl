:- module(rtl_policy,
          [ rtl_position/2,             % -Position, -Mode
            rtl_policy_insert/4,        % +Step, ?Key, +Position, :Arrival
            rtl_policy_delete/4,        % +Step, +Side, ?Key, :Stored
            rtl_policy_drop_twins/2,    % +Step, :Stored
            rtl_policy_take/3,          % +Step, :Stored, -Key
            rtl_policy_positioned/2,    % +Module, +StoreName
            rtl_policy_made/5,          % :MadeA, :MadeB, +Id, -Position, :Derive
            rtl_policy_unmade/5,        % :MadeA, :MadeB, ?Id, -Position, :Underive
            rtl_policy_arrival/1,       % -Id
            rtl_policy_take_arrival/2,  % :Stores, +Own
            rtl_policy_restoring/1,     % :Goal
            rtl_policy_at/2             % +Position, :Goal
          ]).

/** <module> Consumption policies: exact deletion by rewinding and replaying a step

Under `recent` and `chronological` a step of a rule (`L op R`, or the two sides of
`not(N).[L, R]`) pairs each arriving instance with one waiting partner and consumes both, so
what it derives depends on the order in which its instances arrived. Deleting an instance
must give the output of a run in which it never arrived: the match it was consumed in is
taken back, the partner it consumed waits again, and every later decision of the step for the
same join key may change (the freed partner can pair with a later instance, which then leaves
another one waiting, ...).

Every instance a policy step stores or records carries its *position*: its arrival number
(rtl_next_seq/1, one counter for every step, called by compiled code; rtl_position/2).
Instances arrive in position order, also when one input event reaches a step several times
(`a(X) seq a(Y)`, or through two paths), so the step's stores and records are its log:

  - the instances still waiting (the live store and, for a windowed step, its kept
    generations), each with its position;
  - the matches made (`<step>_matched`, kept for the retraction horizon), with the positions
    of both instances: a match was made when the later of them arrived;
  - under `recent`, the waiting twins an arrival replaced (`<step>_dropped`), with the
    position of the arrival.

Rewinding a step for a key to a position Min takes back every match made at Min or later
(its result is retracted), lets the instances that arrived before Min and were consumed or
replaced at Min or later wait again (in position order), and removes the instances that
arrived at Min or later; they are then replayed in position order, each with its own
position. A deletion rewinds to the deleted instance's position and replays the others. A replay passes its results on with the
position of the instance replayed (rtl_replay_position), so a later policy step that receives
such a result receives it "in the past" and rewinds itself to that position before taking it
(rtl_policy_insert/4): steps of one rule and rules fed by derived events stay exact together.
A result taken back reaches the next policy step with the position of its match
(rtl_retract_position): that step deletes the instance the match passed on, not an identical
one (the same events at the same times) that arrived otherwise.

Instances are told apart as variants, not by unification: a partial match from one branch of
an `or` leaves the other branch's variables unbound (and, under a policy, carries the branch it
came through, so `a(1) or b(1)` are two different partial matches). When such a variable is a
join key, the instance pairs with every key: the step is rewound for every key, and a match
record keeps each side's key as it was stored (rtl_policy_take/3), so a freed partner waits
again as it was.
A blocker of a policy negation (`not(N).[L, R]`) blocks the pairs made after it arrived; its
deletion (or its arrival in the past) rewinds every key of the step.

The compiled program describes each policy step by facts of `<step>_policy/1`:

  - `order(recent)` or `order(chronological)`;
  - `entry(Side, Key, Position, Live, Kept, Arrival)`: a side (`left`, `right`) of the step,
    its store Live (and kept generations Kept), the join Key, and the goal that processes an
    instance at Position (`<step>_<side>_at/N`);
  - `match(Key, Generations, LPos, RPos, Retract, Left, Right)`: a match record in its two
    generations, the goal retracting its result, and the stored forms of its two instances;
  - `dropped(Generations, Stored, Position)`: a twin replaced by the arrival at Position;
  - `blocker(Position, Live, Kept)`: the blocker store of a negation.

The cost falls on deletions and on results passed on by a replay; processing an input event
only takes an arrival number. What is exact: within the retraction horizon (rtl_horizon.pl),
the output nets to that of a run in which the deleted event never arrived; of several arrivals
of the same input event, a deletion takes back the latest. A rule without a policy whose results
a policy step takes numbers the arrivals of its input events (rtl_policy_arrival/1): its
partial matches and results carry the numbers they were made from, so a deletion takes back
the latest arrival and what it made (rtl_policy_take_arrival/2), taking a result back deletes
the arrival it made in the policy step (rtl_policy_unmade/5), and a result it makes only when
a blocker (or a `first` partner) is deleted arrives where it would have been made, when its
last input event arrived (rtl_policy_made/5). Positions are then rational numbers: rewinding
is to a position (`from`) or to just after one (`after`). A sliding aggregate's changes are
passed on at their own positions (rtl_policy_at/2, rtl_sliding.pl).
*/

:- use_module(library(lists)).
:- use_module(library(pairs)).
:- use_module(rtl_horizon, [rtl_next_seq/1, rtl_kept_generation/1]).

:- meta_predicate rtl_policy_insert(+, ?, +, 0), rtl_policy_delete(+, +, ?, :),
                  rtl_policy_drop_twins(+, :), rtl_policy_take(+, :, -),
                  rtl_policy_made(:, :, +, -, 0), rtl_policy_unmade(:, :, ?, -, 0),
                  rtl_policy_take_arrival(:, +), rtl_policy_restoring(0), rtl_policy_at(+, 0).

%!  rtl_position(-Position:integer, -Mode) is det.
%
%   The position of the instance a policy step is receiving: a new arrival number (Mode
%   `now`), or, inside a replay, the position of the instance replayed (Mode `replay`: the
%   instance comes from the past). The code compiled for a policy step calls it for every
%   instance (passes/edbc.py), also in rules added at run time: the goal boundary
%   (rtl_sandbox.pl) allows it, and compiled code reads no runtime global itself.

rtl_position(Position, Mode) :-
    nb_getval(rtl_replay_position, R),          % set by rtl_reset/0
    (   R == none
    ->  rtl_next_seq(Position), Mode = now
    ;   Position = R, Mode = replay
    ).

%   next_arrival(-Position): the arrival number rtl_next_seq/1 gives next, without taking it.

next_arrival(Position) :-
    (   nb_current(rtl_processing_seq, Position) -> true ; Position = 0 ).

%!  rtl_policy_insert(+Step, ?Key, +Position, :Arrival) is det.
%
%   An instance of Step arrives from the past (at Position, during a replay): rewind Step
%   for Key to just after Position, process the instance (Arrival), and replay what came
%   after it. An unbound Key rewinds every key (a blocker).

rtl_policy_insert(Step, Key, Position, M:Arrival) :-
    rewind(M, Step, Key, after(Position), Replays),
    with_position(Position, M:Arrival),
    replay(M, Replays).

%!  rtl_policy_delete(+Step, +Side, ?Key, :Stored) is det.
%
%   Delete an instance of Step (Stored, a term of its store for Side, `left`, `right` or
%   `negated`, with its position unbound) as if it had never arrived. Of several arrivals of
%   the same instance (the same events at the same times, told apart by their positions) the
%   one deleted is the one the deletion comes from: when a match of an earlier policy step
%   is taken back, the instance that match passed on (the first that arrived at or after the
%   match was made); else the latest arrival (the deletion of an input event takes back its
%   latest addition). An instance that is not known (never added, or forgotten after the
%   retraction horizon) changes nothing.

rtl_policy_delete(Step, negated, _, M:Stored) :-
    !,
    (   findall(P-Ref, ( blocker_item(M, Step, Found, P, Ref), same_instance(Found, Stored) ), Items),
        pairs_keys(Items, Ps),
        chosen(Ps, Chosen)
    ->  memberchk(Chosen-Ref, Items),
        erase(Ref),
        rewind(M, Step, _AnyKey, after(Chosen), Replays),
        replay(M, Replays)
    ;   true
    ).
rtl_policy_delete(Step, Side, Key, M:Stored) :-
    (   findall(P, ( known(M, Step, Side, Key, Found, P), same_instance(Found, Stored) ), Ps),
        chosen(Ps, Chosen)
    ->  rewind(M, Step, Key, from(Chosen), Replays0),
        side_index(Side, I),
        (   select(Chosen-I-(D-_), Replays0, Replays), same_instance(D, Stored)
        ->  true
        ;   Replays = Replays0
        ),
        replay(M, Replays)
    ;   true
    ).

%   Of the positions of the known arrivals of an instance, the one a deletion takes (see
%   rtl_policy_delete/4). rtl_retract_position is set while a match is taken back.
chosen(Ps, Chosen) :-
    Ps \== [],
    (   nb_current(rtl_retract_position, From), From \== none,
        include(=<(From), Ps, After), After \== []
    ->  min_list(After, Chosen)
    ;   max_list(Ps, Chosen)
    ).

%   same_instance(+A, +B): two stored instances of the same events at the same times (their
%   positions aside; a partial match from one branch of an `or` has the other branch's
%   variables unbound, so this is a variant check, not unification).
same_instance(A, B) :-
    A =.. [_|As],
    B =.. [_|Bs],
    append(KA, [_, SA, EA], As),
    append(KB, [_, SB, EB], Bs),
    KA-SA-EA =@= KB-SB-EB.

% The arrivals of Step for Side with Key, as stored, at Position: waiting, consumed in a
% match, or replaced by a twin.
known(M, Step, Side, Key, Found, Position) :-
    (   waiting_item(M, Step, Side, Key, Found, Position, _)
    ;   match_item(M, Step, Key, m(_, PL, PR, _, L, R)),
        (   Side == left -> Found = L, Position = PL ; Found = R, Position = PR )
    ;   dropped_item(M, Step, Side, Key, Found, Position, _, _)
    ).

%   The items of a step, each fetched twice: by its key (indexed), then as stored (a stored
%   instance may have variables where Key has values).
waiting_item(M, Step, Side, Key, Found, Position, Ref) :-
    policy_info(M, Step, entry(Side, Key, _, Live, Kept, _)),
    nth0(I, [Live|Kept], T),
    clause(M:T, true, Ref),
    policy_info(M, Step, entry(Side, _, Position, Found, Kept1, _)),
    nth0(I, [Found|Kept1], T1),
    clause(M:T1, true, Ref).

match_item(M, Step, Key, m(Ref, PL, PR, Retract, L, R)) :-
    policy_info(M, Step, match(Key, Gens, _, _, _, _, _)),
    nth0(I, Gens, G),
    clause(M:G, true, Ref),
    policy_info(M, Step, match(_, Gens1, PL, PR, Retract, L, R)),
    nth0(I, Gens1, G1),
    clause(M:G1, true, Ref).

dropped_item(M, Step, Side, Key, Found, Position, By, Ref) :-
    policy_info(M, Step, entry(Side, Key, _, Stored, _, _)),
    policy_info(M, Step, dropped(Gens, Stored, _)),
    nth0(I, Gens, G),
    clause(M:G, true, Ref),
    policy_info(M, Step, entry(Side, _, Position, Found, _, _)),
    policy_info(M, Step, dropped(Gens1, Found, By)),
    nth0(I, Gens1, G1),
    clause(M:G1, true, Ref).

blocker_item(M, Step, Found, Position, Ref) :-
    policy_info(M, Step, blocker(_, Stored, Kept)),
    nth0(I, [Stored|Kept], T),
    clause(M:T, true, Ref),
    policy_info(M, Step, blocker(Position, Found, Kept1)),
    nth0(I, [Found|Kept1], T1),
    clause(M:T1, true, Ref).

side_index(left, 0).
side_index(right, 1).

%   rewind(+M, +Step, ?Key, +Bound, -Replays)
%
%   Undo what Step did for Key from position Min on (Bound `from(Min)`), or after position
%   P (`after(P)`: positions are rational numbers when results were made late,
%   rtl_policy_made/5) (see the module header). Replays are the instances to process again,
%   `Position-SideIndex-(Stored-Arrival)`, in order.
rewind(M, Step, Key, Min, Replays) :-
    findall(Made-Item,
            ( match_item(M, Step, Key, Item),
              Item = m(_, PL, PR, _, _, _),
              Made is max(PL, PR),
              at_or_after(Min, Made) ),
            Matches0),
    keysort(Matches0, Ascending),
    reverse(Ascending, Matches),                    % the latest result is taken back first
    forall(member(_-m(Ref, _, _, _, _, _), Matches), erase(Ref)),
    forall(member(Made-m(_, _, _, Retract, _, _), Matches), taken_back(Made, M:Retract)),
    findall(Item, ( member(_-m(_, PL, PR, _, L, R), Matches),
                    ( Item = left-PL-L ; Item = right-PR-R ) ), Consumed),
    findall(Side-P-Stored,
            ( dropped_item(M, Step, Side, Key, Stored, P, By, Ref),
              at_or_after(Min, By),
              erase(Ref) ),
            Dropped),
    findall(Side-P-Stored,
            ( waiting_item(M, Step, Side, Key, Stored, P, Ref),
              at_or_after(Min, P),
              erase(Ref) ),
            Waiting),
    append([Consumed, Dropped, Waiting], Instances),
    partition(later(Min), Instances, Later, Earlier),
    restore(M, Step, Key, Earlier),
    findall(P-I-(Stored-Arrival),
            ( member(Side-P-Stored, Later),
              side_index(Side, I),
              policy_info(M, Step, entry(Side, _, P, Stored, _, Arrival)) ),
            Replays0),
    keysort(Replays0, Replays).

later(Min, _-P-_) :- at_or_after(Min, P).

at_or_after(from(Min), P) :- P >= Min.
at_or_after(after(Min), P) :- P > Min.

%   Take back the result of a match made at Made: a policy step it reaches deletes the
%   instance that match passed on (rtl_policy_delete/4).
taken_back(Made, Goal) :-
    (   nb_current(rtl_retract_position, Old) -> true ; Old = none ),
    (   nb_current(rtl_made_mode, OldMode) -> true ; OldMode = none ),
    setup_call_cleanup(( nb_setval(rtl_retract_position, Made),
                         nb_setval(rtl_made_mode, none) ),
                       ignore(Goal),
                       ( nb_setval(rtl_retract_position, Old),
                         nb_setval(rtl_made_mode, OldMode) )).

%   Instances that arrived before the rewind point wait again: each side's live store for
%   Key is rebuilt in position order (newest first under `recent`, oldest first else).
restore(_, _, _, []) :- !.
restore(M, Step, Key, Instances) :-
    policy_info(M, Step, order(Order)),
    forall(( member(Side, [left, right]), memberchk(Side-_-_, Instances) ),
           (   findall(P-Live, ( waiting_item(M, Step, Side, Key, Live, P, Ref),
                                 policy_info(M, Step, entry(Side, _, _, Live0, _, _)),
                                 clause(M:Live0, true, Ref),  % the live store, not a kept one
                                 erase(Ref) ),
                       Present),
               findall(P-S, member(Side-P-S, Instances), Back),
               append(Present, Back, All),
               keysort(All, Sorted),
               pairs_values(Sorted, Stored),
               (   Order == recent
               ->  forall(member(S, Stored), asserta(M:S))
               ;   forall(member(S, Stored), assertz(M:S))
               )
           )).

replay(M, Replays) :-
    forall(member(P-_-(_-Arrival), Replays), with_position(P, M:Arrival)).

%   Process Goal as an instance arriving at Position: what it passes on comes from there.
with_position(Position, Goal) :-
    nb_getval(rtl_replay_position, Old),
    (   nb_current(rtl_retract_position, OldFrom) -> true ; OldFrom = none ),
    (   nb_current(rtl_made_mode, OldMode) -> true ; OldMode = none ),
    setup_call_cleanup(( nb_setval(rtl_replay_position, Position),
                         nb_setval(rtl_retract_position, none),
                         nb_setval(rtl_made_mode, none) ),
                       ignore(Goal),
                       ( nb_setval(rtl_replay_position, Old),
                         nb_setval(rtl_retract_position, OldFrom),
                         nb_setval(rtl_made_mode, OldMode) )).

%!  rtl_policy_drop_twins(+Step, :Stored) is det.
%
%   Under `recent`, a partial match about to wait replaces its waiting twins: the stored
%   matches (live or kept) of the same events at other times, recorded as replaced by the
%   arrival at Stored's position. Called by compiled rules when Stored is not ground (a
%   partial match from one branch of an `or`, whose other branch's variables are unbound):
%   a twin is then a variant of it, not anything that unifies (ground twins are replaced by
%   the compiled code itself).

rtl_policy_drop_twins(Step, M:Stored) :-
    policy_info(M, Step, entry(Side, Key0, By, Stored, _, _)),
    !,
    copy_term(Key0, Key),                       % (for the index: Stored keeps its variables)
    Stored =.. [_|Args],
    append(Events, [_, _, _], Args),
    forall(( waiting_item(M, Step, Side, Key, Twin, _, Ref),
             Twin =.. [_|TwinArgs],
             append(TwinEvents, [_, _, _], TwinArgs),
             TwinEvents =@= Events ),
           (   erase(Ref),
               policy_info(M, Step, dropped([GenA, GenB], Twin, By)),
               (   rtl_kept_generation(a) -> assertz(M:GenA) ; assertz(M:GenB) )
           )).
rtl_policy_drop_twins(_, _).

%!  rtl_policy_take(+Step, :Stored, -Key:list) is det.
%
%   Consume the waiting partner Stored (live or kept) of a step whose join key may be
%   unbound in a partial match, and give its key as it was stored: a partner that pairs with
%   every key does so again when it is restored (rtl_policy.pl records it with the match).

rtl_policy_take(Step, M:Partner, Key) :-
    functor(Partner, Name, Arity),
    policy_info(M, Step, entry(_, Key0, _, Stored, Kept, _)),
    functor(Stored, Name, Arity),
    !,
    Partner =.. [_|Args],
    member(T0, [Stored|Kept]),
    functor(T0, StoreName, Arity),
    T =.. [StoreName|Args],
    clause(M:T, true, Ref),
    !,
    functor(Fresh, StoreName, Arity),
    clause(M:Fresh, true, Ref),
    erase(Ref),
    Fresh =.. [_|FreshArgs],
    length(Key0, N),
    length(Key, N),
    append(Key, _, FreshArgs).

%!  rtl_policy_made(:MadeA, :MadeB, +Id, -Position, :Derive) is det.
%
%   A rule without a policy makes a result that a policy step takes as input: record when
%   (MadeA or MadeB, the two generations of `<step>_made`, with Position unbound) and run
%   Derive. Id tells the result apart from identical ones: the arrival numbers of the input
%   events it was made from (rtl_policy_arrival/1), joined by `-` (`IdL-IdR` for a pair).
%   Made while an input event arrives, the result takes the arrival number the policy step
%   takes next. Made later, because a blocker of its negation or its `first` partner was
%   deleted (rtl_policy_restoring/1), or made in a replay, it is made where it would have
%   been made when its last input event arrived: the policy step receives it in the past
%   (late_position/4). A sliding aggregate's change is made at the position it is given
%   (rtl_policy_at/2).

rtl_policy_made(MA:MadeA, MB:MadeB, Id, Position, Derive) :-
    nb_getval(rtl_replay_position, R),
    (   nb_current(rtl_made_mode, given)            % rtl_policy_at/2: the position is known
    ->  nb_setval(rtl_made_mode, none),             % (for this result only)
        Position = R,
        kept_assert(MA:MadeA, MB:MadeB),
        with_position(Position, Derive)
    ;   R == none, \+ nb_current(rtl_made_mode, restore)
    ->  next_arrival(Position),
        kept_assert(MA:MadeA, MB:MadeB),
        ignore(Derive)
    ;   nonvar(Id)
    ->  late_position(MA:MadeA, MB:MadeB, Id, Position),
        kept_assert(MA:MadeA, MB:MadeB),
        with_position(Position, Derive)
    ;   (   R \== none
        ->  Position = R
        ;   next_arrival(Position)
        ),
        kept_assert(MA:MadeA, MB:MadeB),
        ignore(Derive)
    ).

%   late_position(:MadeA, :MadeB, +Id, -Position)
%
%   The position of a result made late: among the results made when its last input event
%   (Last) arrived, the rule made them in the order of made_key/2 (its stores are in arrival
%   order); the position is halfway between the one made just before it (or Last) and the
%   one made just after it (or the next whole number). Positions are then rational numbers,
%   and results made late never share a position.
late_position(MA:MadeA, MB:MadeB, Id, Position) :-
    last_arrival(Id, Last),
    made_key(Id, Key),
    functor(MadeA, NameA, Arity),
    functor(MadeB, NameB, Arity),
    IdArg is Arity - 1,
    findall(K-P,
            ( member(MM:Name, [MA:NameA, MB:NameB]),
              functor(Record, Name, Arity),
              MM:Record,
              arg(IdArg, Record, Other),
              last_arrival(Other, Last),
              arg(Arity, Record, P),
              made_key(Other, K) ),
            Made),
    findall(P, ( member(K-P, Made), K @=< Key ), Before),
    max_list([Last|Before], Prev),
    Next0 is floor(Prev) + 1,
    findall(P, ( member(K-P, Made), K @> Key, P > Prev ), After),
    min_list([Next0|After], Next),
    Position is (Prev + Next) rdiv 2.

%   made_key(+Id, -Key): the order in which results made when the same input event arrived
%   were made: along the steps the arrival went through, by the partners it met there, in
%   the order they were stored.
made_key(A-B, Key) :-
    !,
    last_arrival(A, LA),
    last_arrival(B, LB),
    made_key(A, KA),
    made_key(B, KB),
    (   LA >= LB -> append(KA, [KB], Key) ; append(KB, [KA], Key) ).
made_key(Leaf, [Leaf]).

last_arrival(Id, Last) :-
    var(Id),
    !,
    Last = 0.
last_arrival(A-B, Last) :-
    !,
    last_arrival(A, LA),
    last_arrival(B, LB),
    Last is max(LA, LB).
last_arrival(Last, Last).

kept_assert(MA:A, MB:B) :-
    (   rtl_kept_generation(a) -> assertz(MA:A) ; assertz(MB:B) ).

%!  rtl_policy_unmade(:MadeA, :MadeB, ?Id, -Position, :Underive) is det.
%
%   Take back a result of a rule without a policy that a policy step takes as input:
%   remove its record of when it was made (the record of Id; of several records of the same
%   result with Id unbound, the one chosen/2 takes) and run Underive with that position, so
%   that the policy step deletes the arrival this result made, not an identical one made
%   from other input events. Without a record (forgotten after the retraction horizon),
%   Underive runs as it is.

rtl_policy_unmade(MA:MadeA, MB:MadeB, _Id, Position, Underive) :-
    findall(Position-Ref, ( clause(MA:MadeA, true, Ref) ; clause(MB:MadeB, true, Ref) ), Items),
    pairs_keys(Items, Ps),
    (   chosen(Ps, Chosen)
    ->  memberchk(Chosen-Ref, Items),
        erase(Ref),
        Position = Chosen,
        taken_back(Chosen, Underive)
    ;   ignore(Underive)
    ).

%!  rtl_policy_arrival(-Id:integer) is det.
%
%   The arrival number of an input event of a rule without a policy whose results a policy
%   step takes (as rtl_position/2): stored with the event, it tells two arrivals of the
%   same event apart, and places a result made later where its last input event arrived.

rtl_policy_arrival(Id) :-
    rtl_position(Id, _).

%!  rtl_policy_take_arrival(:Stores, +Own) is semidet.
%
%   Remove one stored instance of a rule without a policy whose results a policy step takes.
%   Stores are the step's store and its kept generations, as terms with the same arguments,
%   the instance's Id third from the end: bound, that instance; unbound (an input event
%   deleted), of its arrivals the one chosen/2 takes (the latest, or the one a match taken
%   back passed on). Own is `none`, or, in a rule with `or`, a term of the instance's own
%   variables: the instance taken has the same unbound variables (rtl_take_instance/2).
%   Binds Id. Fails if there is none.

rtl_policy_take_arrival(M:Stores, Own) :-
    Stores = [Stored|_],
    functor(Stored, _, Arity),
    IdArg is Arity - 2,
    findall(P-Ref,
            ( member(S, Stores),
              copy_term(Own-S, _-Pattern),
              clause(M:Pattern, true, Ref),
              copy_term(Own-S, Found-Fresh),
              clause(M:Fresh, true, Ref),
              Found =@= Own,
              arg(IdArg, Fresh, P) ),
            Items),
    pairs_keys(Items, Ps),
    chosen(Ps, Chosen),
    memberchk(Chosen-Ref, Items),
    erase(Ref),
    arg(IdArg, Stored, Chosen).

%!  rtl_policy_restoring(:Goal) is det.
%
%   Run Goal, which makes results again because a blocker (or a `first` partner) was
%   deleted: they are made where their last input event arrived (rtl_policy_made/5).

rtl_policy_restoring(Goal) :-
    (   nb_current(rtl_made_mode, Old) -> true ; Old = none ),
    setup_call_cleanup(nb_setval(rtl_made_mode, restore),
                       ignore(Goal),
                       nb_setval(rtl_made_mode, Old)).

%!  rtl_policy_at(+Position, :Goal) is det.
%
%   Run Goal, which passes on a result given at Position (a sliding aggregate's change,
%   rtl_sliding.pl): a policy step receives it there, in the past if later instances
%   arrived, and rewinds itself as for a replay; a rule deriving it records it made there
%   (rtl_policy_made/5, which passes it on without this mode).

rtl_policy_at(Position, Goal) :-
    with_position(Position, with_made_mode(given, Goal)).

with_made_mode(Mode, Goal) :-
    setup_call_cleanup(nb_setval(rtl_made_mode, Mode),
                       ignore(Goal),
                       nb_setval(rtl_made_mode, none)).

%!  rtl_policy_positioned(+Module, +StoreName) is semidet.
%
%   StoreName (a live store or a kept generation) belongs to a policy step: its partial
%   matches carry a position before their start and end (tracing shows them without it).

rtl_policy_positioned(M, Name) :-
    member(Suffix, ['_lefts', '_rights', '_negs']),
    sub_atom(Name, Before, _, _, Suffix),
    sub_atom(Name, 0, Before, _, Step),
    atom_concat(Step, '_policy', Info),
    current_predicate(M:Info/1),
    !.

policy_info(M, Step, Info) :-
    atom_concat(Step, '_policy', Name),
    Goal =.. [Name, Info],
    M:Goal.
