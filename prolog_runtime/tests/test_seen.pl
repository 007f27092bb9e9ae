/*  plunit tests of rtl_seen.pl: the input events remembered to check retractions. On a long
    stream only the events of the last max_delay + window seconds (and at most a few
    generations of 1,024 more) are kept, every event within the horizon can be retracted
    exactly as often as it was added, and one never added cannot.

        swipl -g run_tests -t halt prolog_runtime/tests/test_seen.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(random)).
:- use_module('../retalis').

% A program with one store of window 10 s and no rules.
:- dynamic seen_test_program:ele_trigger/3, seen_test_program:ele_untrigger/3,
           seen_test_program:s_lefts/3.
seen_test_program:ele_store(s_lefts, 3, 10).
seen_test_program:ele_partial_store(s_lefts, 3).
seen_test_program:ele_printed(_).
:- dynamic other_test_program:ele_trigger/3, other_test_program:ele_untrigger/3.
other_test_program:ele_printed(_).
other_test_program:ele_store(o_lefts, 3, 10).
other_test_program:ele_partial_store(o_lefts, 3).
:- dynamic other_test_program:o_lefts/3.

setup :-
    rtl_use_program(seen_test_program),
    rtl_clear,
    rtl_set_flag(max_delay, 1),
    rtl_output_to(buffer).

add(Event, T) :-
    rtl_seen_add(Event, T, T),
    rtl_event(Event, T, T).

:- begin_tests(rtl_seen, [setup(setup)]).

test(bounded_on_a_long_stream) :-
    forall(between(1, 6000, I), ( K is I mod 7, add(e(K), I) )),
    rtl_seen_count(N),
    rtl_seen_horizon(H),
    assertion(H =:= 6000 - 1 - 10),
    assertion(N >= 11),
    assertion(N =< 11 + 2 * 1024).

test(recent_events_can_be_retracted_once, [setup(setup)]) :-
    forall(between(1, 5000, I), add(e(I), I)),
    assertion(rtl_seen_take(e(4995), 4995, 4995)),
    assertion(\+ rtl_seen_take(e(4995), 4995, 4995)),          % retracted already
    assertion(\+ rtl_seen_take(e(4996), 4995, 4995)),          % never added with that time
    assertion(\+ rtl_seen_take(nope, 4990, 4990)),
    rtl_seen_horizon(H),
    assertion(4990 >= H).

test(duplicates_are_counted, [setup(setup)]) :-
    add(d, 1), add(d, 1), add(d, 2),
    assertion(rtl_seen_take(d, 1, 1)),
    assertion(rtl_seen_take(d, 1, 1)),
    assertion(\+ rtl_seen_take(d, 1, 1)),
    assertion(rtl_seen_take(d, 2, 2)).

% Model: a random stream of adds (keys 0..4, one per second, some late) and retractions of
% random recent keys; every retraction of an event within the horizon succeeds exactly when
% the model holds it.
test(agrees_with_a_list_model, [setup(setup)]) :-
    set_random(seed(12)),
    numlist(1, 3000, Ticks),
    foldl(model_step, Ticks, [], _).

% The same model with most events added in blocks (rtl_seen_add_atomic/1, as the line loop
% adds a block of lines read at once) of random length, 200 events a second (a generation
% spans less than the horizon), some with an event twice; single adds and retractions of
% random recent keys come between the blocks.
test(blocks_agree_with_a_list_model, [setup(setup)]) :-
    set_random(seed(7)),
    block_steps(1, [], _).

block_steps(T, Model, Model) :-
    T > 200,
    !.
block_steps(T, Model0, Model) :-
    random_between(1, 4, Choice),
    (   Choice == 1
    ->  retraction_step(T, Model0, Model1),
        T1 = T
    ;   Choice == 2
    ->  random_between(0, 4, K),
        add(k(K), T),
        Model1 = [k(K)-T|Model0],
        T1 is T + 1
    ;   random_between(1, 600, Length),                % 200 events a second
        findall(a(k(K), Time), ( between(1, Length, I), Time is T + I // 200, random_between(0, 4, K) ),
                Items0),
        T1 is T + Length // 200 + 1,
        (   Items0 = [Twin|_], random_between(1, 3, 1)
        ->  append(Items0, [Twin], Items)            % the first event once more, at its time
        ;   Items = Items0
        ),
        rtl_seen_add_atomic(Items),
        forall(member(a(E, Time), Items), rtl_event(E, Time, Time)),
        findall(E-Time, member(a(E, Time), Items), Added),
        reverse(Added, Newest),
        append(Newest, Model0, Model1)
    ),
    block_steps(T1, Model1, Model).

retraction_step(T, Model0, Model) :-
    random_between(0, 4, K),
    random_between(1, 15, Back),
    take_back(k(K), T, Back, Model0, Model).

%   take_back(+Event, +T, +Back, +Model0, -Model): retract Event at T - Back when that is
%   inside the horizon; the store must agree with the model on whether it is there.
take_back(Event, T, Back, Model0, Model) :-
    Time is T - Back,
    rtl_seen_horizon(H),
    (   Time >= H
    ->  (   selectchk(Event-Time, Model0, Model)
        ->  assertion(rtl_seen_take(Event, Time, Time))
        ;   assertion(\+ rtl_seen_take(Event, Time, Time)),
            Model = Model0
        )
    ;   Model = Model0
    ).

test(blocks_are_counted_and_bounded, [setup(setup)]) :-
    forall(between(0, 99, B),
           ( First is B * 60 + 1, Last is First + 59,
             findall(a(e(I), I), between(First, Last, I), Items),
             rtl_seen_add_atomic(Items),
             forall(member(a(E, T), Items), rtl_event(E, T, T)) )),
    rtl_seen_count(N),
    rtl_seen_horizon(H),
    assertion(H =:= 6000 - 1 - 10),
    assertion(N >= 11),
    assertion(N =< 11 + 2 * 1024 + 60),
    assertion(rtl_seen_take(e(5995), 5995, 5995)),
    assertion(\+ rtl_seen_take(e(5995), 5995, 5995)),
    assertion(\+ rtl_seen_take(e(5995), 5995, 5996)),
    rtl_seen_count(N1),
    assertion(N1 =:= N - 1).

model_step(T, Model0, Model) :-
    random_between(0, 4, K),
    (   random_between(1, 5, 1)
    ->  random_between(0, 3, Back),
        take_back(k(K), T, Back, Model0, Model)
    ;   add(k(K), T),
        Model = [k(K)-T|Model0]
    ).

% Two programs of one process: each checks retractions against its own events, switching
% back finds the open generation again, and clearing one forgets only its events.
test(each_program_has_its_own_store, [setup(setup)]) :-
    add(mine, 1),
    rtl_use_program(other_test_program),
    assertion(\+ rtl_seen_take(mine, 1, 1)),
    rtl_seen_add(theirs, 2, 2),
    assertion(rtl_seen_count(1)),
    rtl_use_program(seen_test_program),
    assertion(rtl_seen_count(1)),
    assertion(\+ rtl_seen_take(theirs, 2, 2)),
    rtl_clear,
    assertion(rtl_seen_count(0)),
    rtl_use_program(other_test_program),
    assertion(rtl_seen_take(theirs, 2, 2)),
    rtl_clear,
    rtl_use_program(seen_test_program).

test(generation_modules_are_not_shared, [setup(setup)]) :-
    forall(between(1, 1100, I), add(e(I), I)),                 % a closed generation and an open one
    rtl_use_program(other_test_program),
    forall(between(1, 1100, I), rtl_seen_add(f(I), I, I)),
    findall(M-P, rtl_seen_owner(M, P), Owners),
    forall(( member(M-P, Owners), member(M-Q, Owners) ), assertion(P == Q)),
    assertion(\+ rtl_seen_take(e(1050), 1050, 1050)),
    assertion(rtl_seen_take(f(1050), 1050, 1050)),
    rtl_clear,
    rtl_use_program(seen_test_program),
    assertion(rtl_seen_take(e(1050), 1050, 1050)).

:- end_tests(rtl_seen).
