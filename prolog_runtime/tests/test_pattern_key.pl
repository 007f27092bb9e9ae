/*  plunit tests of rtl_pattern_key.pl: a pattern's key equals the key of every event that
    unifies with it (random patterns and events), and the mask marks the atomic arguments.

        swipl -g run_tests -t halt prolog_runtime/tests/test_pattern_key.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(random)).
:- use_module('../rtl_pattern_key').

:- begin_tests(rtl_pattern_key).

test(mask_marks_atomic_arguments) :-
    rtl_pattern_mask(tf(torso, _, f(a), 1.0, "s"), M1),
    assertion(M1 =:= 0b11001),
    rtl_pattern_mask(tf(_, _), M2),
    assertion(M2 =:= 0),
    rtl_pattern_mask(tick, M3),
    assertion(M3 =:= 0).

test(keys_differ_by_constant_type_and_functor) :-
    rtl_pattern_mask(p(1, _), M),
    rtl_pattern_key(p(1, _), M, K1),
    rtl_pattern_key(p(1.0, x), M, K2),
    rtl_pattern_key(q(1, x), M, K3),
    rtl_pattern_key(p(1, x), M, K4),
    assertion(K1 =\= K2),
    assertion(K1 =\= K3),
    assertion(K1 =:= K4).

test(non_ground_at_the_mask_has_no_key) :-
    rtl_pattern_key(p(_, x), 1, K),
    assertion(var(K)),
    rtl_pattern_key(p(_, x), 2, K2),
    assertion(integer(K2)).

% Random patterns over p/3 (variables, constants, nested terms) and ground events: when an
% event unifies with a pattern, the event's key under the pattern's mask is the pattern's key
% (the index never misses a match); when the keys are equal, the constants are equal.
test(key_of_a_match_is_the_key_of_its_pattern) :-
    set_random(seed(39)),
    forall(between(1, 3000, _),
           (   random_pattern(P),
               random_event(E),
               rtl_pattern_mask(P, Mask),
               rtl_pattern_key(P, Mask, KP),
               rtl_pattern_key(E, Mask, KE),
               (   \+ \+ P = E
               ->  assertion(KP =:= KE)
               ;   true
               ),
               (   KP =:= KE
               ->  P =.. [_|PA], E =.. [_|EA],
                   forall((nth1(I, PA, A), atomic(A)), (nth1(I, EA, B), assertion(A == B)))
               ;   true
               )
           )).

value(V) :- random_member(V, [a, b, 0, 1, 1.0]).

random_event(p(A, B, C)) :- maplist(random_ground, [A, B, C]).
random_ground(V) :- random_between(0, 3, R), ( R =:= 0 -> value(X), V = f(X) ; value(V) ).

random_pattern(p(A, B, C)) :- maplist(random_arg, [A, B, C]).
random_arg(V) :-
    random_between(0, 3, R),
    (   R =:= 0 -> true
    ;   R =:= 1 -> value(X), V = f(X)
    ;   R =:= 2 -> V = f(_)
    ;   value(V)
    ).

:- end_tests(rtl_pattern_key).
