:- module(rtl_sandbox,
          [ rtl_check_goal/4,           % +Policy, +Module, :Goal, -Guarded
            rtl_check_rule/5,           % +Module, +Id, +Stores, +Clauses, -Guarded
            rtl_unsafe_message/2,       % +Error, -Message
            rtl_replace_goals/4,        % +Called, +Guarded, +Term0, -Term
            rtl_rule_pred_name/2,       % +Id, +Name
            rtl_store_pred/2            % +Store, -Name/Arity
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

Every other goal is a system or library predicate, and denied by default: allowed/1 lists
those untrusted code may call (pure predicates, all-solutions and control, output to the
current output or a string), and each must pass library(sandbox)'s safe_goal/1 as well, a
second check. Not listed, so refused: message printing (it interprets its term), attributed
variables (their hooks run goals), blocking builtins (sleep, reads, waits, threads), cleanup
handlers, files, processes, flags, global variables, the program's clauses. Module qualified
database changes (`M:retractall(G)`), which safe_goal/1 lets through, are checked here.

What can only be judged when it runs is guarded (rtl_guard.pl): the walk gives back the
goal to run, in which throw/1 of a ball that could be reserved, catch/3 with a catcher that
could catch a reserved ball and format/1,2,3 with a format string given by data are
replaced by their guards. The clauses of program predicates are not rewritten: there such a
goal is refused (unless the call at hand decides it). `format` directives that call goals or
take write options (`~@`, `~W`, `~p`) are refused when the format string is known.

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
:- use_module(rtl_guard).
:- use_module(rtl_error_text).

%   Stand-ins for the goal arguments of a library meta-predicate: the arguments are checked
%   by the walk, the meta-predicate itself by safe_goal/1 with these in their place (the
%   second check).
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
builtin(any,  rtl_horizon:rtl_aggregate(_, _, _, _), []).
builtin(any,  rtl_horizon:rtl_aggregate_initial(_, _), []).
builtin(any,  rtl_guard:rtl_catch(G, _, R), [G, R]).    % guarded forms (a goal kept in a snapshot)
builtin(any,  rtl_guard:rtl_throw(_), []).
builtin(any,  rtl_guard:rtl_format(_), []).
builtin(any,  rtl_guard:rtl_format(_, _), []).
builtin(any,  rtl_guard:rtl_format(_, _, _), []).          % (checks its sink when it runs)
builtin(any,  rtl_library:min(_, _, _), []).
builtin(any,  rtl_library:max(_, _, _), []).
builtin(any,  rtl_library:datime_minus_datime(_, _, _), []).
builtin(any,  rtl_library:is_datime(_), []).
builtin(any,  rtl_library:less_datime(_, _), []).
builtin(any,  rtl_library:equal_datime(_, _), []).
builtin(any,  rtl_library:between_datime(_, _, _), []).
builtin(any,  rtl_library:datime_plus_sec(_, _, _), []).
builtin(any,  rtl_library:datime_minus_sec(_, _, _), []).
builtin(any,  rtl_time:rtl_time_seconds(_, _), []).
builtin(any,  rtl_time:rtl_interval_seconds(_, _, _), []).
builtin(any,  rtl_flags:rtl_flag(_, _), []).
builtin(any,  rtl_flags:rtl_stat(_, _), []).
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
builtin(any,  rtl_tf:tf_road(_), []).
builtin(any,  rtl_tf:tf_bytes(_), []).
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

%!  rtl_check_goal(+Policy, +Module, +Goal, -Guarded) is det.
%
%   Throw rtl_unsafe/3 unless Goal, run in Module, is safe; Guarded is the goal to run
%   instead of Goal: Goal with the goals that can only be judged when they run (throw/1,
%   catch/3, format/1,2,3 with a format string given by data) replaced by their guards
%   (rtl_guard.pl). Policy is `query(Writable)`: database changes are allowed in the modules
%   of the list Writable only (a query's temporary module; `[]` for conditions of
%   subscriptions and memories).

rtl_check_goal(Policy, Module, Goal, Guarded) :-
    sandbox_loaded,
    Policy = query(Writable),
    must_be(list(atom), Writable),
    empty_assoc(V0),
    walk(Goal, Module, st(Policy, [], guard), Guarded, V0, _).

%!  rtl_check_rule(+Module, +Id, +Stores, +Clauses, -Guarded) is det.
%
%   Throw rtl_unsafe/3 unless the clauses of the compiled rule Id (rtl_rules.pl) may be
%   added to Module: every head is a trigger (`ele_trigger/3`, `ele_untrigger/3`), a sweep
%   (`ele_forget_blockers/1`, negations without a window) or one of
%   the rule's own predicates (`e_<Id>_<N>...`), every store (`store(Name, Arity, Window)`
%   in Stores) is one of the rule's own predicates, and every body is safe, changing only
%   the rule's stores. Guarded are the clauses to add: Clauses with the guards of
%   rtl_check_goal/4.

rtl_check_rule(M, Id, Stores, Clauses, Guarded) :-
    sandbox_loaded,
    (   atom(Id) -> true ; throw(error(rtl_unsafe(Id, rule_id, []), _)) ),
    forall(member(Store, Stores),
           (   own_store(Id, Store)
           ->  true
           ;   throw(error(rtl_unsafe(Store, store, []), _))
           )),
    findall(N/A, ( member(C, Clauses), clause_head(C, H), callable(H),
                   functor(H, N, A), rtl_rule_pred_name(Id, N)
                 ; member(S, Stores), store_pred(S, N/A) ), Local0),
    sort(Local0, Local),
    findall(pred(M, PI), ( member(S, Stores), store_pred(S, PI) ), Writable),
    Policy = rule(Id, Writable, Local),
    empty_assoc(V0),
    foldl(check_clause(M, Policy), Clauses, Guarded, V0, _).

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
    forall(member(N, Names), ( atom(N), rtl_rule_pred_name(Id, N) )).

%!  rtl_store_pred(+Store, -PI) is nondet.
%
%   The predicates of a rule's store declaration (rtl_rules.pl).

rtl_store_pred(Store, PI) :-
    store_pred(Store, PI).

store_pred(store(N, A, _), N/A).
store_pred(record(N, A, _, _), N/A).
store_pred(record(_, A, KA, _), KA/A).
store_pred(record(_, A, _, KB), KB/A).
store_pred(kept(Live, A, _, _, _), Live/A).
store_pred(kept(_, A, KA, _, _), KA/A).
store_pred(kept(_, A, _, KB, _), KB/A).

check_clause(M, Policy, Clause, Guarded, V0, V) :-
    (   Clause = (:- Directive)
    ->  goal_pi(Directive, PI),
        throw(error(rtl_unsafe(PI, directive, []), _))
    ;   true
    ),
    clause_head(Clause, Head),
    Policy = rule(Id, _, _),
    check_head(Head, Id),
    (   Clause = (_ :- Body)
    ->  walk(Body, M, st(Policy, [rule(Id)], guard), Body1, V0, V),
        Guarded = (Head :- Body1)
    ;   Guarded = Clause,
        V = V0
    ).

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
    rtl_rule_pred_name(Id, Name), !.
check_head(Head, _) :-
    goal_pi(Head, PI),
    throw(error(rtl_unsafe(PI, head, []), _)).

% ---- the walk -----------------------------------------------------------------------------

%   walk(+Goal, +Module, +State, -Guarded, +Visited0, -Visited)
%
%   State is st(Policy, Path, Mode), Path the predicates through which Goal was reached,
%   innermost first; Mode `guard` where Goal may be rewritten into Guarded (the untrusted
%   goal itself, an added rule's clauses), `strict` where it may not (the clauses of a
%   program predicate, a closure: Guarded is Goal there, and a goal that would need a guard
%   is refused). Visited holds the predicates whose clauses were checked (most general form),
%   or specific goals (when the general form needs more instantiation).
%
%   Deny by default: a system or library predicate is allowed when allowed/1 lists it (and
%   library(sandbox)'s safe_goal/1 agrees), a runtime predicate when builtin/3 declares it,
%   a program predicate when its clauses are; everything else is refused.

walk(G, _, S, _, _, _) :-
    var(G), !,
    refuse(S, call/1, instantiation).
walk(Q:G, M, S, Q:G1, V0, V) :- !,
    (   atom(Q) -> true ; refuse(S, (:)/2, instantiation) ),
    (   current_module(Q) -> true ; refuse(S, Q:G, unknown_module) ),
    (   Q == M -> true ; cross_module_call(Q, G, S) ),
    walk(G, Q, S, G1, V0, V).
walk(G, _, S, _, _, _) :-
    \+ callable(G), !,
    refuse(S, G, not_callable).
walk(G, M, S, G, V, V) :-
    db_change(G), !,
    arg(1, G, Clause),
    check_db(Clause, M, G, S).
walk(G, M, S, G1, V0, V) :-
    S = st(Policy, _, _),
    local_pred(Policy, M, G), !,
    G1 = G,
    V = V0.
walk(G, M, S, G1, V0, V) :-
    defined_in(G, M, S, IM),
    (   runtime_module(IM)
    ->  runtime_goal(IM, G, M, S, G1, V0, V)
    ;   user_code(IM)
    ->  walk_pred(G, IM, S, V0, V),
        G1 = G
    ;   system_goal(G, IM, M, S, G1, V0, V)
    ).

%   As library(sandbox): a qualified call into a library module may only call what it
%   exports (its other predicates may rely on being called by its own code only).
cross_module_call(Q, G, S) :-
    (   var(G)
    ->  true                                    % refused by the walk
    ;   user_code(Q)
    ->  true
    ;   runtime_module(Q)
    ->  true                                    % builtin/3 decides
    ;   \+ db_change(G),
        \+ '$get_predicate_attribute'(Q:G, defined, 1),
        functor(G, Name, Arity),
        \+ allowed(Name/Arity)
    ->  refuse(S, Name/Arity, not_allowed)     % (asking for its properties would autoload it)
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

db_change(assert(_)).
db_change(asserta(_)).
db_change(assertz(_)).
db_change(asserta(_, _)).
db_change(assertz(_, _)).
db_change(retract(_)).
db_change(retractall(_)).

check_db(Clause, M, G, S) :-
    strip_module(M:Clause, TM, C),
    (   var(C)
    ->  refuse(S, G, instantiation)
    ;   C = (_ :- _)
    ->  refuse(S, G, database_rule)
    ;   callable(C)
    ->  functor(C, N, A),
        S = st(Policy, _, _),
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

%   The module that defines G as called from M, autoloading it if allowed/1 lists it:
%   checking a goal loads no other library (loading one runs its directives, and even
%   predicate_property(G, defined) autoloads, so the test of a definition is the system's
%   own, which does not).
defined_in(G, M, S, IM) :-
    functor(G, Name, Arity),
    (   '$get_predicate_attribute'(M:G, defined, 1)
    ->  true
    ;   allowed(Name/Arity),
        catch('$define_predicate'(M:G), _, fail),
        '$get_predicate_attribute'(M:G, defined, 1)
    ->  true
    ;   '$autoload':library_index(G, _, _)
    ->  refuse(S, Name/Arity, not_allowed)
    ;   refuse(S, Name/Arity, unknown)
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

%   A runtime predicate: builtin/3 decides; the goals it runs are walked and, where they
%   are guarded, replaced in its arguments.
runtime_goal(IM, G, M, S, G1, V0, V) :-
    S = st(Policy, _, _),
    (   builtin(Where, IM:G, Called),
        ( Where == any ; Policy = rule(_, _, _) )
    ->  own_step(IM:G, S),
        walk_called(Called, M, S, Guarded, V0, V),
        rtl_replace_goals(Called, Guarded, G, G1)
    ;   catch(sandbox:safe_primitive(IM:G), _, fail)
    ->  G1 = G,
        V = V0
    ;   goal_pi(G, PI),
        refuse(S, PI, runtime)
    ).

walk_called([], _, _, [], V, V).
walk_called([G|Gs], M, S, [G1|G1s], V0, V) :-
    walk(G, M, S, G1, V0, V1),
    walk_called(Gs, M, S, G1s, V1, V).

%!  rtl_replace_goals(+Called:list, +Guarded:list, +Term0, -Term) is det.
%
%   Term0 with each subterm identical to an element of Called replaced by the element of
%   Guarded at its place: the goals of a builtin's arguments, or of a memory request's
%   conditions, replaced by their guarded forms (rtl_check_goal/4).

rtl_replace_goals(Called, Guarded, T0, T) :-
    foldl(replace_goal, Called, Guarded, T0, T).

replace_goal(Called, Guarded, T0, T) :-
    (   Called == Guarded
    ->  T = T0
    ;   replace_identical(T0, Called, Guarded, T)
    ).

replace_identical(T0, Old, New, T) :-
    (   T0 == Old
    ->  T = New
    ;   compound(T0)
    ->  compound_name_arguments(T0, F, Args0),
        replace_in_args(Args0, Old, New, Args),
        compound_name_arguments(T, F, Args)
    ;   T = T0
    ).

replace_in_args([], _, _, []).
replace_in_args([A0|As0], Old, New, [A|As]) :-
    replace_identical(A0, Old, New, A),
    replace_in_args(As0, Old, New, As).

%   The policy runtime (rtl_policy.pl) rewinds the step it is given, retracting that step's
%   matches: an added rule may name only its own steps.
own_step(rtl_policy:G, S) :-
    policy_step(G, Step), !,
    S = st(rule(Id, _, _), Path, _),
    (   atom(Step), rtl_rule_pred_name(Id, Step)
    ->  true
    ;   throw(error(rtl_unsafe(Step, not_own_step, Path), _))
    ).
own_step(_, _).

policy_step(rtl_policy_insert(Step, _, _, _), Step).
policy_step(rtl_policy_delete(Step, _, _, _), Step).
policy_step(rtl_policy_drop_twins(Step, _), Step).
policy_step(rtl_policy_take(Step, _, _), Step).

%   A predicate of the program (or of `user`): check its clauses, for the most general call
%   first; if that needs more instantiation (a clause calls an argument, or has a goal that
%   could only be judged when it runs), for this call. Program clauses are not rewritten:
%   they are walked in `strict` mode.
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
        catch(walk_clauses(Gen, IM, S, V1, V2), error(rtl_unsafe(_, Reason, _), _),
              ( needs_instance(Reason), fail ))
    ->  V = V2
    ;   walk_specific(G, IM, S, V0, V)
    ).

needs_instance(instantiation).
needs_instance(run_time(_)).

walk_specific(G, IM, S, V0, V) :-
    copy_term(G, Key0),
    numbervars(Key0, 0, _),
    Key = IM:Key0,
    S = st(_, Path, _),
    functor(G, N, A),
    (   get_assoc(Key, V0, _)
    ->  V = V0
    ;   length(Path, Depth), Depth > 64
    ->  refuse(S, N/A, too_deep)
    ;   put_assoc(Key, V0, specific, V1),
        walk_clauses(G, IM, S, V1, V)
    ).

walk_clauses(G, IM, st(Policy, Path, _), V0, V) :-
    functor(G, N, A),
    findall(G-Body, ( clause(IM:G, Body), Body \== true ), Clauses),
    foldl(walk_clause(IM, st(Policy, [N/A|Path], strict)), Clauses, V0, V).

walk_clause(IM, S, _-Body, V0, V) :-
    walk(Body, IM, S, _, V0, V).

% ---- system and library predicates --------------------------------------------------------

%   system_goal(+G, +IM, +M, +S, -G1, +V0, -V): G, defined in the system or library module
%   IM, must be listed by allowed/1 and pass library(sandbox) (with stand-ins for the goals
%   it calls, walked here); the goals that can only be judged when they run are guarded.
system_goal(G, IM, M, S, G1, V0, V) :-
    functor(G, Name, Arity),
    (   system_module(IM), allowed(Name/Arity)
    ->  true
    ;   refuse(S, Name/Arity, not_allowed)
    ),
    checked_goal(G, M, S, G1, Second, V0, V),
    (   output(G)
    ->  true                        % library(sandbox) allows only format/2 and writeln/1
    ;   catch(sandbox:safe_goal(M:Second), E, refuse_error(S, G, E))
    ).

%   Writing to the current output (actions such as `do write(X)`).
output(write(_)).
output(writeq(_)).
output(print(_)).
output(write_canonical(_)).
output(write_term(_, _)).
output(nl).
output(tab(_)).
output(put_char(_)).

%   The modules whose predicates allowed/1 names: the system and the libraries that
%   define them.
system_module(system).
system_module('$bags').
system_module('$apply').
system_module(apply).
system_module(lists).
system_module(aggregate).
system_module(pairs).
system_module(assoc).
system_module(error).
system_module(occurs).
system_module(ordsets).
system_module(strings).
system_module('$syspreds').
system_module(yall).

%   checked_goal(+G, +M, +S, -Guarded, -Second, +V0, -V): the goals G runs are walked;
%   Guarded is what runs, Second what library(sandbox) checks (stand-ins for the walked
%   goals).
checked_goal(throw(Ball), _, S, G1, throw(Ball), V, V) :- !,
    (   \+ rtl_reserved_ball(Ball)
    ->  G1 = throw(Ball)
    ;   S = st(_, _, strict), rtl_is_reserved_ball(Ball)
    ->  refuse(S, throw/1, reserved_ball(Ball))
    ;   guard(S, throw/1, ball, rtl_guard:rtl_throw(Ball), G1)    % raises a permission error
    ).
checked_goal(catch(G, C, R), M, S, G1, catch(Checked, C, Checked), V0, V) :- !,
    stand_in(0, Checked),
    walk(G, M, S, GG, V0, V1),
    walk(R, M, S, RG, V1, V),
    (   \+ catches_reserved(C)
    ->  G1 = catch(GG, C, RG)
    ;   guard(S, catch/3, catcher, rtl_guard:rtl_catch(GG, C, RG), G1)
    ).
checked_goal(format(F), M, S, G1, Second, V0, V) :- !,
    checked_goal(format(F, []), M, S, G2, Second, V0, V),
    ( G2 = format(F, []) -> G1 = format(F) ; G1 = rtl_guard:rtl_format(F) ).
checked_goal(format(F, A), _, S, G1, Second, V, V) :- !,
    format_goal(F, S, format(F, A), rtl_guard:rtl_format(F, A), G1, Second).
checked_goal(format(Sink, F, A), _, S, G1, Second, V, V) :- !,
    checked_sink(Sink, S, format/3),
    format_goal(F, S, format(Sink, F, A), rtl_guard:rtl_format(Sink, F, A), G1, Second).
checked_goal(with_output_to(Sink, G), M, S, with_output_to(Sink, G1), Second, V0, V) :- !,
    checked_sink(Sink, S, with_output_to/2),
    stand_in(0, Checked),
    Second = with_output_to(Sink, Checked),
    walk(G, M, S, G1, V0, V).
checked_goal(write_term(T, Options), _, S, write_term(T, Options), write_term(T, Options), V, V) :- !,
    (   is_list(Options)
    ->  forall(member(O, Options),
               (   nonvar(O), functor(O, Name, 1), write_option(Name)
               ->  true
               ;   refuse(S, write_term/2, write_option(O))
               ))
    ;   refuse(S, write_term/2, write_option(Options))
    ).
checked_goal(G, M, S, G, Second, V0, V) :-                % a yall lambda: [X1, ...]>>Body
    compound(G), compound_name_arguments(G, >>, [Params, Body|Extra]), !,
    (   lambda_params(Params, Ps), callable(Body)
    ->  true
    ;   refuse(S, (>>)/2, instantiation)
    ),
    length(Ps, P),
    length(Extra, N),
    More is max(0, N - P),
    closure_goal(More, Body, Goal),
    S = st(Policy, Path, _),
    walk(Goal, M, st(Policy, Path, strict), _, V0, V),
    stand_in(0, Checked),
    length(Rest, N),
    compound_name_arguments(Second, >>, [[], Checked|Rest]).
checked_goal(print(T), _, S, print(T), print(T), V, V) :- !,
    no_portray(S, print/1).
checked_goal(G, M, S, G1, Second, V0, V) :-
    predicate_property(M:G, meta_predicate(Spec)),
    \+ \+ calls_goals(Spec), !,
    G =.. [Name|Args],
    Spec =.. [_|Specs],
    meta_args(Specs, Args, M, S, Args1, Neutral, V0, V),
    G1 =.. [Name|Args1],
    Second =.. [Name|Neutral].
checked_goal(G, _, _, G, G, V, V).

%   A goal that only a run-time guard can judge: guarded where the walk may rewrite,
%   refused where it may not (in a program predicate: the walk tries the call itself next).
guard(st(_, _, guard), _, _, Guarded, Guarded) :- !.
guard(S, PI, What, _, _) :-
    refuse(S, PI, run_time(What)).

% A catcher that could unify with a reserved ball.
catches_reserved(C) :-
    rtl_reserved_ball(C).

%   A format string known now is judged now (and by library(sandbox)); one given by data
%   is judged by the guard when it runs.
format_goal(F, S, Plain, Guarded, G1, Second) :-
    (   nonvar(F), rtl_format_directive(F, Refused)
    ->  refuse(S, format/2, format_directive(Refused))
    ;   nonvar(F), rtl_format_text(F)
    ->  G1 = Plain,
        Second = Plain
    ;   guard(S, format/2, format, Guarded, G1),
        Second = true
    ).

checked_sink(Sink, S, PI) :-
    (   rtl_output_sink(Sink)
    ->  true
    ;   refuse(S, PI, sink(Sink))
    ).

write_option(quoted).
write_option(ignore_ops).
write_option(max_depth).
write_option(numbervars).
write_option(spacing).
write_option(fullstop).
write_option(nl).
write_option(no_lists).
write_option(brace_terms).
write_option(character_escapes).
write_option(dotlists).
write_option(variable_names).
write_option(partial).
write_option(quote_non_ascii).

%   print/1 calls the program's user:portray/1: refused when the program defines it.
no_portray(S, PI) :-
    (   predicate_property(user:portray(_), number_of_clauses(N)), N > 0
    ->  refuse(S, PI, portray)
    ;   true
    ).

calls_goals(Spec) :-
    sub_term(X, Spec), nonvar(X), calling_spec(X), !.

calling_spec(I) :- integer(I).
calling_spec(^).
calling_spec(//).

%   The goal arguments of a meta-predicate: a goal (0) is walked and may be guarded; a
%   closure (N > 0) is walked with N more arguments and may not (its goal is only built
%   when it runs); `^` as 0 after its variables; a grammar body (`//`) is refused.
meta_args([], [], _, _, [], [], V, V).
meta_args([Spec|Specs], [Arg|Args], M, S, [Arg1|Args1], [N|Ns], V0, V) :-
    (   Spec == 0
    ->  walk(Arg, M, S, Arg1, V0, V1),
        stand_in(0, N)
    ;   Spec == ^
    ->  caret_goal(Arg, Inner, Arg1, Inner1),
        walk(Inner, M, S, Inner1, V0, V1),
        stand_in(0, N)
    ;   integer(Spec)
    ->  closure_goal(Spec, Arg, Goal),
        S = st(Policy, Path, _),
        walk(Goal, M, st(Policy, Path, strict), _, V0, V1),
        Arg1 = Arg,
        stand_in(Spec, N)
    ;   Spec == //
    ->  refuse(S, (//)/0, not_allowed)
    ;   Arg1 = Arg, N = Arg, V1 = V0
    ),
    meta_args(Specs, Args, M, S, Args1, Ns, V1, V).

lambda_params(Params, Ps) :-
    nonvar(Params),
    (   Params = _Free/Ps0 -> true ; Ps0 = Params ),
    is_list(Ps0),
    Ps = Ps0.

caret_goal(G, G, G1, G1) :- var(G), !.
caret_goal(V^G0, G, V^G1a, G1) :- !, caret_goal(G0, G, G1a, G1).
caret_goal(G, G, G1, G1).

stand_in(_, rtl_sandbox:'$rtl_checked').

%   allowed(?Name/Arity): the system and library predicates untrusted code may call (in
%   the modules system_module/1 lists). Pure: type tests, comparison, arithmetic, terms,
%   text conversion, lists, sets, pairs, assocs, all-solutions and control; output to the
%   current output (and to strings); the database changes check_db/4 allows. Not here, so
%   refused: files, streams and reading, processes, the OS, flags, global variables, the
%   program's clauses, modules and operators, threads, mutexes and message queues, sleep
%   and waits, attributed variables (put_attr/3, freeze/2, dif/2, when/2: their hooks run
%   goals), messages (print_message/2, message_to_codes/3: they interpret terms), cleanup
%   handlers (setup_call_cleanup/3 could run a goal after a limit fired), halt and abort.
allowed(Name/Arity) :-
    allowed_list(List),
    memberchk(Name/Arity, List).

allowed_list([
    % control
    true/0, fail/0, false/0, !/0, (',')/2, (;)/2, (->)/2, (*->)/2, (\+)/1, not/1,
    call/1, call/2, call/3, call/4, call/5, call/6, call/7, call/8,
    once/1, ignore/1, forall/2, catch/3, throw/1,
    findall/3, findall/4, bagof/3, setof/3, aggregate_all/3, aggregate_all/4,
    between/3, succ/2, plus/3, repeat/0,
    % unification, comparison, type tests
    (=)/2, (\=)/2, (==)/2, (\==)/2, (@<)/2, (@>)/2, (@=<)/2, (@>=)/2, compare/3,
    unify_with_occurs_check/2, subsumes_term/2, (?=)/2,
    var/1, nonvar/1, atom/1, number/1, integer/1, float/1, atomic/1, compound/1,
    callable/1, is_list/1, string/1, ground/1, rational/1, blob/2, text_to_string/2,
    must_be/2, is_of_type/2,
    % arithmetic
    (is)/2, (=:=)/2, (=\=)/2, (<)/2, (>)/2, (=<)/2, (>=)/2,
    % terms
    functor/3, arg/3, (=..)/2, copy_term/2, term_variables/2, setarg/3, nb_setarg/3,
    numbervars/3, term_to_atom/2, term_string/2, sub_term/2, occurrences_of_term/3,
    compound_name_arity/3, compound_name_arguments/3, tab/1,
    % atoms, strings, characters, codes, numbers
    atom_codes/2, atom_chars/2, char_code/2, atom_length/2, atom_number/2, number_codes/2,
    number_chars/2, atom_string/2, number_string/2, string_chars/2, string_codes/2,
    string_to_atom/2, string_concat/3, string_length/2, string_lower/2, string_upper/2,
    sub_atom/5, sub_string/5, atom_concat/3, atomic_list_concat/2, atomic_list_concat/3,
    split_string/4, string_code/3, upcase_atom/2, downcase_atom/2, char_type/2,
    code_type/2, text_concat/3,
    % lists
    append/2, append/3, member/2, memberchk/2, length/2, nth0/3, nth1/3, nth0/4, nth1/4,
    last/2, reverse/2, msort/2, sort/2, sort/4, predsort/3, permutation/2, flatten/2,
    sum_list/2, sumlist/2, max_list/2, min_list/2, numlist/3, list_to_set/2, subtract/3,
    intersection/3, union/3, delete/3, exclude/3, include/3, partition/4, select/3,
    selectchk/3, select/4, nextto/3, max_member/2, min_member/2, keysort/2,
    exclude/3, maplist/2, maplist/3, maplist/4, maplist/5, foldl/4, foldl/5, foldl/6,
    pairs_keys_values/3, pairs_keys/2, pairs_values/2, transpose_pairs/2,
    list_to_ord_set/2, ord_union/3, ord_subtract/3, ord_memberchk/2, ord_intersection/3,
    sumlist/3, max_member/3, min_member/3, last/2, proper_length/2, msort/2,
    (>>)/2, (>>)/3, (>>)/4, (>>)/5, (>>)/6, (>>)/7, (>>)/8, (>>)/9,
    % assocs
    empty_assoc/1, put_assoc/4, get_assoc/3, list_to_assoc/2, assoc_to_list/2,
    assoc_to_keys/2, assoc_to_values/2,
    % output to the current output or a string
    write/1, writeln/1, print/1, writeq/1, write_canonical/1, write_term/2, nl/0,
    put_char/1, format/1, format/2, format/3, with_output_to/2,
    % time
    get_time/1
]).

% ---- refusals -----------------------------------------------------------------------------

refuse(st(_, Path, _), Culprit0, Reason) :-
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
    rtl_error_text(E, Text),
    format(string(T), "unsafe goal: ~q (~s)", [C, Text]).
reason_text(reserved_ball(Ball), C, T) :-
    rtl_term_text(Ball, B),
    format(string(T), "unsafe goal: ~q of ~s, a ball reserved for the runtime (its limits, aborts and halts)", [C, B]).
reason_text(run_time(What), C, T) :-
    run_time_what(What, W),
    format(string(T), "unsafe goal: ~q ~w is only known when it runs, and it is in a program predicate, where it cannot be guarded", [C, W]).
reason_text(format_directive(D), C, T) :-
    format(string(T), "unsafe goal: ~q with the directive ~w (a directive that calls a goal, takes write options or calls portray hooks)", [C, D]).
reason_text(sink(Sink), C, T) :-
    rtl_term_text(Sink, Text),
    format(string(T), "unsafe goal: ~q writing to ~s (only the current output, atom(_), string(_), codes(_) or chars(_))", [C, Text]).
reason_text(write_option(O), C, T) :-
    rtl_term_text(O, Text),
    format(string(T), "unsafe goal: ~q with the write option ~s", [C, Text]).
reason_text(portray, C, T) :-
    format(string(T), "unsafe goal: ~q (it calls the program's portray/1)", [C]).

run_time_what(ball, "whose ball").
run_time_what(catcher, "whose catcher could catch the runtime's limits, which").
run_time_what(format, "whose format").

rtl_error_text:runtime_error_text(rtl_unsafe(Culprit, Reason, Path), Message) :-
    rtl_unsafe_message(rtl_unsafe(Culprit, Reason, Path), Message).

:- multifile prolog:error_message//1.

prolog:error_message(rtl_unsafe(Culprit, Reason, Path)) -->
    { rtl_unsafe_message(rtl_unsafe(Culprit, Reason, Path), Message) },
    [ '~s'-[Message] ].

%!  rtl_rule_pred_name(+Id, +Name) is semidet.
%
%   Name is a predicate generated for the rule labelled Id: `e_<Id>_<digits>` or
%   `e_<Id>_<digits>_<suffix>`, the suffix not starting with a digit (`e_r1_2_1` belongs to
%   rule `r1_2`, not `r1`).

rtl_rule_pred_name(Id, Name) :-
    atom(Name),
    atomic_list_concat([e_, Id, '_'], Prefix),
    atom_concat(Prefix, Tail, Name),
    atom_codes(Tail, Codes),
    digits(Codes, Rest),
    (   Rest == []
    ->  true
    ;   Rest = [0'_, C|_],
        \+ code_type(C, digit)
    ).

digits([C|Cs], Rest) :-
    code_type(C, digit), !,
    digits_(Cs, Rest).

digits_([C|Cs], Rest) :-
    code_type(C, digit), !,
    digits_(Cs, Rest).
digits_(Rest, Rest).
