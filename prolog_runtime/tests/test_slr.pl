/*  plunit tests of rtl_slr.pl internals: the numbering of records (thesis 5.2.1-5.2.2).
    Load a compiled Retalis program (any; it only hosts the memories) whose path is in the
    environment variable SLR_TEST_PROGRAM:

        SLR_TEST_PROGRAM=/tmp/host.pl swipl -g run_tests -t halt prolog_runtime/tests/test_slr.pl

    Records of instance H are `record(H * 2^40 + Number, Start, End, Template)` numbered
    First..Last in end-time order; these tests look at the numbers themselves.
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).

:- set_prolog_flag(retalis_embedded, true).
:- getenv('SLR_TEST_PROGRAM', File) -> consult(File)
   ;  throw(error(existence_error(environment_variable, 'SLR_TEST_PROGRAM'), _)).

%   fresh(+Id, +N): a new memory Id of x/1 events keeping N records, clock and records reset.
fresh(Id, N) :-
    rtl_ele:rtl_clear,
    rtl_slr:d_mem(_),
    rtl_slr:c_mem(Id, x(_)-[], N, inf).

add(V, T) :- rtl_ele:rtl_event(x(V), T, T).
del(V, T) :- rtl_ele:rtl_retract_event(x(V), T, T).

%   numbered(+Id, -First, -Last, -Records): the numbers and the records Number-End-Value.
numbered(Id, First, Last, Records) :-
    rtl_slr:current_program(M),
    rtl_slr:id_handle(M, Id, H),
    rtl_slr:bounds(H, First, Last),
    findall(N-E-V, ( between(First, Last, N), rtl_slr:key(H, N, K), rtl_slr:record(K, _, E, x(V)) ),
            Records).

%   clauses(+Id, -Count): every record/4 clause of the instance, numbered in range or not.
clauses(Id, Count) :-
    rtl_slr:current_program(M),
    rtl_slr:id_handle(M, Id, H),
    rtl_slr:key_base(Base),
    aggregate_all(count, ( rtl_slr:record(K, _, _, _), K // Base =:= H ), Count).

%   well_formed(+Id, -Values): one record per number First..Last, no other clause,
%   ends non-decreasing; Values in number order.
well_formed(Id, Values) :-
    numbered(Id, First, Last, Records),
    length(Records, Size),
    assertion(Size =:= Last - First + 1),
    clauses(Id, Count),
    assertion(Count =:= Size),
    pairs_keys_values(Records, NumberEnds, Values),
    pairs_values(NumberEnds, Ends),
    assertion(msort(Ends, Ends)).


%   Instances are found through the hash of their pattern's constants (one mask per set of
%   constant positions): what each instance records equals plain unification of every event
%   with every pattern, over random patterns (constants, variables, nested terms) and events.
random_arg(A) :-
    random_between(0, 5, K),
    (   K =< 1 -> random_member(A, [a, b, 1])
    ;   K =:= 2 -> random_member(A, [f(a), f(_), g(b, _)])
    ;   true
    ).

random_event_arg(A) :-
    random_member(A, [a, b, 1, 2, f(a), f(b), g(b, c), "a"]).

index_round :-
    rtl_ele:rtl_clear,
    rtl_slr:d_mem(_),
    random_between(1, 12, NP),
    findall(I-P, ( between(1, NP, I), P = p(_, _, _),
                   forall(arg(J, P, A), ( J > 0, random_arg(A) )) ), Patterns),
    forall(member(I-P, Patterns), rtl_slr:c_mem(m(I), P-[], inf, inf)),
    findall(p(A1, A2, A3), ( between(1, 30, _), random_event_arg(A1), random_event_arg(A2),
                             random_event_arg(A3) ), Events),
    forall(nth1(T, Events, E), rtl_ele:rtl_event(E, T, T)),
    forall(member(I-P, Patterns),
           (   aggregate_all(count, ( member(E, Events), \+ E \= P ), Expected),
               rtl_slr:current_program(M),
               rtl_slr:id_handle(M, m(I), H),
               rtl_slr:bounds(H, First, Last),
               Got is Last - First + 1,
               assertion(Got =:= Expected)
           )).

:- begin_tests(rtl_slr, [cleanup((rtl_slr:d_mem(_), rtl_ele:rtl_clear))]).

test(index_finds_what_unification_finds) :-
    set_random(seed(39)),
    forall(between(1, 20, _), index_round).


test(in_order_records_are_appended) :-
    fresh(m, inf),
    numbered(m, F0, L0, []),
    assertion(L0 =:= F0 - 1),
    forall(member(T, [1, 2, 2, 3]), add(T, T)),
    numbered(m, F0, L1, _),                     % First does not move
    assertion(L1 =:= F0 + 3),
    well_formed(m, Vs),
    assertion(Vs == [1, 2, 2, 3]).

test(late_records_are_inserted_in_end_time_order) :-
    fresh(m, inf),
    forall(member(T, [1, 2, 3, 5, 6, 7, 8]), add(T, T)),
    numbered(m, F0, L0, _),
    add(4, 4),                                  % 3 records before its place, 4 after
    numbered(m, F1, L1, _),
    assertion(F1 =:= F0 - 1), assertion(L1 =:= L0),   % the shorter side moved: the first three
    add(7.5, 7.5),                              % near the end: the last record moves up
    numbered(m, F2, L2, _),
    assertion(F2 =:= F1), assertion(L2 =:= L1 + 1),
    add(0, 0),                                  % before all: numbered First - 1, nothing moves
    numbered(m, F3, L3, _),
    assertion(F3 =:= F2 - 1), assertion(L3 =:= L2),
    well_formed(m, Vs),
    assertion(Vs == [0, 1, 2, 3, 4, 5, 6, 7, 7.5, 8]).

test(records_of_one_end_time_go_by_start_then_template_whatever_the_arrival_order) :-
    Events = [x(a)-5-5, x(b)-6-6, x(c)-5-5, x(d)-4-5, x(0)-5-5],
    forall(permutation(Events, Order),
           ( fresh(m, inf),
             forall(member(E-S-T, Order), rtl_ele:rtl_event(E, S, T)),
             well_formed(m, Vs),
             assertion(Vs == [d, 0, a, c, b]) )).   % d starts earlier; 0 @< a @< c

test(count_forgets_the_first_number) :-
    fresh(m, 3),
    forall(member(T, [1, 2, 3]), add(T, T)),
    numbered(m, F0, _, _),
    add(4, 4),
    numbered(m, F1, _, _),
    assertion(F1 =:= F0 + 1),
    add(1.5, 1.5),                              % late and older than all: forgotten at once
    well_formed(m, Vs1),
    assertion(Vs1 == [2, 3, 4]),
    add(3.5, 3.5),                              % late but among the three latest: 2 goes
    well_formed(m, Vs2),
    assertion(Vs2 == [3, 3.5, 4]).

test(retraction_closes_the_gap) :-
    fresh(m, inf),
    forall(member(T, [1, 2, 3, 4, 5, 6, 7]), add(T, T)),
    numbered(m, F0, L0, _),
    del(2, 2),                                  % near the start: the first record moves up
    numbered(m, F1, L1, _),
    assertion(F1 =:= F0 + 1), assertion(L1 =:= L0),
    well_formed(m, Vs1),
    assertion(Vs1 == [1, 3, 4, 5, 6, 7]),
    del(6, 6),                                  % near the end: the last record moves down
    numbered(m, F2, L2, _),
    assertion(F2 =:= F1), assertion(L2 =:= L1 - 1),
    well_formed(m, Vs2),
    assertion(Vs2 == [1, 3, 4, 5, 7]),
    del(1, 1), del(7, 7),                       % the ends themselves
    well_formed(m, Vs3),
    assertion(Vs3 == [3, 4, 5]),
    del(9, 9),                                  % no such record: nothing changes
    well_formed(m, Vs4),
    assertion(Vs4 == [3, 4, 5]).

test(retraction_takes_one_of_equal_records) :-
    fresh(m, inf),
    rtl_ele:rtl_event(x(a), 5, 5),
    rtl_ele:rtl_event(x(b), 5, 5),
    rtl_ele:rtl_event(x(a), 5, 5),
    rtl_ele:rtl_event(x(a), 4, 5),
    rtl_ele:rtl_retract_event(x(a), 5, 5),      % one x(a)^[5,5]; not x(a)^[4,5]
    well_formed(m, Vs),
    assertion(Vs == [a, a, b]),
    rtl_slr:current_program(M), rtl_slr:id_handle(M, m, H), rtl_slr:bounds(H, First, _),
    rtl_slr:key(H, First, K), rtl_slr:record(K, S, _, _),
    assertion(S =:= 4).

test(deleting_an_instance_removes_its_records) :-
    fresh(m, inf),
    forall(member(T, [1, 2, 3]), add(T, T)),
    rtl_slr:current_program(M), rtl_slr:id_handle(M, m, H),
    rtl_slr:d_mem(m),
    rtl_slr:key_base(Base),
    assertion(\+ ( rtl_slr:record(K, _, _, _), K // Base =:= H )),
    assertion(\+ rtl_slr:exist_mem(m)).

:- end_tests(rtl_slr).
