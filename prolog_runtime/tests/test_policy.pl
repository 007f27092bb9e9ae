/*  plunit tests of rtl_policy.pl, through compiled programs: under `recent` and
    `chronological` a step pairs each arriving instance with one waiting partner and consumes
    both. Random streams (in time order) give what a brute-force simulation of the policy
    gives, and deleting random input events afterwards nets the output to that of a run in
    which they never arrived (the engine against itself). Needs a Python that compiles
    (compiled_program.pl).

        RETALISC_PYTHON=.venv/bin/python swipl -g run_tests -t halt prolog_runtime/tests/test_policy.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(random)).
:- use_module(library(pairs)).
:- use_module('../retalis').
:- use_module(compiled_program).

:- dynamic program/2.            % program(Policy, Module)

load_programs :-
    (   program(_, _)
    ->  true
    ;   forall(member(Policy, [recent, chronological]),
               ( format(string(Source),
                        ":- set_etalis_flag(event_consumption_policy, ~w).~nr(I, X, Y) <- a(I, X) seq b(I, Y).~n",
                        [Policy]),
                 atom_concat(policy_, Policy, Name),
                 load_compiled_program(Name, Source, Module),
                 assertz(program(Policy, Module)) ))
    ).

start(Policy) :-
    program(Policy, M),
    rtl_use_program(M),
    rtl_clear,
    rtl_set_flag(max_delay, inf),
    rtl_output_to(buffer),
    rtl_take_output(_).

feed(add-E-T) :- rtl_event(E, T, T).
feed(retract-E-T) :- rtl_retract_event(E, T, T).

% The output lines netted: Line-Count, additions +1, deletions -1, zeros left out.
netted(Lines, Net) :-
    foldl(count_line, Lines, [], Counts0),
    exclude([_-0]>>true, Counts0, Counts1),
    msort(Counts1, Net).
count_line(Line, C0, C) :-
    (   sub_string(Line, B, _, 0, ", \"op\": \"retract\"}")
    ->  sub_string(Line, 0, B, _, Head), string_concat(Head, "}", Key), D = -1
    ;   Key = Line, D = 1
    ),
    (   selectchk(Key-N0, C0, C1) -> true ; N0 = 0, C1 = C0 ),
    N is N0 + D,
    C = [Key-N|C1].

run_lines(Policy, Events, Lines) :-
    start(Policy),
    maplist(feed, Events),
    rtl_take_output(Lines).

% The policy simulated: waiting a(I, X) instances (I-X-T), in arrival order.
simulate(Policy, Events, Lines) :-
    foldl(sim(Policy), Events, []-[], _-Rev),
    reverse(Rev, Lines).
sim(Policy, add-a(I, X)-T, W0-L, W-L) :-
    (   Policy == recent, select(I-X-_, W0, W1) -> true ; W1 = W0 ),    % a twin is replaced
    append(W1, [I-X-T], W).
sim(Policy, add-b(I, Y)-T, W0-L0, W-L) :-
    include([I1-_-Ta]>>(I1 == I, Ta < T), W0, Partners),
    (   Partners == []
    ->  W = W0, L = L0
    ;   (   Policy == recent -> last(Partners, I-X-Ta) ; Partners = [I-X-Ta|_] ),
        selectchk(I-X-Ta, W0, W),
        format(string(Line), "{\"event\": \"~q\", \"start\": ~w, \"end\": ~w}", [r(I, X, Y), Ta, T]),
        L = [Line|L0]
    ).

random_events(N, Events) :-
    numlist(1, N, Ns),
    foldl([_, T0-E0, T-E]>>( random_between(0, 2, Dt), T is T0 + Dt,
                             random_between(1, 2, I), random_member(X, [x, y, z]),
                             random_member(Ev, [a(I, X), b(I, X)]),
                             append(E0, [add-Ev-T], E) ),
          Ns, 0-[], _-Events).

:- begin_tests(rtl_policy, [setup(load_programs)]).

test(the_policies_against_a_simulation) :-
    set_random(seed(36)),
    forall(( between(1, 60, _), member(Policy, [recent, chronological]) ),
           ( random_between(1, 12, N), random_events(N, Events),
             run_lines(Policy, Events, Lines),
             simulate(Policy, Events, Expected),
             assertion(Lines == Expected) )).

test(a_deletion_nets_to_the_run_without_the_event) :-
    set_random(seed(7)),
    forall(( between(1, 60, _), member(Policy, [recent, chronological]) ),
           ( random_between(1, 12, N), random_events(N, Events),
             random_between(1, N, K), length(Deleted0, K),
             random_permutation(Events, Shuffled), append(Deleted0, _, Shuffled),
             foldl([D, Es0, Es]>>selectchk(D, Es0, Es), Deleted0, Events, Kept),  % one arrival each
             findall(retract-E-T, member(add-E-T, Deleted0), Deletions),
             append(Events, Deletions, WithDeletions),
             run_lines(Policy, WithDeletions, Lines),
             run_lines(Policy, Kept, Without),
             netted(Lines, Net),
             netted(Without, Expected),
             assertion(Net == Expected) )).

test(a_golden_case_recent) :-
    run_lines(recent, [add-a(1, x)-1, add-a(1, y)-2, add-b(1, p)-3, add-b(1, q)-4], L1),
    assertion(L1 == ["{\"event\": \"r(1,y,p)\", \"start\": 2, \"end\": 3}",
                     "{\"event\": \"r(1,x,q)\", \"start\": 1, \"end\": 4}"]),
    run_lines(recent, [add-a(1, x)-1, add-a(1, y)-2, add-b(1, p)-3, add-b(1, q)-4, retract-a(1, y)-2], L2),
    netted(L2, N2),
    assertion(N2 == ["{\"event\": \"r(1,x,p)\", \"start\": 1, \"end\": 3}"-1]).

:- end_tests(rtl_policy).
