/*  plunit tests of rtl_bridge.pl, the Prolog half of the Python bridge: bridge_apply/6 runs
    a fixed goal with values and never raises, bridge/6 runs trusted goal text in its five
    modes, requests from other threads run in the one owner thread (so global variables are
    the same for every caller), and a request that ends the owner is answered.

        swipl -g run_tests -t halt prolog_runtime/tests/test_bridge.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module('../rtl_bridge').

%   call_from_thread(:Goal): run Goal in a new thread (a caller other than the owner).
call_from_thread(Goal) :-
    thread_create(Goal, Id, []),
    thread_join(Id, Status),
    Status == true.

:- begin_tests(rtl_bridge).

test(apply_success) :-
    bridge_apply("system", "atom_length", ["abcd"], Status, Out, Err),
    assertion(Status == 1), assertion(Out == "4"), assertion(Err == "").

test(apply_failure) :-
    bridge_apply("lists", "nth0", [5, [1, 2]], Status, Out, _),
    assertion(Status == 0), assertion(Out == "").

test(apply_error_is_reported_not_raised) :-
    bridge_apply("system", "atom_length", [1.5, 2], Status, Out, Err),
    assertion(Status == 2),
    assertion(string(Out)),
    assertion(sub_string(Err, 0, _, _, "error(")).

test(apply_values_are_not_parsed) :-
    bridge_apply("system", "string_length", ["halt."], Status, Out, _),
    assertion(Status == 1), assertion(Out == "5").

test(apply_compound_result_is_its_text) :-
    bridge_apply("system", "=", [[1, "a"]], Status, Out, _),
    assertion(Status == 1), assertion(Out == "[1,a]").

test(text_modes) :-
    bridge(0, "X = 1, X > 0", "", S0, _, _), assertion(S0 == 1),
    bridge(0, "fail", "", S1, _, _), assertion(S1 == 0),
    bridge(1, "X = f(Y), Y = 'A b'", "X", S2, O2, _), assertion(S2-O2 == 1-"f('A b')"),
    bridge(2, "member(X, [a, 'B'])", "X", S3, O3, _), assertion(S3-O3 == 1-["a", "'B'"]),
    bridge(3, "atom_codes(V, \"xyz\")", "V", S4, O4, _), assertion(S4-O4 == 1-"xyz").

test(text_syntax_error) :-
    bridge(0, "X = = (", "", Status, Out, _),
    assertion(Status == 2), assertion(Out \== "").

test(unknown_procedure_reads_as_the_users) :-
    bridge(0, "no_such_bridge_test_predicate(1)", "", Status, Out, Err),
    assertion(Status == 2),
    assertion(sub_string(Out, _, _, _, "no_such_bridge_test_predicate")),
    assertion(sub_string(Err, _, _, _, "existence_error")),
    assertion(\+ sub_string(Out, _, _, _, "retalisc_bridge")).

test(consult_collects_errors, [setup(tmp_file_stream(text, File, S)), cleanup(delete_file(File))]) :-
    format(S, "bridge_test_ok(1).~nbridge_test_bad( :- .~n", []),
    close(S),
    bridge(4, File, "", Status, Out, _),
    assertion(Status == 2),
    assertion(sub_string(Out, _, _, _, "yntax")),
    assertion(user:bridge_test_ok(1)).

test(requests_from_every_thread_share_the_owners_globals) :-
    bridge(0, "nb_setval(bridge_plunit_key, 42)", "", S0, _, _),
    assertion(S0 == 1),
    call_from_thread(( bridge(1, "nb_getval(bridge_plunit_key, V)", "V", 1, Out, _),
                       Out == "42" )),
    bridge(1, "thread_self(T)", "T", 1, Owner, _),
    call_from_thread(( bridge(1, "thread_self(T)", "T", 1, Owner2, _), Owner2 == Owner )).

test(a_request_that_ends_the_owner_is_answered) :-
    bridge(0, "abort", "", Status, Out, _),
    assertion(Status == 2),
    assertion(sub_string(Out, _, _, _, "ended")),
    bridge(1, "X is 6 * 7", "X", S1, O1, _),
    assertion(S1-O1 == 1-"42").

test(python_call_fails_without_python) :-
    \+ rtl_python_call(compile_rules, ["m", "p", "t"], _, _).

test(claim_after_the_owner_started_is_refused) :-
    bridge(0, "true", "", 1, _, _),
    call_from_thread(( claim_caller(Claimed), Claimed == false )).

:- end_tests(rtl_bridge).
