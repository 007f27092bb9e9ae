:- module(rtl_pattern_key,
          [ rtl_pattern_mask/2,         % +Pattern, -Mask
            rtl_pattern_key/3           % +Term, +Mask, -Key
          ]).

/** <module> The keys by which events find the patterns that can match them

Memory instances (rtl_slr.pl) and subscriptions (rtl_subscriptions.pl) are found by every
constant argument of their pattern, not by the first argument only: with a memory per tf
frame pair, 48 patterns `tf(torso, Child, V, Q)` differ in their second argument.

A pattern's *mask* has bit I-1 set when its argument I is atomic (a constant an event must
be equal to, `==`, to match: 1 and 1.0 differ). A pattern is filed under its mask and under
its *key*, the hash of its functor, its mask and its constants at the mask's positions. An
event is keyed once per mask in use for its type, with the same predicate: the patterns that
can match it are among those filed under one of its keys, and only those are unified with
it. Nested terms and variables are not in the mask: a pattern `tf(X, f(a), _, _)` is found
by its functor alone, then unification decides.

An event with a variable at a mask position has no key (Key stays unbound); the caller then
tries every pattern of the type.
*/

%!  rtl_pattern_mask(+Pattern, -Mask:integer) is det.
%
%   Mask has bit I-1 set for each atomic argument I of Pattern (0 for an atom or a pattern
%   without constant arguments).

rtl_pattern_mask(Pattern, Mask) :-
    (   compound(Pattern) -> compound_name_arguments(Pattern, _, Args) ; Args = [] ),
    args_mask(Args, 1, 0, Mask).

args_mask([], _, Mask, Mask).
args_mask([A|As], Bit, Mask0, Mask) :-
    (   atomic(A) -> Mask1 is Mask0 \/ Bit ; Mask1 = Mask0 ),
    Bit1 is Bit << 1,
    args_mask(As, Bit1, Mask1, Mask).

%!  rtl_pattern_key(+Term, +Mask:integer, -Key) is det.
%
%   Key is the integer hash of Term's name and arity, Mask, and Term's arguments at the
%   positions of Mask: a pattern and an event equal at those positions have the same key.
%   Key is left unbound when one of those arguments is not ground.

rtl_pattern_key(Term, Mask, Key) :-
    (   compound(Term)
    ->  compound_name_arguments(Term, Name, Args),
        length(Args, Arity)
    ;   Name = Term, Arity = 0, Args = []
    ),
    masked_args(Args, Mask, Values),
    term_hash(k(Name, Arity, Mask, Values), Key).

masked_args([], _, []).
masked_args([A|As], Mask, Values) :-
    (   Mask /\ 1 =:= 1 -> Values = [A|Values1] ; Values = Values1 ),
    Mask1 is Mask >> 1,
    masked_args(As, Mask1, Values1).
