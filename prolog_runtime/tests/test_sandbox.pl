/*  plunit tests of rtl_sandbox.pl, through its exported predicates: what untrusted goals
    may run. Pure goals pass (with their guards in place); goals with effects outside the
    goal (files, processes, flags, global variables, the program's database, message
    printing, attributed variables, blocking) are refused, also when reached through the
    program's own predicates, and the refusal names the culprit and the path.

        swipl -g run_tests -t halt prolog_runtime/tests/test_sandbox.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module('../retalis').
:- use_module('../rtl_sandbox').

% A program: `nearby/2` is pure, `leaky/1` reaches shell/1, `grow/1` changes the program.
:- dynamic sandbox_test_program:ele_trigger/3, sandbox_test_program:ele_untrigger/3,
           sandbox_test_program:ele_store/3, sandbox_test_program:ele_partial_store/2,
           sandbox_test_program:fact/1.
sandbox_test_program:ele_printed(_).
sandbox_test_program:fact(1).
sandbox_test_program:(nearby(X, Y) :- Y is X + 1).
sandbox_test_program:(leaky(X) :- helper(X)).
sandbox_test_program:(helper(X) :- shell(X)).
sandbox_test_program:(grow(X) :- assertz(fact(X))).

setup :- rtl_use_program(sandbox_test_program).

safe(Goal) :-
    catch(( rtl_check_goal(query([]), sandbox_test_program, Goal, _), Safe = true ),
          error(rtl_unsafe(_, _, _), _), Safe = false),
    Safe == true.

refused(Goal, Culprit, Path) :-
    catch(( rtl_check_goal(query([]), sandbox_test_program, Goal, _), fail ),
          error(rtl_unsafe(Culprit, _, Path), _), true).

:- begin_tests(rtl_sandbox, [setup(setup)]).

test(pure_goals_pass) :-
    forall(member(G, [X is 1 + 2, atom_length(abc, _), findall(Y, member(Y, [1, 2]), _),
                      ( member(Z, [1, 2]), Z > 1 -> true ; fail ), \+ fail, msort([b, a], _),
                      format(atom(_), "~w", [x]), nearby(1, _), fact(_), forall(fact(F), F > 0),
                      aggregate_all(count, fact(_), _), catch(true, _, true)]),
           assertion(safe(G))),
    assertion(var(X)).

test(effects_are_refused) :-
    forall(member(G-PI, [shell(ls)-shell/1, open(f, write, _)-open/3, set_prolog_flag(x, y)-set_prolog_flag/2,
                         nb_setval(k, 1)-nb_setval/2, assertz(fact(2))-assertz/1,
                         retract(fact(1))-retract/1, print_message(error, x)-print_message/2,
                         put_attr(_, m, 1)-put_attr/3, sleep(1)-sleep/1, halt-halt/0,
                         thread_create(true, _, [])-thread_create/3]),
           ( refused(G, Culprit, _),
             assertion(nonvar(Culprit)),
             (   Culprit = _:PI0 -> true ; PI0 = Culprit ),
             assertion(PI0 == PI) )).

test(effects_reached_through_the_program_name_the_path) :-
    refused(leaky(ls), Culprit, Path),
    assertion(Culprit == shell/1),
    assertion(memberchk(leaky/1, Path)),
    refused(grow(3), _, _),
    assertion(\+ sandbox_test_program:fact(3)).

test(nothing_refused_runs) :-
    nb_setval(sandbox_test_ran, false),
    refused(( nb_setval(sandbox_test_ran, true) ), _, _),
    nb_getval(sandbox_test_ran, Ran),
    assertion(Ran == false).

test(a_query_may_write_its_own_module_only) :-
    rtl_check_goal(query([sandbox_tmp]), sandbox_tmp, assertz(sandbox_tmp:x(1)), _),
    catch(( rtl_check_goal(query([sandbox_tmp]), sandbox_tmp, assertz(sandbox_test_program:fact(9)), _), fail ),
          error(rtl_unsafe(_, _, _), _), true).

test(runtime_internals_are_refused_unless_declared) :-
    assertion(\+ safe(rtl_ele:rtl_set_flag(max_delay, 0))),
    assertion(\+ safe(rtl_clear)),
    assertion(safe(rtl_clock(_))).

test(format_directives_that_call_goals_are_refused) :-
    assertion(\+ safe(format(atom(_), "~@", [shell(ls)]))),
    assertion(safe(format(atom(_), "~a ~d", [x, 1]))).

test(the_message_names_the_culprit_and_the_path) :-
    catch(( rtl_check_goal(query([]), sandbox_test_program, leaky(ls), _), fail ), Error, true),
    rtl_unsafe_message(Error, Message),
    assertion(Message == "unsafe goal: shell/1 (reached from leaky/1 -> helper/1)").

:- end_tests(rtl_sandbox).
