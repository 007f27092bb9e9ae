/*  plunit tests of rtl_relations.pl: the table of the operators' temporal relations is data
    the compiler can read (facts over the intervals' variables only) and means what
    docs/language.md says, on sample intervals.

        swipl -g run_tests -t halt prolog_runtime/tests/test_relations.pl
*/
:- use_module(library(plunit)).
:- use_module(library(apply)).
:- use_module('../rtl_relations').

:- begin_tests(rtl_relations).

holds(Goals) :- maplist(call, Goals).

relation_holds(Op, S1-E1, S2-E2, S, E) :-
    rtl_relation(Op, S1-E1, S2-E2, Goals, Start, End),
    holds(Goals),
    S is Start, E is End.

test(one_relation_per_operator) :-
    findall(Op, rtl_relation(Op, _, _, _, _, _), Ops),
    msort(Ops, Sorted), sort(Ops, Unique),
    assertion(Sorted == Unique),
    assertion(Unique == [and, cnot, during, equals, finishes, meets, par, seq, starts]).

test(goals_read_only_the_intervals, [forall(rtl_relation(Op, L, R, Goals, S, E))]) :-
    term_variables(L-R, Known),
    term_variables(Goals-S-E, Used),
    forall(member(V, Used), memberchk_eq(V, Known)),
    assertion(atom(Op)).

memberchk_eq(X, [Y|Ys]) :- ( X == Y -> true ; memberchk_eq(X, Ys) ).

test(seq) :-
    assertion(relation_holds(seq, 1-2, 3-4, 1, 4)),
    assertion(\+ relation_holds(seq, 1-3, 3-4, _, _)).
test(and) :-
    assertion(relation_holds(and, 3-4, 1-2, 1, 4)).
test(par) :-
    assertion(relation_holds(par, 1-3, 2-5, 1, 5)),
    assertion(\+ relation_holds(par, 1-2, 2-5, _, _)).
test(equals) :-
    assertion(relation_holds(equals, 1-3, 1.0-3, 1, 3)),
    assertion(\+ relation_holds(equals, 1-3, 1-4, _, _)).
test(meets) :-
    assertion(relation_holds(meets, 1-3, 3-5, 1, 5)).
test(during) :-
    assertion(relation_holds(during, 2-3, 1-5, 1, 5)),
    assertion(\+ relation_holds(during, 1-3, 1-5, _, _)).
test(starts) :-
    assertion(relation_holds(starts, 1-3, 1-5, 1, 5)).
test(finishes) :-
    assertion(relation_holds(finishes, 2-5, 1-5, 1, 5)).

test(cnot_blocker_strictly_between) :-
    rtl_blocker(cnot, 1-2, 5-6, 3-4, Between), assertion(holds(Between)),
    rtl_blocker(cnot, 1-2, 5-6, 2-4, AtEnd), assertion(\+ holds(AtEnd)).

test(fnot_blocker_before_and_within_the_window) :-
    rtl_blocker(fnot, 5-5, none, 1-1, Before), assertion(holds(Before)),
    rtl_blocker(fnot, 5-5, none, 5-5, Same), assertion(\+ holds(Same)),
    rtl_blocker_window(fnot, 5-5, 1-1, From, To),
    rtl_window(From, To, 2, Far), assertion(\+ call(Far)),
    rtl_window(From, To, 4, Near), assertion(call(Near)).

test(absence_result_and_blocker) :-
    rtl_absence_result(1-2, 3, Start, End0),
    End is End0,
    assertion(Start-End == 1-5),
    rtl_blocker(absence, 1-2, 1-5, 5-5, AtEnd), assertion(holds(AtEnd)),
    rtl_blocker(absence, 1-2, 1-5, 2-3, AtL), assertion(\+ holds(AtL)).

:- end_tests(rtl_relations).
