/*  plunit tests of rtl_time_goal/2 (rtl_query.pl): the time terms of a query from outside,
    rewritten through the goal arguments of rtl_goal_arguments/3 as the compiler rewrites the
    program (tests/test_time_terms_roads.py compares the two on generated goals).

        swipl -g run_tests -t halt prolog_runtime/tests/test_time_goal.pl
*/
:- use_module(library(plunit)).
:- use_module('../rtl_query', [rtl_time_goal/2]).
:- use_module('../rtl_goal_arguments').

:- begin_tests(rtl_time_goal).

test(time_term) :-
    rtl_time_goal(place(box, P)^5, G),
    G == place(box, P, 5, 5).
test(interval) :-
    rtl_time_goal(seg(O)^[S, E], G),
    G == seg(O, S, E).
test(atom_event) :-
    rtl_time_goal(ok^T, G),
    G == ok(T, T).
test(partial_list_is_one_time) :-
    rtl_time_goal(p^[A|B], G),
    G == p([A|B], [A|B]),
    var(B).
test(not_an_event) :-
    rtl_time_goal(X^T, G),
    G == X^T.
test(variable_goal) :-
    rtl_time_goal(G0, G),
    G == G0.
test(call) :-
    rtl_time_goal(call(place(box, P)^5), G),
    G == call(place(box, P, 5, 5)).
test(soft_cut) :-
    rtl_time_goal((a^1 *-> b^2 ; c^3), G),
    G == (a(1, 1) *-> b(2, 2) ; c(3, 3)).
test(findall_4) :-
    rtl_time_goal(findall(P^1, p(P)^1, L, T), G),
    G == findall(P^1, p(P, 1, 1), L, T).
test(aggregate_all_4) :-
    rtl_time_goal(aggregate_all(count, X^1, p(X)^1, N), G),
    G == aggregate_all(count, X^1, p(X, 1, 1), N).
test(data_of_prev_stays) :-
    rtl_time_goal(prev(m, tf(L)^T, 12), G),
    G == prev(m, tf(L)^T, 12).
test(outside_the_table) :-
    rtl_time_goal(catch(p^1, E, true), G),
    G == catch(p^1, E, true).
test(every_entry_is_entered, [forall(rtl_goal_arguments(Name, Arity, Positions))]) :-
    numlist(1, Arity, Is),
    maplist(time_term, Is, Args),
    compound_name_arguments(G0, Name, Args),
    rtl_time_goal(G0, G),
    forall(arg(I, G, A),
           (   memberchk(I, Positions) -> A == e(I, t, t) ; A == e(I)^t )).

:- end_tests(rtl_time_goal).

time_term(I, e(I)^t).
