:- module(rtl_sandbox,
          [ rtl_check_goal/3,           % +Policy, +Module, :Goal
            rtl_check_rule/4,           % +Module, +Id, +Stores, +Clauses
            rtl_unsafe_message/2        % +Error, -Message
          ]).

/** <module> Untrusted goals: what code from outside the program file may run

The program file is trusted: its author may call anything. Everything that reaches the
engine at run time from elsewhere (rules added while events flow, queries, subscription
and memory conditions, from Python, a control line or a service) is checked here before
anything of it is installed or run: every goal that could run must be safe.

The check walks the goal as SWI-Prolog's library(sandbox) does, with two differences:

  - The program's own predicates (and those of module `user`) are checked by walking their
    clauses with the same rules, so a condition that calls a program predicate that calls
    shell/1 is refused, and so is one that reaches a predicate changing the program's
    database (the triggers, stores or facts of the program): untrusted code is read-only
    towards the program. A query may assert into its own temporary module; an added rule
    may change only its own partial-match stores.
  - Predicates of the runtime (`prolog_runtime/`) are refused unless declared safe below
    (builtin/3): pure helpers (rtl_math, min/max, rtl_aggregate, the SLR queries) anywhere;
    the effects of a rule (rtl_derived/3, new_event/1-3, c_mem/4, sub/5, ...) only in an
    added rule.

Every other goal (system and library predicates) must pass library(sandbox)'s safe_goal/1:
no files, processes, streams other than the current output, halt or global flags. Module
qualified database changes (`M:retractall(G)`), which safe_goal/1 lets through, and
set_prolog_flag/2 are refused here.

A refusal throws `error(rtl_unsafe(Culprit, Reason, Path), _)`: Culprit is the predicate indicator
of the unsafe goal, Path the program predicates through which it was reached. Its message
(print_message/2, rtl_unsafe_message/2) reads `unsafe goal: shell/1 (reached from
nearby/2)`.
*/

:- use_module(library(assoc)).
:- use_module(library(apply)).
:- use_module(library(lists)).
:- use_module(rtl_ele).
:- use_module(rtl_slr).

%   Stand-ins for the goal arguments of a library meta-predicate: the arguments are checked
%   by the walk, the meta-predicate itself by safe_goal/1 with these in their place.
'$rtl_checked'.
'$rtl_checked'(_).
'$rtl_checked'(_, _).
'$rtl_checked'(_, _, _).
'$rtl_checked'(_, _, _, _).
'$rtl_checked'(_, _, _, _, _).
'$rtl_checked'(_, _, _, _, _, _).
'$rtl_checked'(_, _, _, _, _, _, _).
'$rtl_checked'(_, _, _, _, _, _, _, _).

% ---- the SLR queries may be called by any code, queries included -------------------------

:- multifile sandbox:safe_primitive/1.

sandbox:safe_primitive(rtl_slr:mem(_, _)).
sandbox:safe_primitive(rtl_slr:access_mem(_, _, _)).
sandbox:safe_primitive(rtl_slr:prev(_, _)).
sandbox:safe_primitive(rtl_slr:prev(_, _, _)).
sandbox:safe_primitive(rtl_slr:prev(_, _, _, _, _)).
sandbox:safe_primitive(rtl_slr:next(_, _)).
sandbox:safe_primitive(rtl_slr:next(_, _, _)).
sandbox:safe_primitive(rtl_slr:next(_, _, _, _)).
sandbox:safe_primitive(rtl_slr:next(_, _, _, _, _, _)).
sandbox:safe_primitive(rtl_slr:next_inf(_, _, _, _, _)).
sandbox:safe_primitive(rtl_slr:exist_mem(_)).
sandbox:safe_primitive(rtl_slr:rtl_memory_size(_, _)).
sandbox:safe_primitive(rtl_ele:rtl_clock(_)).
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked').
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked'(_)).
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked'(_, _)).
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked'(_, _, _)).
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked'(_, _, _, _)).
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked'(_, _, _, _, _)).
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked'(_, _, _, _, _, _)).
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked'(_, _, _, _, _, _, _)).
sandbox:safe_primitive(rtl_sandbox:'$rtl_checked'(_, _, _, _, _, _, _, _)).

% ---- the runtime's builtins ---------------------------------------------------------------

%   builtin(?Where, ?Module:Goal, -Called) is nondet.
%
%   A runtime predicate untrusted code may call: anywhere (Where `any`: pure helpers and
%   read-only inspection of the runtime's state) or only in an added rule (`rule`: the
%   effects of a rule). Called are the goals it runs, checked in turn.

builtin(any,  retalis:rtl_action(G), [G]).
builtin(any,  retalis:rtl_aggregate(_, _, _, _), []).
builtin(any,  retalis:rtl_aggregate_initial(_, _), []).
builtin(any,  rtl_library:min(_, _, _), []).
builtin(any,  rtl_library:max(_, _, _), []).
builtin(any,  rtl_library:datime_minus_datime(_, _, _), []).
builtin(any,  rtl_time:rtl_time_seconds(_, _), []).
builtin(any,  rtl_time:rtl_interval_seconds(_, _, _), []).
builtin(any,  rtl_ele:rtl_flag(_, _), []).
builtin(any,  rtl_ele:rtl_stat(_, _), []).
builtin(any,  rtl_ele:rtl_store_size(_), []).
builtin(any,  rtl_ele:rtl_started_after(_), []).          % (`seq` steps; reads a number)
builtin(any,  rtl_slr:rtl_memory(_, _, _, _, _), []).
builtin(any,  rtl_slr:rtl_memory_records(_, _), []).
builtin(any,  rtl_slr:rtl_memory_last_end(_, _), []).
builtin(any,  rtl_slr:rtl_memory_type(_, _), []).
builtin(any,  rtl_sync:rtl_sync_pending(_), []).
builtin(any,  rtl_sync:rtl_type_delay(_, _), []).
builtin(any,  rtl_sync:rtl_history_complete(_, _), []).
builtin(any,  rtl_sync:rtl_up_to_date(_), []).
builtin(any,  rtl_sync:rtl_input_ended, []).
builtin(any,  rtl_sync:rtl_goal_set(_, _, _), []).
builtin(any,  rtl_tf:tf_lookup(_, _, _, _), []).                 % the tf library: read-only
builtin(any,  rtl_tf:tf_lookup(_, _, _, _, _, _), []).
builtin(any,  rtl_tf:tf_can_transform(_, _, _), []).
builtin(any,  rtl_tf:tf_buffer(_), []).
builtin(any,  rtl_tf:tf_frames(_), []).
builtin(any,  rtl_tf:tf_parent(_, _, _), []).
builtin(any,  rtl_tf:tf_links(_), []).
builtin(any,  rtl_tf:tf_records(_), []).
builtin(any,  rtl_tf:tf_waiting(_), []).
builtin(rule, rtl_tf:tf_wait(_, _, _, _, Goal), [Goal]).
builtin(any,  rtl_math:G, []) :-
    (   var(G) -> true ; predicate_property(rtl_math:G, exported) ).
builtin(rule, rtl_ele:rtl_derived(_, _, _), []).
builtin(rule, rtl_ele:rtl_detected(_), []).
builtin(rule, rtl_horizon:rtl_late(_), []).                % deletions and late events
builtin(rule, rtl_horizon:rtl_kept_generation(_), []).
builtin(rule, rtl_horizon:rtl_next_seq(_), []).
builtin(rule, rtl_ele:rtl_blockers_due(_, _, _, _), []).         % a negation's sweep
builtin(rule, rtl_horizon:rtl_take_instance(Stored, _), [retract(Stored)]).   % from the rule's store
builtin(rule, rtl_horizon:rtl_aggregate_values(_, _, _), []).
builtin(rule, rtl_horizon:rtl_aggregate_redo(_, _, _, _, _), []).
builtin(rule, rtl_horizon:rtl_aggregate_redo_numbered(_, _, _, _, _), []).
builtin(rule, rtl_policy:rtl_position(_, _), []).                      % consumption policies
builtin(rule, rtl_policy:rtl_policy_insert(_, _, _, Goal), [Goal]).
builtin(rule, rtl_policy:rtl_policy_made(A, B, _, _, Goal), [assertz(A), assertz(B), Goal]).
builtin(rule, rtl_policy:rtl_policy_unmade(A, B, _, _, Goal), [retract(A), retract(B), Goal]).
builtin(rule, rtl_policy:rtl_policy_arrival(_), []).
builtin(rule, rtl_policy:rtl_policy_take_arrival(Stores, _), Retracts) :-
    (   is_list(Stores) -> findall(retract(S), member(S, Stores), Retracts) ; Retracts = [retract(Stores)] ).
builtin(rule, rtl_policy:rtl_policy_restoring(Goal), [Goal]).
builtin(rule, rtl_policy:rtl_policy_delete(_, _, _, Stored), [retract(Stored)]).
builtin(rule, rtl_policy:rtl_policy_drop_twins(_, Stored), [retract(Stored)]).
builtin(rule, rtl_policy:rtl_policy_take(_, Stored, _), [retract(Stored)]).
builtin(rule, rtl_ele:rtl_underived(_, _, _), []).
builtin(rule, rtl_timers:rtl_timer_add(_, _, Goal), [Goal]).   % absences and alarms
builtin(rule, rtl_timers:rtl_absence_wait(_, Goal), [Goal]).
builtin(rule, rtl_timers:rtl_timer_cancel(_), []).
builtin(rule, rtl_sliding:rtl_sliding_refresh(_, _, _, _, A, B, C, D), Called) :-   % sliding aggregates
    maplist(closure_goal(2), [A, B, C, D], Called).
builtin(rule, rtl_sliding:rtl_sliding_refresh_numbered(_, _, _, _, _, A, B, C, D, E), Called) :-
    maplist(closure_goal, [3, 3, 2, 3, 2], [A, B, C, D, E], Called).
builtin(rule, rtl_policy:rtl_policy_at(_, Goal), [Goal]).
builtin(rule, rtl_sync:rtl_synchronized(_, Q, _, _, _), [Q]).
builtin(rule, rtl_sync:rtl_synchronized_retract(_, Q, _, _, _), [Q]).
builtin(rule, rtl_raise:new_event(_), []).
builtin(rule, rtl_raise:new_event(_, _), []).
builtin(rule, rtl_raise:new_event(_, _, _), []).
builtin(rule, rtl_slr:c_mem(_, Query, _, _), Conds) :- query_conditions(Query, Conds).
builtin(rule, rtl_slr:c_mem(_, Query, _, _, _), Conds) :- query_conditions(Query, Conds).
builtin(rule, rtl_slr:memorize(_, Conds, _, _, _), Called) :- condition_list(Conds, Called).
builtin(rule, rtl_slr:d_mem(_), []).
builtin(rule, rtl_slr:delete_memory(_), []).
builtin(rule, rtl_subscriptions:subscribe(_, Conds, _, _, _), Called) :- condition_list(Conds, Called).
builtin(rule, rtl_subscriptions:sub(_, _, Query, _, _), Conds) :- query_conditions(Query, Conds).
builtin(rule, rtl_subscriptions:subscribe_between(_, Query, _, _, _), Conds) :- query_conditions(Query, Conds).
builtin(rule, rtl_subscriptions:unsub(_, _), []).
builtin(rule, rtl_subscriptions:delete_subscription(_, _), []).

% `Event-Conds` or a bare event: the conditions must be known when the rule is checked (a
% query only known at run time is refused, as a goal only known then).
query_conditions(Query, Called) :-
    (   var(Query)
    ->  Called = [Query]
    ;   Query = _-Conds
    ->  condition_list(Conds, Called)
    ;   Called = []
    ).

condition_list(Conds, Called) :-
    (   is_list(Conds) -> Called = Conds ; Called = [Conds] ).

% ---- entry points -------------------------------------------------------------------------

% library(sandbox) is loaded by the first check, not with the runtime: most programs never
% check a goal, and loading it is a third of the runtime's start-up. (The clauses of
% sandbox:safe_primitive/1 above are multifile: they stay when it loads.)
sandbox_loaded :-
    (   current_predicate(sandbox:safe_meta_call/3)
    ->  true
    ;   use_module(library(sandbox), [])
    ).

%!  rtl_check_goal(+Policy, +Module, :Goal) is det.
%
%   Throw rtl_unsafe/3 unless Goal, run in Module, is safe. Policy is `query(Writable)`:
%   database changes are allowed in the modules of the list Writable only (a query's
%   temporary module; `[]` for conditions of subscriptions and memories).

rtl_check_goal(Policy, Module, Goal) :-
    sandbox_loaded,
    Policy = query(Writable),
    must_be(list(atom), Writable),
    copy_term(Goal, Copy),
    empty_assoc(V0),
    walk(Copy, Module, st(Policy, []), V0, _).

%!  rtl_check_rule(+Module, +Id, +Stores, +Clauses) is det.
%
%   Throw rtl_unsafe/3 unless the clauses of the compiled rule Id (rtl_rules.pl) may be
%   added to Module: every head is a trigger (`ele_trigger/3`, `ele_untrigger/3`), a sweep
%   (`ele_forget_blockers/1`, negations without a window) or one of
%   the rule's own predicates (`e_<Id>_<N>...`), every store (`store(Name, Arity, Window)`
%   in Stores) is one of the rule's own predicates, and every body is safe, changing only
%   the rule's stores.

rtl_check_rule(M, Id, Stores, Clauses0) :-
    sandbox_loaded,
    (   atom(Id) -> true ; throw(error(rtl_unsafe(Id, rule_id, []), _)) ),
    forall(member(Store, Stores),
           (   own_store(Id, Store)
           ->  true
           ;   throw(error(rtl_unsafe(Store, store, []), _))
           )),
    copy_term(Clauses0, Clauses),
    findall(N/A, ( member(C, Clauses), clause_head(C, H), callable(H),
                   functor(H, N, A), rtl_rules:rule_pred_name(Id, N)
                 ; member(S, Stores), store_pred(S, N/A) ), Local0),
    sort(Local0, Local),
    findall(pred(M, PI), ( member(S, Stores), store_pred(S, PI) ), Writable),
    Policy = rule(Id, Writable, Local),
    empty_assoc(V0),
    foldl(check_clause(M, Policy), Clauses, V0, _).

% A store of rule Id: its partial matches (`store/3`), or what is kept of them for deletions
% (`record/4`, `kept/5`, rtl_horizon.pl); every name is one of the rule's own predicates.
own_store(Id, store(N, A, W)) :-
    own_names(Id, [N], A),
    ( W == none ; number(W), W >= 0 ).
own_store(Id, record(N, A, KA, KB)) :-
    own_names(Id, [N, KA, KB], A).
own_store(Id, kept(Live, A, KA, KB, Order)) :-
    own_names(Id, [Live, KA, KB], A),
    atom(Order).

own_names(Id, Names, Arity) :-
    integer(Arity),
    forall(member(N, Names), ( atom(N), rtl_rules:rule_pred_name(Id, N) )).

store_pred(store(N, A, _), N/A).
store_pred(record(N, A, _, _), N/A).
store_pred(record(_, A, KA, _), KA/A).
store_pred(record(_, A, _, KB), KB/A).
store_pred(kept(Live, A, _, _, _), Live/A).
store_pred(kept(_, A, KA, _, _), KA/A).
store_pred(kept(_, A, _, KB, _), KB/A).

check_clause(M, Policy, Clause, V0, V) :-
    (   Clause = (:- Directive)
    ->  goal_pi(Directive, PI),
        throw(error(rtl_unsafe(PI, directive, []), _))
    ;   true
    ),
    clause_head(Clause, Head),
    Policy = rule(Id, _, _),
    check_head(Head, Id),
    (   Clause = (_ :- Body) -> true ; Body = true ),
    walk(Body, M, st(Policy, [rule(Id)]), V0, V).

clause_head((Head :- _), Head) :- !.
clause_head(Head, Head).

check_head(Head, _) :-
    var(Head), !,
    throw(error(rtl_unsafe(variable, head, []), _)).
check_head(Head, _) :-
    \+ callable(Head), !,
    throw(error(rtl_unsafe(Head, head, []), _)).
check_head(ele_trigger(_, _, _), _) :- !.
check_head(ele_untrigger(_, _, _), _) :- !.
check_head(ele_forget_blockers(_), _) :- !.        % a negation's sweep: its body is checked like any
check_head(Head, Id) :-
    functor(Head, Name, _),
    rtl_rules:rule_pred_name(Id, Name), !.
check_head(Head, _) :-
    goal_pi(Head, PI),
    throw(error(rtl_unsafe(PI, head, []), _)).

% ---- the walk -----------------------------------------------------------------------------

%   walk(+Goal, +Module, +State, +Visited0, -Visited)
%
%   State is st(Policy, Path), Path the predicates through which Goal was reached, innermost
%   first. Visited holds the predicates whose clauses were checked (most general form), or
%   specific goals (when the general form needs more instantiation).

walk(G, _, S, _, _) :-
    var(G), !,
    refuse(S, call/1, instantiation).
walk(Q:G, M, S, V0, V) :- !,
    (   atom(Q) -> true ; refuse(S, (:)/2, instantiation) ),
    (   current_module(Q) -> true ; refuse(S, Q:G, unknown_module) ),
    (   Q == M -> true ; cross_module_call(Q, G, S) ),
    walk(G, Q, S, V0, V).

walk(G, _, S, _, _) :-
    \+ callable(G), !,
    refuse(S, G, not_callable).
walk(G, M, S, V0, V) :-
    db_change(G), !,
    arg(1, G, Clause),
    check_db(Clause, M, G, S),
    V = V0.
walk(G, _, S, _, _) :-
    forbidden(G), !,
    refuse(S, G, not_allowed).
walk(G, M, _, V, V) :-
    output(G),
    predicate_property(M:G, implementation_module(system)), !.
walk(G, M, S, V0, V) :-
    meta_called(G, M, S, Called), !,
    walk_list(Called, M, S, V0, V).
walk(G, M, S, V0, V) :-
    S = st(Policy, _),
    local_pred(Policy, M, G), !,
    V = V0.
walk(G, M, S, V0, V) :-
    defined_in(G, M, S, IM),
    (   runtime_module(IM)
    ->  runtime_goal(IM, G, M, S, V0, V)
    ;   user_code(IM)
    ->  walk_pred(G, IM, S, V0, V)
    ;   library_goal(G, M, S, V0, V)
    ).

walk_list([], _, _, V, V).
walk_list([G|Gs], M, S, V0, V) :-
    (   nonvar(G), G = M2:G2, M2 == M       % in our context
    ->  walk(G2, M, S, V0, V1)
    ;   walk(G, M, S, V0, V1)
    ),
    walk_list(Gs, M, S, V1, V).

%   As library(sandbox): a qualified call into a library module may only call what it
%   exports (its other predicates may rely on being called by its own code only).
cross_module_call(Q, G, S) :-
    (   var(G)
    ->  true                                    % refused by the walk
    ;   user_code(Q)
    ->  true
    ;   runtime_module(Q)
    ->  true                                    % builtin/3 decides
    ;   (   predicate_property(Q:G, exported)
        ;   predicate_property(Q:G, public)
        ;   predicate_property(Q:G, multifile)
        ;   predicate_property(system:G, iso)
        ;   db_change(G)                         % checked by check_db/4
        )
    ->  true
    ;   goal_pi(Q:G, PI),
        refuse(S, PI, not_exported)
    ).

%   Goals whose called goals library(sandbox) knows: control constructs, findall/3, call/N,
%   catch/3, format/2 with ~@, with_output_to/2, phrase/2,3, ...
meta_called(G, M, S, Called) :-
    (   predicate_property(system:G, iso)
    ->  Meta = G
    ;   predicate_property(M:G, implementation_module(IM)),
        Meta = IM:G
    ),
    catch(sandbox:safe_meta_call(Meta, M, Called0), E, refuse_error(S, G, E)),
    !,
    Called = Called0.

db_change(assert(_)).
db_change(asserta(_)).
db_change(assertz(_)).
db_change(asserta(_, _)).
db_change(assertz(_, _)).
db_change(retract(_)).
db_change(retractall(_)).

%   Writing to the current output (actions such as `do write(X)`; library(sandbox) only
%   allows format/2 and writeln/1).
output(write(_)).
output(writeq(_)).
output(print(_)).
output(write_canonical(_)).
output(nl).
output(tab(_)).

forbidden(set_prolog_flag(_, _)).
forbidden(create_prolog_flag(_, _, _)).
forbidden(erase(_)).
forbidden(abolish(_)).
forbidden(abolish(_, _)).
forbidden(abort).
forbidden(flag(_, _, _)).
forbidden(abolish_all_tables).
forbidden(set_prolog_stack(_, _)).

check_db(Clause, M, G, S) :-
    strip_module(M:Clause, TM, C),
    (   var(C)
    ->  refuse(S, G, instantiation)
    ;   C = (_ :- _)
    ->  refuse(S, G, database_rule)
    ;   callable(C)
    ->  functor(C, N, A),
        S = st(Policy, _),
        (   writable(Policy, TM, N/A)
        ->  true
        ;   goal_pi(G, GPI),
            refuse(S, GPI, database(TM:N/A))
        )
    ;   refuse(S, G, not_callable)
    ).

writable(query(Modules), TM, _) :-
    memberchk(TM, Modules).
writable(rule(_, Writable, _), TM, PI) :-
    memberchk(pred(TM, PI), Writable).

local_pred(rule(_, _, Local), _, G) :-
    functor(G, N, A),
    memberchk(N/A, Local).

%   The module that defines G as called from M (autoloading it if need be).
defined_in(G, M, S, IM) :-
    (   predicate_property(M:G, defined)
    ->  true
    ;   catch('$define_predicate'(M:G), _, fail),
        predicate_property(M:G, defined)
    ->  true
    ;   goal_pi(G, PI),
        refuse(S, PI, unknown)
    ),
    predicate_property(M:G, implementation_module(IM)).

% The goal call/N runs for Closure and N more arguments (a variable stays a variable).
closure_goal(_, Closure, Closure) :-
    var(Closure), !.
closure_goal(N, Closure, Goal) :-
    length(Extra, N),
    Closure =.. List0,
    append(List0, Extra, List),
    Goal =.. List.

runtime_module(retalisc_bridge).
runtime_module(M) :-
    atom(M),
    module_property(M, file(File)),
    file_directory_name(File, Dir),
    module_property(rtl_sandbox, file(Own)),
    file_directory_name(Own, Dir).

user_code(M) :-
    module_property(M, class(Class)),
    memberchk(Class, [user, temporary]).

runtime_goal(IM, G, M, S, V0, V) :-
    S = st(Policy, _),
    (   builtin(Where, IM:G, Called),
        ( Where == any ; Policy = rule(_, _, _) )
    ->  own_step(IM:G, S),
        walk_list(Called, M, S, V0, V)
    ;   catch(sandbox:safe_primitive(IM:G), _, fail)
    ->  V = V0
    ;   goal_pi(G, PI),
        refuse(S, PI, runtime)
    ).

%   The policy runtime (rtl_policy.pl) rewinds the step it is given, retracting that step's
%   matches: an added rule may name only its own steps.
own_step(rtl_policy:G, S) :-
    policy_step(G, Step), !,
    S = st(rule(Id, _, _), Path),
    (   atom(Step), rtl_rules:rule_pred_name(Id, Step)
    ->  true
    ;   throw(error(rtl_unsafe(Step, not_own_step, Path), _))
    ).
own_step(_, _).

policy_step(rtl_policy_insert(Step, _, _, _), Step).
policy_step(rtl_policy_delete(Step, _, _, _), Step).
policy_step(rtl_policy_drop_twins(Step, _), Step).
policy_step(rtl_policy_take(Step, _, _), Step).

%   A predicate of the program (or of `user`): check its clauses, for the most general call
%   first; if that needs more instantiation (a clause calls an argument), for this call.
walk_pred(G, IM, S, V0, V) :-
    functor(G, N, A),
    (   get_assoc(IM:N/A, V0, _)
    ->  V = V0
    ;   predicate_property(IM:G, foreign)
    ->  refuse(S, N/A, not_allowed)
    ;   predicate_property(IM:G, number_of_rules(0))
    ->  V = V0                                    % facts only
    ;   put_assoc(IM:N/A, V0, general, V1),
        functor(Gen, N, A),
        catch(walk_clauses(Gen, IM, S, V1, V2), error(rtl_unsafe(_, instantiation, _), _), fail)
    ->  V = V2
    ;   walk_specific(G, IM, S, V0, V)
    ).

walk_specific(G, IM, S, V0, V) :-
    copy_term(G, Key0),
    numbervars(Key0, 0, _),
    Key = IM:Key0,
    S = st(_, Path),
    functor(G, N, A),
    (   get_assoc(Key, V0, _)
    ->  V = V0
    ;   length(Path, Depth), Depth > 64
    ->  refuse(S, N/A, too_deep)
    ;   put_assoc(Key, V0, specific, V1),
        walk_clauses(G, IM, S, V1, V)
    ).

walk_clauses(G, IM, st(Policy, Path), V0, V) :-
    functor(G, N, A),
    findall(G-Body, ( clause(IM:G, Body), Body \== true ), Clauses),
    foldl(walk_clause(IM, st(Policy, [N/A|Path])), Clauses, V0, V).

walk_clause(IM, S, _-Body, V0, V) :-
    walk(Body, IM, S, V0, V).

%   A system or library predicate: library(sandbox) decides. The goal arguments of a
%   meta-predicate are walked here (they may be program predicates), and the predicate
%   itself checked with stand-ins for them.
library_goal(G, M, S, V0, V) :-
    (   predicate_property(M:G, meta_predicate(Spec)),
        calls_goals(Spec)
    ->  G =.. [Name|Args],
        Spec =.. [_|Specs],
        meta_args(Specs, Args, Called, Neutral),
        walk_list(Called, M, S, V0, V),
        Checked =.. [Name|Neutral]
    ;   V = V0,
        Checked = G
    ),
    catch(sandbox:safe_goal(M:Checked), E, refuse_error(S, G, E)).

calls_goals(Spec) :-
    sub_term(X, Spec), nonvar(X), calling_spec(X), !.

calling_spec(I) :- integer(I).
calling_spec(^).
calling_spec(//).

meta_args([], [], [], []).
meta_args([Spec|Specs], [Arg|Args], Called, [N|Ns]) :-
    (   calling_spec(Spec)
    ->  catch(sandbox:extend(Spec, Arg, Goal), _, Goal = _),
        Called = [Goal|Called1],
        stand_in(Spec, N)
    ;   Called = Called1,
        N = Arg
    ),
    meta_args(Specs, Args, Called1, Ns).

stand_in(//, []) :- !.
stand_in(_, rtl_sandbox:'$rtl_checked').

% ---- refusals -----------------------------------------------------------------------------

refuse(st(_, Path), Culprit0, Reason) :-
    (   callable(Culprit0), Culprit0 \= _/_, Culprit0 \= _:_/_
    ->  goal_pi(Culprit0, Culprit)
    ;   Culprit = Culprit0
    ),
    throw(error(rtl_unsafe(Culprit, Reason, Path), _)).

refuse_error(S, G, E) :-
    (   E = error(rtl_unsafe(_, _, _), _)
    ->  throw(E)
    ;   E = error(permission_error(call, sandboxed, Inner), _)
    ->  goal_pi(Inner, InnerPI),
        goal_pi(G, PI),
        (   PI = N/_, InnerPI = N/_ -> Reason = not_allowed ; Reason = calls(InnerPI) ),
        refuse(S, PI, Reason)
    ;   E = error(existence_error(procedure, PI), _)
    ->  refuse(S, PI, unknown)
    ;   E = error(instantiation_error, _)
    ->  refuse(S, G, instantiation)
    ;   refuse(S, G, error(E))
    ).

goal_pi(G, PI) :-
    (   var(G)
    ->  PI = G
    ;   G = M:G1, atom(M)
    ->  goal_pi(G1, PI1),
        (   sub_atom(M, 0, _, _, rtl_), PI1 = _/_ -> PI = PI1 ; PI = M:PI1 )
    ;   callable(G)
    ->  functor(G, N, A), PI = N/A
    ;   PI = G
    ).

%!  rtl_unsafe_message(+Error, -Message:string) is semidet.
%
%   The one-line message of a refusal, `error(rtl_unsafe(Culprit, Reason, Path), _)`.

rtl_unsafe_message(error(Unsafe, _), Message) :- !,
    rtl_unsafe_message(Unsafe, Message).
rtl_unsafe_message(rtl_unsafe(Culprit, Reason, Path), Message) :-
    reason_text(Reason, Culprit, Text),
    (   Path == []
    ->  format(string(Message), "~w", [Text])
    ;   reverse(Path, Chain),
        atomic_list_concat_pis(Chain, ChainText),
        format(string(Message), "~w (reached from ~w)", [Text, ChainText])
    ).

atomic_list_concat_pis(PIs, Text) :-
    maplist(pi_text, PIs, Ts),
    atomic_list_concat(Ts, ' -> ', Text).

pi_text(rule(Id), T) :- !,
    format(string(T), "rule ~q", [Id]).
pi_text(PI, T) :-
    format(string(T), "~q", [PI]).

reason_text(not_allowed, C, T) :-
    format(string(T), "unsafe goal: ~q", [C]).
reason_text(calls(Inner), C, T) :-
    format(string(T), "unsafe goal: ~q (it calls ~q)", [C, Inner]).
reason_text(instantiation, C, T) :-
    format(string(T), "unsafe goal: ~q with a goal that is only known when it runs", [C]).
reason_text(database(Target), C, T) :-
    format(string(T), "unsafe goal: ~q changes ~q, which untrusted code may not change", [C, Target]).
reason_text(database_rule, C, T) :-
    format(string(T), "unsafe goal: ~q of a clause with a body", [C]).
reason_text(unknown, C, T) :-
    format(string(T), "unsafe goal: ~q is not defined", [C]).
reason_text(not_exported, C, T) :-
    format(string(T), "unsafe goal: ~q (not exported by its module)", [C]).
reason_text(unknown_module, C, T) :-
    format(string(T), "unsafe goal: ~q names a module that does not exist", [C]).
reason_text(not_callable, C, T) :-
    format(string(T), "unsafe goal: ~q is not a goal", [C]).
reason_text(runtime, C, T) :-
    format(string(T), "unsafe goal: ~q (a runtime predicate not available here)", [C]).
reason_text(too_deep, C, T) :-
    format(string(T), "unsafe goal: ~q (too deep to check)", [C]).
reason_text(head, C, T) :-
    format(string(T), "unsafe clause: an added rule may only define its triggers and its own predicates, not ~q", [C]).
reason_text(not_own_step, C, T) :-
    format(string(T), "unsafe goal: the step ~q is not one of the added rule's own", [C]).
reason_text(rule_id, C, T) :-
    format(string(T), "unsafe rule: its id ~q is not an atom", [C]).
reason_text(store, C, T) :-
    format(string(T), "unsafe rule: ~q is not a store of the rule's own", [C]).
reason_text(directive, C, T) :-
    format(string(T), "unsafe goal: ~q (a directive in an added rule)", [C]).
reason_text(error(E), C, T) :-
    (   catch(message_to_codes(E, Codes), _, fail)
    ->  format(string(T), "unsafe goal: ~q (~s)", [C, Codes])
    ;   format(string(T), "unsafe goal: ~q (~q)", [C, E])
    ).

message_to_codes(E, Codes) :-
    '$messages':translate_message(E, Lines, []),
    with_output_to(codes(Codes0), print_message_lines(current_output, '', Lines)),
    string_codes(S0, Codes0),
    split_string(S0, "\n", " \t", Parts0),
    exclude(==(""), Parts0, Parts),
    atomic_list_concat(Parts, ' ', A),
    atom_codes(A, Codes).

:- multifile prolog:error_message//1.

prolog:error_message(rtl_unsafe(Culprit, Reason, Path)) -->
    { rtl_unsafe_message(rtl_unsafe(Culprit, Reason, Path), Message) },
    [ '~s'-[Message] ].
