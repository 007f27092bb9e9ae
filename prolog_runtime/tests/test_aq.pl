/*  plunit tests of rtl_aq.pl.  Load a program compiled from Program 4 of the thesis
    (left recursion) whose path is in the environment variable AQ_TEST_PROGRAM:

        AQ_TEST_PROGRAM=/tmp/p4.pl swipl -g run_tests -t halt prolog_runtime/tests/test_aq.pl
*/
:- use_module(library(plunit)).

:- getenv('AQ_TEST_PROGRAM', File) -> consult(File) ; throw(error(existence_error(environment_variable, 'AQ_TEST_PROGRAM'), _)).

:- begin_tests(rtl_aq, [cleanup(rtl_aq:aq_reset)]).

test(left_recursion_terminates, [setup(aq_reset), cleanup(aq_reset), true(As == [path(0,1), path(0,2)])]) :-
    aq_register(q, path(0, _), As).

test(add_then_delete, [setup(aq_reset), cleanup((aq_reset, user:retractall(edge(2,3))))]) :-
    aq_register(q, path(0, _), _), aq_events(_),
    aq_assert(edge(2, 3)),
    aq_events(E1), assertion(E1 == [ev(q, add, path(0,3))]),
    aq_retract(edge(2, 3)),
    aq_events(E2), assertion(E2 == [ev(q, delete, path(0,3))]).

test(cycle_rederives, [setup(aq_reset), cleanup((aq_reset, user:retractall(edge(2,0)), user:retractall(edge(0,2))))]) :-
    aq_register(q, path(0, _), _),
    aq_assert(edge(2, 0)), aq_assert(edge(0, 2)), aq_events(_),
    aq_retract(edge(1, 2)),          % path(0,2) still holds through edge(0,2)
    aq_events(E), assertion(E == []),
    aq_answers(q, As), assertion(As == [path(0,0), path(0,1), path(0,2)]),
    aq_assert(edge(1, 2)).

test(unregister_frees_everything, [setup(aq_reset)]) :-
    aq_register(a, path(_, _), _),
    aq_register(b, path(1, _), _),
    aq_unregister(a), aq_unregister(b),
    aq_stats(S),
    forall(member(_=V, S), assertion(V == 0)).

test(duplicate_id, [setup(aq_reset), cleanup(aq_reset), error(permission_error(register, active_query, q))]) :-
    aq_register(q, path(0, _), _),
    aq_register(q, path(1, _), _).

% A non-ground stored fact: retracting a ground instance of it changes nothing,
% retracting a ground fact leaves the non-ground one alone.
test(non_ground_facts, [setup(aq_reset), cleanup(aq_reset)]) :-
    aq_register(q, path(0, _), _),
    aq_retract(edge(0, 7)),                    % ground and absent: nothing
    aq_answers(q, A0), assertion(A0 == [path(0,1), path(0,2)]),
    aq_assert(edge(2, _)),
    aq_answers(q, A1), assertion(A1 = [path(0,_), path(0,1), path(0,2)]),
    aq_retract(edge(2, 7)),
    aq_answers(q, A2), assertion(A2 =@= A1),
    aq_retract(edge(1, 2)),
    aq_answers(q, A3), assertion(A3 == [path(0,1)]),
    assertion(( user:clause(edge(2, X), true), var(X) )),
    aq_retract(edge(2, _)),
    aq_assert(edge(1, 2)),
    aq_answers(q, A4), assertion(A4 == [path(0,1), path(0,2)]).

test(not_dynamic, [error(permission_error(modify, static_procedure, path/2))]) :-
    aq_assert(path(5, 6)).

% Facts are a set.  A second copy of a stored fact (as consulting another file
% of facts leaves it) is the same fact: one retraction removes it, and the
% states derived from both copies go with it.
test(fact_stored_twice, [setup(aq_reset), cleanup(restore_program4)]) :-
    user:assertz(edge(1, 2)),
    aq_register(q, path(0, _), A0), assertion(A0 == [path(0,1), path(0,2)]),
    aq_retract(edge(1, 2)),
    aq_events(E1), assertion(E1 == [ev(q, delete, path(0,2))]),
    assertion(\+ user:edge(1, 2)),
    aq_assert(edge(1, 2)),
    aq_events(E2), assertion(E2 == [ev(q, add, path(0,2))]),
    aq_retract(edge(1, 2)),
    aq_events(E3), assertion(E3 == [ev(q, delete, path(0,2))]),
    aq_answers(q, A3), assertion(A3 == [path(0,1)]),
    aq_unregister(q),
    aq_stats(S), forall(member(_=V, S), assertion(V == 0)).

test(batch_names_a_fact_twice, [setup(aq_reset), cleanup(restore_program4)]) :-
    aq_register(q, path(0, _), _),
    aq_assert_all([edge(2, 3), edge(2, 3)]),
    aq_events(E1), assertion(E1 == [ev(q, add, path(0,3))]),
    aggregate_all(count, user:edge(2, 3), N), assertion(N == 1),
    aq_retract_all([edge(2, 3), edge(2, 3)]),
    aq_events(E2), assertion(E2 == [ev(q, delete, path(0,3))]),
    aq_assert_all([edge(2, 3), edge(2, 3)]),
    aq_retract(edge(2, 3)),
    aq_events(E3), assertion(E3 == [ev(q, add, path(0,3)), ev(q, delete, path(0,3))]),
    aq_answers(q, A), assertion(A == [path(0,1), path(0,2)]).

% A query's own consumer record is added after its evaluation: a second query
% of the same goal shares the table and gets its answers, both are notified
% of later changes, and either keeps being notified after the other goes.
test(queries_share_a_table, [setup(aq_reset), cleanup(restore_program4)]) :-
    aq_register(a, path(0, _), A0), assertion(A0 == [path(0,1), path(0,2)]),
    aq_register(b, path(0, _)),
    aq_events(E0), assertion(E0 == [ev(b, answer, path(0,1)), ev(b, answer, path(0,2))]),
    aq_register(c, path(1, _), C0), assertion(C0 == [path(1,2)]),
    aq_assert(edge(2, 3)),
    aq_events(E1), msort(E1, E1s),
    assertion(E1s == [ev(a, add, path(0,3)), ev(b, add, path(0,3)), ev(c, add, path(1,3))]),
    aq_unregister(a),
    aq_retract(edge(1, 2)),
    aq_events(E2), msort(E2, E2s),
    assertion(E2s == [ev(b, delete, path(0,2)), ev(b, delete, path(0,3)),
                      ev(c, delete, path(1,2)), ev(c, delete, path(1,3))]),
    aq_unregister(b), aq_unregister(c),
    aq_stats(S), forall(member(_=V, S), assertion(V == 0)).

restore_program4 :-
    aq_reset,
    retractall(user:edge(_, _)),
    assertz(user:edge(0, 1)),
    assertz(user:edge(1, 2)).

:- end_tests(rtl_aq).
