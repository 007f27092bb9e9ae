/*  Retalis active queries: the runtime shared by the Naive, Optimized and
    Tabled Optimized transformations (thesis chapter 6).

    A program compiled by `retalisc compile --active-queries MODE` (or by
    retalisc.backends.prolog.aq_backend.compile_active_queries/4) consists of
    its dynamic facts plus, for every rule k and every body literal that waits
    for answers (a *wait point*), generated clauses:

      '$aq_act'(Head, T)            activation e_k0: rule k for table T
      '$aq_go'(State, Literal, R)   resume State once Literal has an answer
                                    of rank R (see Ranks below)
      '$aq_final'(Head, T, Prev, Kind, Literal, Check) one-step derivation of an answer

    A *state* s<k>_<j>(T, Env...) is the binary-rule intermediate result
    e_k(j-1) of the thesis: rule k, owned by table T, with every variable bound
    by the head and the literals before literal j.  It waits for literal j,
    either on stored facts (a fact record, "facts resolved in place") or on a
    table of answers (a consumer record).  Together they are the one kind of
    goal(a_i, e_ki) record of the Optimized approach.  A state on a fact
    literal right after a call literal is a join state instead: no record,
    the join of the consumer state before it with its table (see "Join
    states").

    Tables are keyed according to the mode:
      tabled     variant of the sub-goal (or a subsuming table), shared by all
                 queries, answer-invariant (an answer is propagated once);
      optimized  a fresh table for every call, local to the query id;
      naive      the most general sub-goal per predicate, local to the query
                 id, facts copied into tables (EDBC initialisation); only the
                 query's own goal keeps its bindings.

    Addition propagates new facts and answers forward.  Deletion is DRed on
    the binarized program: over-delete (and remove) what is reachable from
    the deleted facts (states, and answers whose creating derivation may be
    among the deleted ones: see Ranks), then re-derive the over-deleted
    answers and states that had more than one derivation and still have a
    one-step derivation, and propagate those forward again.
    aq_configure([dred(basic)]) over-deletes every reachable answer instead.
    Facts are a set: a fact stored twice is one fact (see "A state can be
    derived more than once").

    Update scripts (`retalisc aq --script`) are read and run by
    rtl_aq_script.pl, through the exports of this module.
*/

:- module(rtl_aq,
          [ aq_configure/1,         % +Options
            aq_register/2,          % +Id, :Goal
            aq_register/3,          % +Id, :Goal, -Answers
            aq_register/4,          % +Id, :Goal, -Answers, +Options
            aq_unregister/1,        % +Id
            aq_assert/1,            % +Fact
            aq_retract/1,           % +Fact
            aq_assert_all/1,        % +Facts
            aq_retract_all/1,       % +Facts
            aq_add_rule/1,          % +Rule
            aq_remove_rule/1,       % +Rule
            aq_answers/2,           % +Id, -Answers
            aq_query/2,             % :Goal, -Answers
            aq_events/1,            % -Events
            aq_set_notify/1,        % :Hook
            aq_queries/1,           % -Ids
            aq_stats/1,             % -Stats
            aq_reset/0,
            aq_reset_program/0,
            aq_registered/1,        % +Id                      (rtl_aq_script.pl)
            aq_check_query_goal/1,  % +Goal                    (rtl_aq_script.pl)
            aq_check_fact/1,        % +Fact                    (rtl_aq_script.pl)
            aq_rule_added/1,        % +Rule                    (rtl_aq_script.pl)
            aq_wait_fact/2,         % +Literal, +State         (called by generated code)
            aq_wait_call/2,         % +Literal, +State         (called by generated code)
            aq_wait_neg/4,          % +Kind, +Literal, +State, +Stratum (called by generated code)
            aq_answer/3,            % +Table, +Answer, +Rank   (called by generated code)
            aq_fact_arrived/2,      % +State, +Fact            (called by generated code)
            aq_adornment/2,         % +Vars, -Mask             (called by generated code)
            aq_state_code/1,        % +Terms                   (rtl_state.pl: restore)
            aq_code_head/1,         % ?Head                    (rtl_state.pl)
            aq_state_kinds/2,       % +Terms, -Kinds           (rtl_state.pl: restore)
            aq_state_literal/3,     % +Kinds, +Literal, -Kind  (rtl_state.pl)
            aq_state_negations/2,   % +Kinds, +NStatesTrie     (rtl_state.pl)
            aq_state_negated/3,     % +Kinds, +How, +Literal   (rtl_state.pl)
            aq_state_conf/2,        % +Key, +Value             (rtl_state.pl)
            aq_event_op/1           % ?Op                      (rtl_state.pl)
          ]).
:- use_module(rtl_load, []).              % first: out-of-date .qlf files are not used
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(pairs)).
:- use_module(library(assoc)).
:- use_module(library(ordsets)).
:- use_module(rtl_aq_rules).

%   Arithmetic compiled to virtual machine instructions (this file only):
%   the ranks of answers (aq_answer/3) and the adornment masks of
%   activations (aq_adornment/2) are computed for every answer and table,
%   and called is/2 cost a tenth of a point query.
:- set_prolog_flag(optimise, true).

:- meta_predicate aq_set_notify(2).

:- dynamic
    aq_tab/5,          % aq_tab(T, Goal, AnswerTrie, Owner, Key)
    aq_tpred/3,        % aq_tpred(Name/Arity, Goal, T)   (subsumption index)
    aq_c/3,            % aq_c(T, Literal, State)       consumer records
    aq_agenda/3,       % aq_agenda(T, Answer, Rank)    new answers still to propagate
    aq_q/4,            % aq_q(Id, Goal, Kind, T)
    aq_ev/3,           % aq_ev(Id, Op, Answer)         pending notifications
    aq_conf/2,
    aq_hook/1,
    aq_ground_facts/3,  % aq_ground_facts(Name, Arity, Bool)  every stored fact is ground
    aq_negq/5,         % aq_negq(Stratum, Kind, Goal, State, T)  a negation still to be checked
    aq_buf/3,          % aq_buf(Id, Op, Answer)        notifications of an update, held back
    aq_rule/3,         % aq_rule(N, Rule, ClauseRefs)  rules added at run time
    aq_mixed/2.        % aq_mixed(P, N)  P became a mixed predicate, its facts read by rule N

aq_conf(mode, tabled).
aq_conf(subsumption, false).
aq_conf(dred, primary).
aq_conf(negation, false).

:- initialization(init_globals).

init_globals :-
    nb_setval(aq_phase, insert),
    nb_setval(aq_ground, unknown),
    nb_setval(aq_registering, '$none'),
    trie_new(Sub), nb_setval(aq_subgoals, Sub),
    trie_new(St), nb_setval(aq_cstates, St),
    trie_new(NS), nb_setval(aq_nstates, NS),
    nb_setval(aq_buffer, off),
    nb_setval(aq_joins, unknown),
    nb_setval(aq_dred, '$none').

%!  aq_configure(+Options) is det.
%
%   Set the transformation the program was compiled with: mode(tabled),
%   mode(optimized), mode(naive) and subsumption(true/false) (tabled only:
%   reuse the table of a more general sub-goal when there is no variant).
%   Generated programs call it; it must run before any query is registered.
%   dred(primary) (default) or dred(basic) chooses the DRed variant.

aq_configure(Options) :-
    retractall(aq_ground_facts(_, _, _)),       % a (re)loaded program
    retractall(aq_fact_only(_, _, _)),
    retractall(aq_mixed(_, _)),
    nb_setval(aq_ground, unknown),
    nb_setval(aq_joins, unknown),
    retractall(aq_join_step(_, _, _, _)),
    retractall(aq_join_state(_)),
    retractall(aq_join_eligible(_, _, _, _)),
    retractall(aq_join_consumers(_, _, _)),
    retractall(aq_join_off(_, _)),
    forall(member(Opt, Options), configure(Opt)).

configure(Opt) :-
    (   compound(Opt), Opt =.. [Key, Value], option_domain(Key, Domain)
    ->  must_be(Domain, Value),
        retractall(aq_conf(Key, _)), assertz(aq_conf(Key, Value))
    ;   domain_error(aq_option, Opt)
    ).

option_domain(mode, oneof([tabled, optimized, naive])).
option_domain(subsumption, boolean).
option_domain(dred, oneof([primary, basic])).
option_domain(negation, boolean).

%!  aq_state_conf(+Key, +Value) is semidet.
%
%   Key is an option of aq_configure/1 (`aq_conf(Key, Value)`) and Value one of its values.
aq_state_conf(Key, Value) :-
    atom(Key), option_domain(Key, Domain), is_of_type(Domain, Value).

%!  aq_event_op(?Op) is nondet.
%
%   The operations of a notification (emit/3): Event is Op(Answer).
aq_event_op(answer).
aq_event_op(add).
aq_event_op(delete).

%!  aq_set_notify(:Hook) is det.
%
%   Call Hook(Id, Event) for every notification instead of queueing it, where
%   Event is answer(A), add(A) or delete(A).  aq_set_notify(none) restores
%   queueing (read the queue with aq_events/1).

aq_set_notify(_:none) :- !, retractall(aq_hook(_)).
aq_set_notify(Hook) :- retractall(aq_hook(_)), assertz(aq_hook(Hook)).

%!  aq_events(-Events) is det.
%
%   Events is the list of pending notifications ev(Id, Op, Answer), Op one of
%   answer, add, delete, in the order they were produced (sorted within one
%   update); the queue is emptied.

aq_events(Events) :-
    (   aq_ev(_, _, _)
    ->  findall(ev(Id, Op, A), aq_ev(Id, Op, A), Events),
        retractall(aq_ev(_, _, _))
    ;   Events = []
    ).

emit(Id, Op, A) :-
    (   nb_getval(aq_buffer, on)
    ->  assertz(aq_buf(Id, Op, A))
    ;   aq_hook(Hook)
    ->  Ev =.. [Op, A], ignore(call(Hook, Id, Ev))
    ;   assertz(aq_ev(Id, Op, A))
    ).

%!  aq_register(+Id, :Goal) is det.
%!  aq_register(+Id, :Goal, -Answers) is det.
%
%   Register Goal as active query Id and evaluate it top-down.  Answers is the
%   sorted list of its current answers (instances of Goal); aq_register/2
%   queues them as answer notifications instead (or passes them to the
%   notify hook).  From now on assertions and retractions produce add/delete
%   notifications for Id until aq_unregister(Id).

aq_register(Id, Goal) :-
    aq_register(Id, Goal, Answers),
    forall(member(A, Answers), emit(Id, answer, A)).

aq_register(Id, Goal, Answers) :-
    aq_register(Id, Goal, Answers, []).

%!  aq_register(+Id, :Goal, -Answers, +Options) is det.
%
%   As aq_register/3; Options: answers(sorted) (the default) or
%   answers(unsorted): Answers holds each answer once, in the order of
%   its table, not sorted (a query with 100k answers registers in a fifth
%   less time; findall/3 does not sort either).

aq_register(Id, _:Goal0, Answers, Options) :- !,
    aq_register(Id, Goal0, Answers, Options).
aq_register(Id, Goal, Answers, Options) :-
    must_be(list, Options),
    (   memberchk(answers(Order), Options)
    ->  must_be(oneof([sorted, unsorted]), Order)
    ;   Order = sorted
    ),
    must_be(ground, Id),
    (   aq_q(Id, _, _, _) -> permission_error(register, active_query, Id) ; true ),
    goal_kind(Goal, Kind),
    copy_term(Goal, G),
    (   nb_getval(aq_joins, unknown) -> find_join_steps ; true ),
    nb_setval(aq_registering, Id),
    nb_setval(aq_phase, insert),
    catch(register_root(Kind, Id, G), E,
          ( nb_setval(aq_registering, '$none'), retractall(aq_agenda(_, _, _)), throw(E) )),
    nb_setval(aq_registering, '$none'),
    warm_fact_indexes,
    (   Order == sorted
    ->  aq_answers(Id, Answers)
    ;   query_answers(Id, Answers)
    ).

%   The query's own consumer record is added once the evaluation is done:
%   the answers found while registering are read from the table afterwards
%   (notify/3), so resuming the query on each of them would be work for
%   nothing (a tenth of the registration of a query with 100k answers).
register_root(call, Id, G) :-
    assertz(aq_q(Id, G, call, pending)),
    aq_wait_call(G, q(Id)),
    drain,
    trie_lookup_state(q(Id), T),
    assertz(aq_c(T, G, q(Id))),
    retract(aq_q(Id, G1, call, pending)),
    assertz(aq_q(Id, G1, call, T)).
register_root(fact, Id, G) :-
    assertz(aq_q(Id, G, fact, none)),
    aq_wait_fact(G, q(Id)),
    drain.

%   SWI-Prolog builds the index of a dynamic predicate on its first call
%   with bound arguments, and assesses it again, as the predicate grows, at
%   a later call.  Registration looks up the stored facts and the goal
%   records the ways updates do, so that the first update after it does not
%   pay for indexing (50 ms for the 1.7M records of Program 6 with 500
%   queries, when the records were not looked up; 24 ms, against 0.1 ms for
%   the next retraction, when they were looked up at the first query only,
%   whose 30 records waiting on show/3 got no index, the 16,000 of the 500th
%   did).  Every registration looks up the records as updates call them
%   (warm_records/1); the other looks (a ground fact, as adding or
%   retracting one does; clause/3 of one state's record, as over-deletion
%   does) are repeated once the registrations have doubled since the last
%   (at every registration they cost a fifth of the registration of Program
%   6 with a query per user; counting the records to decide would cost
%   more, number_of_clauses walks the clauses).  Whether every stored fact
%   is ground (ground_fact/1) is decided here too, once, rather than at the
%   first retraction.
warm_fact_indexes :-
    flag(aq_registrations, R0, R0 + 1),
    R is R0 + 1,
    forall(user:'$aq_fact_pred'(F), warm_fact_index(F, R)),
    nb_getval(aq_ground, G),
    (   known_ground(G)
    ->  true
    ;   resolve_ground(G, _)
    ).

warm_fact_index(F, R) :-
    functor(F, N, A),
    (   aq_warm(N, A, R0),
        R < 2 * R0
    ->  warm_records(F)
    ;   retractall(aq_warm(N, A, _)),
        assertz(aq_warm(N, A, R)),
        warm_records(F),
        ignore(( \+ \+ ( once(user:F), once(user:F) ) )),
        ignore(( \+ \+ ( user:'$aq_whead'(F, S, H), once(user:H), fact_record(F, S, _) ) ))
    ).

%   The records waiting on a stored fact (addition, retraction), and those
%   of one state waiting on its literal (re-derivation: premise/4).
warm_records(F) :-
    ignore(( \+ \+ ( once(user:F), once(user:'$aq_wrec'(F, _)) ) )),
    ignore(( \+ \+ ( user:'$aq_whead'(F, S, H), once(user:H), once(user:'$aq_wrec'(F, S)) ) )).

:- dynamic aq_warm/3.           % aq_warm(Name, Arity, RegistrationsThen)

trie_lookup_state(S, T) :-
    nb_getval(aq_cstates, St),
    trie_lookup(St, S, V),
    table_of(V, T).

goal_kind(Goal, Kind) :-
    (   callable(Goal), user:'$aq_kind'(Goal, Kind0)
    ->  (   aq_conf(mode, naive) -> Kind = call ; Kind = Kind0 )
    ;   callable(Goal)
    ->  functor(Goal, N, A),
        existence_error(active_query_predicate, N/A)
    ;   type_error(callable, Goal)
    ).

%!  aq_registered(+Id) is semidet.
%
%   Id is the id of a registered active query.

aq_registered(Id) :-
    aq_q(Id, _, _, _),
    !.

%!  aq_check_query_goal(+Goal) is det.
%
%   Goal is an atom of a query predicate of the program, as aq_register/3 wants it;
%   raises the error aq_register/3 raises otherwise.

aq_check_query_goal(Goal) :-
    goal_kind(Goal, _).

%!  aq_check_fact(+Fact) is det.
%
%   Fact is of a stored (dynamic) predicate of the program, as aq_assert/1 and aq_retract/1
%   want it; raises the error they raise otherwise.

aq_check_fact(Fact) :-
    check_fact(Fact).

%!  aq_rule_added(+Rule) is semidet.
%
%   A variant of Rule was added at run time (aq_add_rule/1) and is not removed.

aq_rule_added(Rule) :-
    aq_rule(_, R, _),
    R =@= Rule,
    !.

%!  aq_answers(+Id, -Answers) is det.
%
%   The current answers of active query Id, sorted.

aq_answers(Id, Answers) :-
    query_answers(Id, As0),
    sort(As0, Answers).

%   The answers of a query in the order of its table, each once (a fact
%   stored twice is one answer).  A table is its answer trie: no lookup of
%   aq_tab/5 (whose first call by table after the tables were made builds
%   an index over all of them, a thirtieth of a point query's registration).
query_answers(Id, Answers) :-
    (   aq_q(Id, G, Kind, T) -> true ; existence_error(active_query, Id) ),
    (   Kind == call
    ->  findall(G, trie_gen(T, G), Answers)
    ;   findall(G, user:G, As0),
        sort(As0, Answers)
    ).

%!  aq_query(:Goal, -Answers) is det.
%
%   One-shot evaluation: register Goal, collect its answers, unregister.

aq_query(_:Goal, Answers) :- !, aq_query(Goal, Answers).
aq_query(Goal, Answers) :-
    gensym('$aq_oneshot_', Id),
    setup_call_cleanup(
        aq_register(Id, Goal, Answers),
        true,
        ( aq_unregister(Id), retractall(aq_ev(Id, _, _)) )).

%!  aq_queries(-Ids) is det.
aq_queries(Ids) :- findall(Id, aq_q(Id, _, _, _), Ids).

%!  aq_unregister(+Id) is det.
%
%   Remove active query Id and free every table, state record and dependency
%   that no other registered query still needs.

aq_unregister(Id) :-
    (   retract(aq_q(Id, G, Kind, T)) -> true ; existence_error(active_query, Id) ),
    (   Kind == call
    ->  forall(clause(aq_c(T, _, q(Id)), true, Ref), erase(Ref)),
        nb_getval(aq_cstates, St),
        ignore(trie_delete(St, q(Id), _))
    ;   forall(user:'$aq_wref'(G, S, Ref), ( S == q(Id) -> erase(Ref) ; true ))
    ),
    retractall(aq_ev(Id, _, _)),
    collect_garbage.

%   Tables reachable from a registered query survive; everything else goes.
%   Table T depends on table T2 when a state of T (its first argument is T)
%   consumes T2 (the cstates trie) or checks a negated literal against T2
%   (the nstates trie, and the negations still to be checked): the
%   dependencies are read from the states when a query goes, not recorded
%   per table (a clause and a lookup for each of the 1000 tables of a point
%   query on a chain of 1000, a seventh of its registration).
collect_garbage :-
    findall(T, aq_q(_, _, call, T), Roots),
    table_dependencies(Deps),
    empty_assoc(Seen0),
    reachable(Roots, Deps, Seen0, Seen),
    assoc_to_keys(Seen, Live),
    findall(T, aq_tab(T, _, _, _, _), All),
    ord_subtract_sorted(All, Live, Dead),
    (   Dead == [] -> true ; free_tables(Dead) ).

%   Deps maps every table to the tables its states consume or check.
table_dependencies(Deps) :-
    nb_getval(aq_cstates, St),
    nb_getval(aq_nstates, NS),
    findall(From-T,
            (   (   trie_entry(St, S, V), table_of(V, T)
                ;   trie_entry(NS, ns(S, _), n(call, T, _, _))
                ;   aq_negq(_, call, _, S, T)
                ),
                state_owner(S, From)
            ),
            Pairs0),
    sort(Pairs0, Pairs),
    group_pairs_by_key(Pairs, Grouped),
    list_to_assoc(Grouped, Deps).

%   trie_gen/3 of SWI-Prolog 9.0.4 crashes (a segmentation fault) on a trie
%   whose entries were all deleted after it had keys of different functors,
%   as the state tries have once every query is unregistered.
trie_entry(Trie, Key, Value) :-
    trie_property(Trie, value_count(N)),
    N > 0,
    trie_gen(Trie, Key, Value).

reachable([], _, Seen, Seen).
reachable([T|Ts], Deps, Seen0, Seen) :-
    (   get_assoc(T, Seen0, _)
    ->  reachable(Ts, Deps, Seen0, Seen)
    ;   put_assoc(T, Seen0, true, Seen1),
        (   get_assoc(T, Deps, Next) -> append(Next, Ts, Ts1) ; Ts1 = Ts ),
        reachable(Ts1, Deps, Seen1, Seen)
    ).

ord_subtract_sorted(All, Live, Dead) :-
    sort(All, AllS),
    ord_subtract(AllS, Live, Dead).

free_tables(Dead) :-
    forall(member(T, Dead), assertz(aq_dead(T))),
    nb_getval(aq_subgoals, Sub),
    nb_getval(aq_cstates, St),
    forall(member(T, Dead),
           ( retract(aq_tab(T, _, Tr, _, Key)),
             trie_destroy(Tr),
             ( Key == none -> true ; ignore(trie_delete(Sub, Key, _)) ),
             retractall(aq_tpred(_, _, T)),
             forall(retract(aq_c(T, _, S)), ignore(trie_delete(St, S, _)))
           )),
    % states owned by dead tables, waiting on facts or on live tables
    forall(( user:'$aq_wref'(_, S, Ref), state_owner(S, O), aq_dead(O) ), erase(Ref)),
    forall(( clause(aq_c(_, _, S), true, Ref), state_owner(S, O), aq_dead(O) ),
           ( erase(Ref), ignore(trie_delete(St, S, _)) )),
    nb_getval(aq_nstates, NS),
    forall(( trie_entry(NS, ns(S, G), _), state_owner(S, O), aq_dead(O) ),
           ignore(trie_delete(NS, ns(S, G), _))),
    retractall(aq_dead(_)).

:- dynamic aq_dead/1.

state_owner(S, T) :- S \= q(_), arg(1, S, T).

%!  aq_reset_program is det.
%
%   Before another program is loaded in place of this one (retalisc/driver/active_queries.py):
%   aq_reset/0 (the globals made again first when they are gone, as after an Engine's snapshot
%   restored in this process without them), and the facts asserted and the rules added at run
%   time dropped too (reloading the program keeps them otherwise).

aq_reset_program :-
    (   nb_current(aq_subgoals, _) -> true ; init_globals ),
    aq_reset,
    forall(catch(user:'$aq_fact_pred'(F), _, fail), retractall(user:F)),
    forall(member(P, ['$aq_act'(_, _), '$aq_go'(_, _, _), '$aq_final'(_, _, _, _, _, _), '$aq_kind'(_, _)]),
           retractall(user:P)),
    retractall(aq_rule(_, _, _)),
    flag(aq_rule_id, _, 0).

%!  aq_reset is det.
%
%   Unregister every query and drop every table (the facts stay).

%   Everything goes at once: unregistering the queries one by one would
%   scan the goal records once per query.  What is known of the facts
%   (whether every stored fact is ground: aq_ground, aq_ground_facts/3)
%   stays with them while no stored predicate changes (kept/2, checked by
%   resolve_ground/2; facts asserted directly after the reset, as a test
%   or a loader does, make it stale): scanning them again at the next
%   registration cost 0.1 ms for a chain of 1000 facts, 5-10 ms for 100k
%   facts, and the re-evaluation of the queries after a negation flipped
%   (aq_reset, then every query registered again) a scan of every fact.
aq_reset :-
    retractall(aq_q(_, _, _, _)),
    forall(retract(aq_tab(T, _, _, _, _)), trie_destroy(T)),
    retractall(aq_tpred(_, _, _)),
    forall(user:'$aq_fact_pred'(F),
           ( user:'$aq_whead'(F, _, H), retractall(user:H) )),
    retractall(aq_c(_, _, _)), retractall(aq_ev(_, _, _)),
    retractall(aq_agenda(_, _, _)),
    retractall(aq_negq(_, _, _, _, _)),
    retractall(aq_warm(_, _, _)),
    retractall(aq_join_step(_, _, _, _)),
    retractall(aq_join_state(_)),
    retractall(aq_join_eligible(_, _, _, _)),
    retractall(aq_join_consumers(_, _, _)),
    retractall(aq_join_off(_, _)),
    flag(aq_registrations, _, 0),
    nb_getval(aq_subgoals, Sub), trie_destroy(Sub),
    nb_getval(aq_cstates, St), trie_destroy(St),
    nb_getval(aq_nstates, NS), trie_destroy(NS),
    nb_getval(aq_ground, Ground),
    init_globals,
    (   known_ground(Ground)
    ->  facts_generations(Gens),
        nb_setval(aq_ground, kept(Ground, Gens))
    ;   nb_setval(aq_ground, Ground)
    ).

%!  aq_stats(-Stats) is det.
%
%   Stats is a list Key=Value: queries, tables, answers, consumers,
%   fact_records, cstates, subgoals, deps, multi (answers derived more than
%   once), negations (states at a negated literal).  All but the facts
%   return to 0 once every query is unregistered.

aq_stats([queries=NQ, tables=NT, answers=NA, consumers=NC, fact_records=NF,
          cstates=NS, subgoals=NG, deps=ND, multi=NM, negations=NN]) :-
    nb_getval(aq_nstates, NSt), trie_count(NSt, NN),
    aggregate_all(count, aq_q(_, _, _, _), NQ),
    aggregate_all(count, aq_tab(_, _, _, _, _), NT),
    aggregate_all(sum(C), (aq_tab(_, _, Tr, _, _), trie_count(Tr, C)), NA),
    aggregate_all(count, aq_c(_, _, _), NC),
    aggregate_all(count, user:'$aq_wref'(_, _, _), NF),
    nb_getval(aq_cstates, St), trie_count(St, NS),
    nb_getval(aq_subgoals, Sub), trie_count(Sub, NG),
    table_dependencies(Deps),
    assoc_to_values(Deps, Consumed),
    append(Consumed, AllConsumed),
    length(AllConsumed, ND),
    aggregate_all(count, ( aq_tab(_, _, Tr, _, _), trie_gen(Tr, _, V), V < 0 ), NM).

trie_count(Tr, C) :-
    (   trie_property(Tr, value_count(C)) -> true ; C = 0 ).

		 /*******************************
		 *     WAITING ON LITERALS      *
		 *******************************/

%   Ranks.  Every answer has a rank, stored with it in its table's trie.
%   A derivation (a state resumed with an answer or a fact) has the rank of
%   the answer it consumed (0 for a fact), and the answer it creates gets
%   rank R+1: the derivation that created an answer always has a smaller
%   rank than the answer.  DRed uses this (see dred/2): an answer is
%   over-deleted only when a deleted derivation of smaller rank reaches it,
%   which always includes the one that created it.

%   A state can be derived more than once: from the same previous state
%   resolved against a fact that the store holds twice (a program may list
%   a fact twice), from two answers or facts that bind its literal alike
%   (e(X, 1) and e(0, 1) for e(0, Y)), or from an answer that a new
%   consumer finds in its table while the answer still waits on the agenda
%   to be propagated to it.  It is still one state: DRed over-deletes it as
%   a whole and re-derives it, like an answer, when it was derived more
%   than once and still has a one-step derivation (rederive_state/3).
%   Where the state is stored says how often it was derived, at no cost
%   for the common single derivation: a state waiting on facts has one goal
%   record per derivation (looking for an existing record at every
%   creation would scan records that are not indexed on the state: 20
%   times slower for Program 6 with a query per user), and over-deletion
%   erases all of them; a consumer state is created once (a second table
%   for one state could not be recorded), and a second derivation turns its
%   table T in the cstates trie into m(T).  (Erasing one of two goal
%   records, as the runtime once did, left the state behind, re-deriving
%   answers whose facts were gone.)

%!  aq_wait_fact(+Literal, +State) is det.
%
%   State waits for stored facts matching Literal: record it (so later
%   assertions find it) and resolve Literal in place against the facts.

%   The insert phase is written out here, not as a clause of wait_fact/3:
%   it runs once per answer of a rule whose next literal is a stored fact,
%   and every call less is a frame less on the depth-first propagation
%   (see "Seventh round" in docs/active_queries.md).
aq_wait_fact(Lit, S) :-
    nb_getval(aq_phase, P),
    (   P == insert
    ->  (   aq_join_state(S)
        ->  true
        ;   user:'$aq_wadd'(Lit, S)
        ),
        (   user:Lit,
            go(S, Lit, 0),
            fail
        ;   true
        )
    ;   wait_fact(P, Lit, S)
    ).

%   A join state existed when its consumer state or its answer is over-deleted
%   (the caller found both), and it has that one derivation.
wait_fact(delete, Lit, S) :-
    join_state(S), !,
    forall(user:Lit, go(S, Lit, 0)).
wait_fact(delete, Lit, S) :-
    take_fact_records(Lit, S, N),
    (   N > 0
    ->  (   N > 1 -> ignore(mark(s(fact, Lit, S))) ; true ),
        forall(user:Lit, go(S, Lit, 0))
    ;   true
    ).
%   A state that is there already gets one more goal record: restoring an
%   over-deleted derivation reached it a second time.
wait_fact(restore, Lit, S) :-
    (   join_state(S)
    ->  forall(user:Lit, go(S, Lit, 0))
    ;   has_fact_record(Lit, S)
    ->  user:'$aq_wadd'(Lit, S)
    ;   user:'$aq_wadd'(Lit, S),
        forall(user:Lit, go(S, Lit, 0))
    ).

%   The goal records of State waiting on Literal (variants, not instances).
fact_record(Lit, S, Ref) :-
    user:'$aq_whead'(Lit, S, H),
    copy_term(H, H1),
    user:clause(H1, true, Ref),
    user:clause(H2, true, Ref),
    H2 =@= H.

%   Erase them; N is how many there were.
take_fact_records(Lit, S, N) :-
    Count = n(0),
    (   fact_record(Lit, S, Ref),
        erase(Ref),
        arg(1, Count, N0),
        N1 is N0 + 1,
        nb_setarg(1, Count, N1),
        fail
    ;   arg(1, Count, N)
    ).

has_fact_record(Lit, S) :-
    once(fact_record(Lit, S, _)).

%   Join states.  A state S waiting on a fact literal F that a consumer
%   state P creates from an answer of its call literal L, with no builtin
%   between the two literals ('$aq_go'(P, L, _) :- aq_wait_fact(F, S)),
%   exists exactly when P waits on its table and L has that answer: S is
%   the join of P with the table.  When S holds every variable of P and L,
%   the pair (P, answer) is its only derivation, and S keeps no goal record:
%   a fact that arrives (or goes) finds its join states through the
%   consumer states of that step (a trie lookup in the cstates trie with the
%   arguments the fact binds) and their tables (a trie lookup of the answer
%   the fact binds).  A left-recursive rule (path(X, Y) :- path(X, Z),
%   edge(Z, Y)) so keeps one record per call instead of one per answer.
%   The steps are found in the generated clauses (join_step/4), again when
%   rules are added or removed at run time; not in the naive mode, whose
%   facts are tables.  A step is live from its first consumer state on:
%   only live steps are looked at when a fact arrives or goes, so that a
%   step no query uses (the body order compiled for another adornment)
%   costs the updates nothing.  The global aq_joins is true while a step is
%   live, eligible while there are steps but none is live, false without
%   steps (unknown until the first registration).
:- dynamic
    aq_join_step/4,             % aq_join_step(Fact, Prev, CallLiteral, State): live
    aq_join_state/1,            % aq_join_state(State): the State of a live step
    aq_join_eligible/4.         % the same for every join step of the program

%   Asked for every state that waits on facts: aq_join_state/1 keeps the
%   states of aq_join_step/4 first, where the clause index finds them by
%   their functor (a twentieth of the left chain's evaluation otherwise).
join_state(S) :-
    aq_join_state(S), !.

live_join_step(F, P, L, S) :-
    assertz(aq_join_step(F, P, L, S)),
    assertz(aq_join_state(S)).

%   The join states that wait on fact F: those of the consumer states of a
%   join step that have an answer binding F's literal.
join_states(F, S) :-
    nb_getval(aq_joins, true),
    aq_join_step(F, P, L, S),
    nb_getval(aq_cstates, St),
    trie_gen(St, P, V),
    table_of(V, T),
    trie_gen(T, L, _).

%   Forward from fact F to every state that waits on it.  The join states
%   are collected first: should the goal records' propagation switch their
%   step to records (join_step_to_records/2), the records loop, which sees
%   the records as they were when it started, would miss them.
fact_go(F) :-
    (   nb_getval(aq_joins, true)
    ->  findall(F-S, join_states(F, S), Joined),
        forall(user:'$aq_wrec'(F, S), go(S, F, 0)),
        forall(member(F1-S, Joined), go(S, F1, 0))
    ;   forall(user:'$aq_wrec'(F, S), go(S, F, 0))
    ).

find_join_steps :-
    retractall(aq_join_step(_, _, _, _)),
    retractall(aq_join_state(_)),
    retractall(aq_join_eligible(_, _, _, _)),
    (   aq_conf(mode, naive)
    ->  true
    ;   forall(( join_step(F, P, L, S), functor(P, N, A), \+ aq_join_off(N, A) ),
               ( assertz(aq_join_eligible(F, P, L, S)),
                 (   aq_join_consumers(N, A, _)
                 ->  live_join_step(F, P, L, S)
                 ;   true
                 ) ))
    ),
    join_flag.

join_flag :-
    (   aq_join_step(_, _, _, _) -> B = true
    ;   aq_join_eligible(_, _, _, _) -> B = eligible
    ;   B = false
    ),
    nb_setval(aq_joins, B).

%   A fact of a join step's literal looks at every consumer state of the
%   step that its arguments do not tell apart (path(X, Z) for every X, when
%   edge(Z, Y) arrives), where a goal record is found by its index.  Past
%   join_consumer_limit/1 consumer states of one step (states still there:
%   live_join_consumers/3), its states get their
%   goal records again (join_step_to_records/2) and keep them until
%   aq_reset/0.  The limit weighs a trie lookup per consumer state (about
%   0.1 us) at every fact of the literal against a goal record per answer
%   (about 1 us and 250 bytes).  A switch in the middle of a propagation may
%   give a state a second record for the derivation it had as a join state:
%   that counts it as derived twice, which costs DRed a re-derivation check
%   and changes no answer.
join_consumer_limit(32).

:- dynamic
    aq_join_consumers/3,        % aq_join_consumers(Name, Arity, Count)
    aq_join_off/2.              % aq_join_off(Name, Arity): the step has records

count_join_consumer(S) :-
    (   \+ nb_getval(aq_joins, false),
        functor(S, N, A), functor(P, N, A),
        aq_join_eligible(_, P, _, _)
    ->  (   retract(aq_join_consumers(N, A, C0)) -> true ; C0 = 0 ),
        C is C0 + 1,
        assertz(aq_join_consumers(N, A, C)),
        (   C =:= 1
        ->  forall(aq_join_eligible(F, P, L, S1), live_join_step(F, P, L, S1)),
            nb_setval(aq_joins, true)
        ;   join_consumer_limit(Max),
            C > Max,
            nb_getval(aq_phase, insert),
            live_join_consumers(N, A, Max)
        ->  join_step_to_records(N, A)
        ;   true
        )
    ;   true
    ).

%   The count above grows with every consumer state made (again by DRed, or
%   by queries registered and unregistered in turn); past the limit the
%   states still there are counted (one trie walk per Max new states), and
%   the count restarts from them when they are not more than Max.
live_join_consumers(N, A, Max) :-
    functor(P, N, A),
    nb_getval(aq_cstates, St),
    aggregate_all(count, trie_gen(St, P, _), Live0),
    Live is Live0 + 1,                  % the state being made is not in the trie yet
    (   Live > Max
    ->  true
    ;   retractall(aq_join_consumers(N, A, _)),
        assertz(aq_join_consumers(N, A, Live)),
        fail
    ).

join_step_to_records(N, A) :-
    functor(P, N, A),
    nb_getval(aq_cstates, St),
    forall(retract(aq_join_step(F, P, L, S)),
           ( retractall(aq_join_state(S)),
             findall(F-S, ( trie_gen(St, P, V), table_of(V, T), trie_gen(T, L, _) ), Waiting),
             forall(member(F-S, Waiting), user:'$aq_wadd'(F, S)) )),
    retractall(aq_join_eligible(_, P, _, _)),
    assertz(aq_join_off(N, A)),
    join_flag.

join_step(F, P, L, S) :-
    user:clause('$aq_go'(P, L, _), Body),
    body_last(Body, true, Last),
    strip_module(Last, _, aq_wait_fact(F, S)),
    nonvar(P), P \= q(_),
    nonvar(L), L \= '$aq_not'(_),
    user:'$aq_kind'(L, call),
    \+ user:'$aq_fact_pred'(L),
    term_variables(P-L, Vs),
    term_variables(S, SVs),
    forall(member(V, Vs), ( member(W, SVs), W == V )),
    functor(S, N, A), functor(S0, N, A),
    aggregate_all(count, state_creator(S0, _), 1).

%!  aq_wait_call(+Literal, +State) is det.
%
%   State waits for answers of the sub-goal Literal: find or create its table
%   (according to the mode), record State as a consumer, activate the
%   table's rules when it is new, and resume State on the answers it has.
%   The cstates trie maps every consumer state to the table it waits on.

aq_wait_call(Lit, S) :-
    nb_getval(aq_phase, P),
    wait_call(P, Lit, S).

wait_call(insert, Lit, S) :-
    nb_getval(aq_cstates, St),
    (   trie_lookup(St, S, V)
    ->  (   V = m(_) -> true ; trie_update(St, S, m(V)) )
    ;   table_for(Lit, S, T, New),
        consume(New, T, Lit, S, St)
    ).
wait_call(delete, Lit, S) :-
    nb_getval(aq_cstates, St),
    (   trie_delete(St, S, V)
    ->  (   V = m(T) -> ignore(mark(s(call, Lit, S))) ; T = V ),
        forall(( clause(aq_c(T, L1, S1), true, Ref), L1-S1 =@= Lit-S ), erase(Ref)),
        findall(Lit-RA, answer_rank(T, Lit, RA), Answers),
        forall(member(Lit-RA, Answers), go(S, Lit, RA))
    ;   true
    ).
wait_call(restore, Lit, S) :-
    wait_call(insert, Lit, S).

%!  aq_wait_neg(+Kind, +Literal, +State, +Stratum) is det.
%
%   State waits at the negated literal `\+ Literal` of a rule whose head is
%   in stratum Stratum; Kind is how Literal is evaluated (call: through a
%   table, fact: stored facts).  Stratified negation:
%
%     - the check is deferred until nothing of a lower stratum is left to
%       do (drain/0 checks the pending negations of the lowest stratum first,
%       once the agenda is empty), so Literal's table is complete then;
%     - the nstates trie keeps every state at a negated literal, keyed
%       ns(State, Literal), with n(Kind, Table, Status, Derivations): Status
%       passed (Literal had no answer; the state resumed with
%       '$aq_not'(Literal)) or blocked;
%     - an update is incremental as long as no negation changes its truth:
%       after it, every state's Status is checked against its table; when one
%       changed (an added fact made a negated literal true, a deleted one made
%       it false), the queries are evaluated again and the difference is
%       notified (neg_update/1).  Programs without negation never pay for it.

aq_wait_neg(Kind, Lit, S, Str) :-
    nb_getval(aq_phase, P),
    wait_neg(P, Kind, Lit, S, Str).

wait_neg(insert, Kind, Lit, S, Str) :-
    neg_table(Kind, Lit, S, T),
    assertz(aq_negq(Str, Kind, Lit, S, T)).
wait_neg(restore, Kind, Lit, S, Str) :-
    wait_neg(insert, Kind, Lit, S, Str).
wait_neg(delete, _, Lit, S, Str) :-
    nb_getval(aq_nstates, NS),
    (   trie_delete(NS, ns(S, Lit), n(Kind, _, Status, M))
    ->  (   M > 1 -> ignore(mark(s(neg(Kind, Str), '$aq_not'(Lit), S))) ; true ),
        (   Status == passed -> go(S, '$aq_not'(Lit), 0) ; true )
    ;   true
    ).

%   The table a negated literal is checked against (none for stored facts),
%   created and activated now so that it is complete when the check runs.
neg_table(fact, _, _, none).
neg_table(call, Lit, S, T) :-
    table_for(Lit, S, T, New),
    activate(New, T).

neg_holds(fact, Lit, _) :-
    \+ user:Lit.
neg_holds(call, Lit, T) :-
    \+ trie_gen(T, Lit, _).

%   The pending negations of the lowest stratum are checked first: what they
%   depend on is in lower strata, whose work is done (the agenda is empty).
check_next_neg :-
    aggregate_all(min(Str), aq_negq(Str, _, _, _, _), Min),
    retract(aq_negq(Min, Kind, Lit, S, T)), !,
    nb_getval(aq_nstates, NS),
    (   trie_lookup(NS, ns(S, Lit), n(K, T0, Status, _))
    ->  trie_update(NS, ns(S, Lit), n(K, T0, Status, 2))
    ;   (   neg_holds(Kind, Lit, T) -> Status = passed ; Status = blocked ),
        trie_insert(NS, ns(S, Lit), n(Kind, T, Status, 1)),
        (   Status == passed -> go(S, '$aq_not'(Lit), 0) ; true )
    ).

%   Every negation still has the truth value its states were resumed with.
negations_unchanged :-
    nb_getval(aq_nstates, NS),
    \+ ( trie_gen(NS, ns(_, Lit), n(Kind, T, Status, _)),
          \+ neg_status(Kind, Lit, T, Status) ).

neg_status(Kind, Lit, T, passed) :- neg_holds(Kind, Lit, T).
neg_status(Kind, Lit, T, blocked) :- \+ neg_holds(Kind, Lit, T).

%   Run an update (aq_assert/1, aq_retract_all/1).  With negation in the
%   program its notifications are held back until the negations are known to
%   be unchanged; otherwise the queries are evaluated again from the facts.
neg_update(Goal) :-
    (   aq_conf(negation, true)
    ->  retractall(aq_buf(_, _, _)),
        nb_setval(aq_buffer, on),
        catch(Goal, E, true),
        nb_setval(aq_buffer, off),
        (   nonvar(E)
        ->  release_buffer, throw(E)
        ;   negations_unchanged
        ->  release_buffer
        ;   reevaluate_queries
        )
    ;   call(Goal)
    ).

release_buffer :-
    forall(retract(aq_buf(Id, Op, A)), emit(Id, Op, A)).

%   The answers before the update are the answers now without what it added
%   and with what it deleted (as notified, held back in the buffer).
reevaluate_queries :-
    findall(Id-Old,
            ( aq_q(Id, _, _, _),
              aq_answers(Id, Now),
              findall(A, aq_buf(Id, add, A), Added0), sort(Added0, Added),
              findall(A, aq_buf(Id, delete, A), Deleted0), sort(Deleted0, Deleted),
              ord_subtract(Now, Added, Kept),
              ord_union(Kept, Deleted, Old)
            ),
            Olds),
    retractall(aq_buf(_, _, _)),
    register_again(Olds).

%   Every query registered again, from the facts, and the difference from its answers
%   before (Olds: Id-Answers) notified.  The notifications not yet taken stay.
register_again(Olds) :-
    findall(Id-G, aq_q(Id, G, _, _), Queries),
    findall(aq_ev(Id, Op, A), aq_ev(Id, Op, A), Pending),
    aq_reset,
    maplist(assertz, Pending),
    forall(member(Id-G, Queries), aq_register(Id, G, _)),
    forall(member(Id-Old, Olds),
           ( aq_answers(Id, New),
             ord_subtract(Old, New, Lost),
             ord_subtract(New, Old, Won),
             forall(member(A, Lost), emit(Id, delete, A)),
             forall(member(A, Won), emit(Id, add, A))
           )).

%   The table of a consumer state, whose value in the cstates trie is T, or
%   m(T) once the state was derived more than once.
table_of(m(T), T) :- !.
table_of(T, T).

consume(New, T, Lit, S, St) :-
    count_join_consumer(S),
    (   S = q(Id), nb_getval(aq_registering, Id)
    ->  Snap = []                       % register_root/3 adds the record
    ;   New = new(_)
    ->  Snap = [],
        assertz(aq_c(T, Lit, S))
    ;   findall(Lit-RA, answer_rank(T, Lit, RA), Snap),
        assertz(aq_c(T, Lit, S))
    ),
    trie_insert(St, S, T),
    activate(New, T),
    forall(member(Lit-RA, Snap), go(S, Lit, RA)).

%!  aq_fact_arrived(+State, +Fact) is det.
%
%   Resume State, whose goal record waits on Fact, with the newly stored Fact.
aq_fact_arrived(S, F) :-
    go(S, F, 0).

go(q(Id), Lit, _) :- !,
    notify(Id, Lit).
go(S, Lit, R) :-
    (   user:'$aq_go'(S, Lit, R) -> true ; true ).

%   New is new(Goal) for a table just created for Goal (its rules run now),
%   old for a table that was there.
activate(new(G), T) :-
    forall(user:'$aq_act'(G, T), true).
activate(old, _).

%!  aq_adornment(+Vars, -Mask) is det.
%
%   Bit I of Mask is set when the I-th of Vars (head variables of a rule)
%   is ground: the activation of a table picks the body order compiled for
%   what its call binds (retalisc/passes/aq_join_order.py).
aq_adornment(Vars, Mask) :-
    adornment(Vars, 1, 0, Mask).

adornment([], _, M, M).
adornment([V|Vs], Bit, M0, M) :-
    (   ground(V) -> M1 is M0 \/ Bit ; M1 = M0 ),
    Bit1 is Bit << 1,
    adornment(Vs, Bit1, M1, M).

%!  aq_answer(+Table, +Answer, +Rank) is det.
%
%   A rule of Table derived Answer by a derivation of rank Rank (the rank
%   of the answer its last state consumed, 0 for a fact).
%   Answer-invariant tabling: only a new answer (no variant in the table yet)
%   is propagated to the consumers.

%   The insert phase is written out here, as in aq_wait_fact/2: it runs
%   for every answer derived.
aq_answer(T, A, R) :-
    nb_getval(aq_phase, P),
    RA is R + 1,
    (   P == insert
    ->  (   trie_lookup(T, A, V)
        ->  (   V > 0
            ->  NV is -V,
                trie_update(T, A, NV)
            ;   true
            )
        ;   trie_insert(T, A, RA),
            schedule(T, A, RA)
        )
    ;   answer(P, T, A, RA)
    ).

%   The answer trie of a table maps every answer to its rank R, stored as
%   -R once the answer was derived more than once (or restored by DRed,
%   whose re-derivation does not enumerate every derivation).  DRed
%   re-derives only those: an answer with a single derivation that was
%   over-deleted lost that derivation, and comes back only if the forward
%   propagation of a restored item derives it again.  (trie_insert/3 raises
%   an error rather than fail for a key that has another value, hence the
%   lookup first.)  The insert phase is in aq_answer/3.
answer(restore, T, A, RA) :-
    (   trie_lookup(T, A, _)
    ->  true
    ;   NV is -RA,
        trie_insert(T, A, NV),
        schedule(T, A, RA)
    ).
%   RD is one more than the rank of the deleted derivation: it can have
%   created A only if RD =< the rank of A.  A derivation of higher rank was
%   not the first one, so A keeps the derivation that created it.
%   An answer derived more than once that still has a derivation from
%   facts alone (kept_by_facts/2) stays, and nothing behind it is visited.
answer(delete, T, A, RD) :-
    (   trie_delete(T, A, V)
    ->  RA is abs(V),
        (   ( RD =< RA -> true ; aq_conf(dred, basic) )
        ->  (   V > 0
            ->  schedule(T, A, RA)
            ;   kept_by_facts(T, A)
            ->  trie_insert(T, A, V)
            ;   mark(a(T, A)),
                schedule(T, A, RA)
            )
        ;   trie_insert(T, A, V)        % cheaper than a lookup first: most
        )                               % deletions do reach the creator
    ;   true
    ).

%   Over-deletion reached answer A of table T, which was derived more than
%   once.  A stays when it has a one-step derivation that the deletion
%   cannot take away: a state P that is still there (it has its goal
%   record) resumed with a stored fact that is not one of the facts being
%   deleted, where P itself was derived from facts only (every literal of
%   the rule before P's wait point is a stored fact: fact_only_state/1).
%   Such a derivation cannot depend on A, so keeping A is not circular
%   support.  Should P be over-deleted later in the same pass, its own
%   forward propagation reaches A again (P resumed with the same fact) and
%   A is checked again without P.  The rank of A stays: the derivation has
%   rank 0, below any answer's rank, so a later deletion of it reaches A.
%   Only for primary DRed (basic DRed over-deletes everything reachable);
%   this is the support count of a non-recursive rule step, found by
%   looking instead of counting, and it saves the over-deletion and the
%   re-derivation of A and of what depends on it.
kept_by_facts(T, A) :-
    aq_conf(dred, primary),
    fact_derivation(T, A, dred).

%   A has a one-step derivation from a state P created from facts only,
%   resumed with a stored fact Lit that Other allows (other_fact/2).
fact_derivation(T, A, Other) :-
    copy_term(A, A1),
    user:'$aq_final'(A1, T, P, fact, Lit, Check),
    fact_only_state(P),
    \+ \+ user:'$aq_wrec'(Lit, P),
    other_fact(Other, Lit),
    user:'$aq_wrec'(Lit, P),
    call(Check),
    A1 =@= A, !.

%   A stored fact that is not one the current DRed pass deletes; or that
%   is not F (a single retraction before any change: retraction_keeps_answers/1).
other_fact(dred, Lit) :-
    user:clause(Lit, true, Ref),
    \+ deleted_fact(Ref).
other_fact(without(F), Lit) :-
    user:Lit,
    Lit \== F.

%   The stored fact Ref is one of the facts the current DRed pass deletes.
%   It is looked up as stored, not as the literal it was resolved with: the
%   literal may be an instance of it (e(X, 1) resolved for e(0, Y)).
deleted_fact(Ref) :-
    user:clause(F, true, Ref),
    nb_getval(aq_dred, D),
    trie_lookup(D, f(F), _).

%   Every state with the functor of P is created from stored facts only:
%   by the activation of its table, or by resuming a state of that kind
%   with a stored fact.  Known per functor (a rule added at run time has
%   states of its own names).
fact_only_state(P) :-
    functor(P, N, Ar),
    (   aq_fact_only(N, Ar, B)
    ->  B == true
    ;   functor(P0, N, Ar),
        (   fact_only_creators(P0) -> B = true ; B = false ),
        assertz(aq_fact_only(N, Ar, B)),
        B == true
    ).

fact_only_creators(P) :-
    \+ ( state_creator(P, How), \+ fact_only_creator(How) ).

state_creator(S, act) :-
    user:clause('$aq_act'(_, _), Body),
    body_last(Body, _, Last),
    creates(Last, S1),
    \+ S1 \= S.
state_creator(S, go(Prev, Lit)) :-
    user:clause('$aq_go'(Prev, Lit, _), Body),
    body_last(Body, _, Last),
    creates(Last, S1),
    \+ S1 \= S.

fact_only_creator(act).
fact_only_creator(go(Prev, Lit)) :-
    nonvar(Prev), Prev \= q(_),
    nonvar(Lit), Lit \= '$aq_not'(_),
    \+ aq_conf(mode, naive),
    user:'$aq_fact_pred'(Lit),
    waits_on_facts(Prev),
    fact_only_state(Prev).

%   States like P wait on stored facts: the goal that creates them is
%   aq_wait_fact/2.  The literal's predicate having stored facts is not
%   enough: a predicate with rules and facts is waited on through its
%   table, whose answers may depend on the answer being kept (r(Y, X) :-
%   e(X, X), r(Y, X) kept r(1, 0) by itself once its fact went).
waits_on_facts(P) :-
    \+ \+ ( (   user:clause('$aq_act'(_, _), Body)
            ;   user:clause('$aq_go'(_, _, _), Body)
            ),
            body_last(Body, _, Last),
            strip_module(Last, _, aq_wait_fact(_, S)),
            \+ S \= P ).

:- dynamic aq_fact_only/3.

%   The answers of a table with their ranks.
answer_rank(Tr, A, RA) :-
    trie_gen(Tr, A, V),
    RA is abs(V).

%   A new answer is propagated at once (depth-first) unless the propagation
%   is already deep in the local stack (about 4 MB): then it waits on an
%   agenda that the update drains at its end (drain/0), so that a long chain
%   of derivations (left recursion over a long path) does not grow the
%   stacks by frames per answer.  prolog_current_frame/1 is the cheapest
%   depth measure there is (a counter in a global variable costs twice as
%   much per answer).  The loop of propagate/3 is written out: a frame
%   less per answer.
schedule(T, A, RA) :-
    prolog_current_frame(F),
    (   F > 500000
    ->  assertz(aq_agenda(T, A, RA))
    ;   aq_c(T, A, S),
        go(S, A, RA),
        fail
    ;   true
    ).

drain :-
    (   retract(aq_agenda(T, A, RA))
    ->  propagate(T, A, RA),
        drain
    ;   aq_negq(_, _, _, _, _),
        check_next_neg
    ->  drain
    ;   true
    ).

%   Resume every consumer of table T whose literal unifies with answer A.
propagate(T, A, RA) :-
    (   aq_c(T, L, S),
        L = A,
        go(S, L, RA),
        fail
    ;   true
    ).

notify(Id, A) :-
    nb_getval(aq_phase, P),
    notify(P, Id, A).

notify(insert, Id, A) :-            % answers found while registering are
    (   nb_getval(aq_registering, Id)   % read from the table afterwards
    ->  true
    ;   emit(Id, add, A)
    ).
notify(delete, Id, A) :-
    ignore(mark(n(Id, A))).
notify(restore, _, _).

		 /*******************************
		 *            TABLES            *
		 *******************************/

table_for(Lit, S, T, New) :-
    aq_conf(mode, Mode),
    table_for(Mode, Lit, S, T, New).

table_for(tabled, Lit, _, T, New) :-
    nb_getval(aq_subgoals, Sub),
    (   trie_lookup(Sub, Lit, T)
    ->  New = old
    ;   aq_conf(subsumption, true)
    ->  (   subsuming_table(Lit, T)
        ->  New = old
        ;   subgoal_table(Sub, Lit, Lit, shared, T, G),
            functor(G, N, A),
            assertz(aq_tpred(N/A, G, T)),
            New = new(G)
        )
    ;   subgoal_table(Sub, Lit, Lit, shared, T, G),
        New = new(G)
    ).
table_for(optimized, Lit, S, T, new(G)) :-
    owner_id(S, Id),
    new_table(Lit, none, Id, T, G).
table_for(naive, Lit, S, T, New) :-
    owner_id(S, Id),
    (   S = q(_)
    ->  G = Lit
    ;   functor(Lit, N, A), functor(G, N, A)
    ),
    Key = n(Id, G),
    nb_getval(aq_subgoals, Sub),
    (   trie_lookup(Sub, Key, T)
    ->  New = old
    ;   subgoal_table(Sub, G, Key, Id, T, G1),
        New = new(G1)
    ).

subsuming_table(Lit, T) :-
    functor(Lit, N, A),
    aq_tpred(N/A, G, T),
    subsumes_term(G, Lit), !.

owner_id(q(Id), Id) :- !.
owner_id(S, Id) :-
    arg(1, S, T0),
    aq_tab(T0, _, _, Id, _).

%   A table is identified by its answer trie: states carry the trie itself,
%   so propagating an answer needs no table lookup.  G is the table's own
%   copy of Goal, which its rules are activated with.  The caller enters
%   Key (none: a table of its own, the optimized mode) in the subgoals trie.
new_table(Goal, Key, Owner, T, G) :-
    trie_new(T),
    copy_term(Goal, G),
    assertz(aq_tab(T, G, T, Owner, Key)).

%   A new table entered under Key in the subgoals trie Sub.
subgoal_table(Sub, Goal, Key, Owner, T, G) :-
    new_table(Goal, Key, Owner, T, G),
    trie_insert(Sub, Key, T).

		 /*******************************
		 *     UPDATES: ADD, DELETE     *
		 *******************************/

%!  aq_assert(+Fact) is det.
%
%   Add Fact to the stored facts (nothing happens if an identical fact, or
%   for a ground Fact a more general one, is there) and propagate it to
%   every active query it affects.

aq_assert(Fact) :-
    check_fact(Fact),
    (   implied_fact(Fact)
    ->  true
    ;   neg_update(add_fact(Fact))
    ).

add_fact(Fact) :-
    store_fact(Fact),
    drain.

%   Store Fact, not implied by a stored one, and resume what waits on it.
store_fact(Fact) :-
    ( ground(Fact) -> true ; not_all_ground(Fact) ),
    assertz(user:Fact),
    fact_go(Fact).

%!  aq_assert_all(+Facts) is det.
aq_assert_all(Facts) :-
    checked_batch(Facts, Ground),
    (   aq_conf(negation, true)
    ->  maplist(aq_assert, Facts)
    ;   add_facts(Ground, Facts),
        drain
    ).

%   Every fact of a batch is checked before any is changed.  Ground is
%   true for a list of ground facts of stored predicates (the usual batch),
%   each found by the first-argument index of the generated
%   '$aq_ground_fact'/1 (the lookup that the batch's calls of
%   '$aq_add_ground'/1 and '$aq_retract_ground'/3 make again), which tests
%   atomic arguments in line.  Any other batch, and a ground one with an
%   error, is checked fact by fact, which reports the first bad fact.
checked_batch(Facts, Ground) :-
    (   is_list(Facts),
        ground_facts(Facts)
    ->  Ground = true
    ;   ( is_list(Facts) -> true ; must_be(list, Facts) ),
        check_facts(Facts),
        Ground = false
    ).

ground_facts([]).
ground_facts([F|Fs]) :-
    nonvar(F),                          % a variable would unify with a fact of arity 0
    user:'$aq_ground_fact'(F),
    ground_facts(Fs).

%   The facts of a batch, propagated one after the other (depth-first, as
%   far as schedule/3 goes) and the agenda drained once at the end: the
%   order in which additions propagate does not change what they derive.
%   A ground fact is implied by a stored one exactly when calling it
%   succeeds (implied_fact/1), tested in place by the generated
%   '$aq_add_ground'/1 of its predicate, which also resumes the states
%   whose goal records wait on it: a batch of a belief base that few queries
%   watch costs little more than the plain assertz/1s.
%   Without join steps (aq_joins false, or unknown before the first
%   registration) none can become live in the batch, and its facts go to
%   the goal records only; otherwise (eligible too) a fact's propagation
%   may make a step live for the next fact, and each fact asks
%   (fact_go/1).
add_facts(Ground, Facts) :-
    nb_getval(aq_joins, J),
    (   ( J == false ; J == unknown )
    ->  (   Ground == true
        ->  add_ground_facts(Facts)
        ;   add_facts_to_records(Facts)
        )
    ;   add_facts_to_joins(Facts)
    ).

add_ground_facts([]).
add_ground_facts([F|Fs]) :-
    user:'$aq_add_ground'(F),
    add_ground_facts(Fs).

add_facts_to_records([]).
add_facts_to_records([F|Fs]) :-
    (   ground(F)
    ->  user:'$aq_add_ground'(F)
    ;   has_fact(F)
    ->  true
    ;   store_fact(F)
    ),
    add_facts_to_records(Fs).

add_facts_to_joins([]).
add_facts_to_joins([F|Fs]) :-
    (   implied_fact(F) -> true ; store_fact(F) ),
    add_facts_to_joins(Fs).

%!  aq_retract(+Fact) is det.
%
%   Remove Fact (nothing happens if it is not stored) and update every active
%   query by DRed.
aq_retract(Fact) :-
    aq_retract_all([Fact]).

%!  aq_retract_all(+Facts) is det.
%
%   Remove all Facts in one DRed pass.
aq_retract_all(Facts0) :-
    checked_batch(Facts0, Ground),
    neg_update(retract_facts(Ground, Facts0)).

%   Facts that are stored and that some state waits on go through one DRed
%   pass; the others are erased at once.
retract_facts(Ground, Facts0) :-
    quiet_retract(Ground, Facts0, Awaited0),
    sort(Awaited0, Awaited),
    (   Awaited == []
    ->  true
    ;   Awaited = [F],
        retraction_keeps_answers(F)
    ->  erase_fact(F)
    ;   dred(Awaited)
    ).

%   A single retracted ground fact F that states wait on changes no answer
%   when each of them is the last step of its rule (F resumes it to an
%   answer, not to another state), created from stored facts only
%   (fact_only_state/1), and the answer it gives with F has a derivation
%   that F is not part of: a state that is there, also created from facts
%   only, resumed with another stored fact (the seller's offer of the same
%   object at another price).  Then the DRed pass would over-delete nothing
%   (kept_by_facts/2 keeps each such answer) and notify nothing, and F just
%   goes.  No state depends on F: one that was created with F has a
%   predecessor whose goal record waits on F at an earlier step, and that
%   record stops the shortcut; nor does the other derivation depend on an
%   answer (its state comes from facts).  Primary DRed only, while every
%   stored fact is ground and no join step is live (join states wait on F
%   without a goal record).
retraction_keeps_answers(F) :-
    ground(F),
    aq_conf(dred, primary),
    \+ aq_conf(mode, naive),
    \+ nb_getval(aq_joins, true),
    stored_facts_ground,
    \+ ( user:'$aq_wrec'(F, S),
          \+ last_step_kept(F, S) ).

last_step_kept(F, S) :-
    fact_only_state(S),
    once(user:'$aq_final'(A, T, S, fact, F, Check)),
    (   call(Check)
    ->  answer_kept_without(T, A, F)
    ;   true                            % F gives S no answer
    ).

answer_kept_without(T, A, F) :-
    fact_derivation(T, A, without(F)).

%   A fact no state waits on derived nothing: it goes without DRed (most
%   retractions of a belief base that a few queries watch are such facts),
%   and without asking first whether it is stored (erasing a fact that is
%   not there does nothing).  Nothing propagates here, so whether a join
%   step is live is asked once for the batch.
quiet_retract(Ground, Facts, Awaited) :-
    (   nb_getval(aq_joins, true)
    ->  quiet_retract_each(Facts, true, Awaited)
    ;   \+ stored_facts_ground
    ->  quiet_retract_each(Facts, false, Awaited)
    ;   Ground == true
    ->  retract_ground_facts(Facts, Awaited)
    ;   quiet_retract_ground(Facts, Awaited)
    ).

retract_ground_facts([], []).
retract_ground_facts([F|Fs], Awaited) :-
    user:'$aq_retract_ground'(F, Awaited, Awaited1),
    retract_ground_facts(Fs, Awaited1).

%   While every stored fact is ground, a ground fact's two
%   tests and its erasure are the generated '$aq_retract_ground'/3 of its
%   predicate (one call instead of the goal-record test, ground_fact/1 and
%   a meta-call).
quiet_retract_ground([], []).
quiet_retract_ground([F|Fs], Awaited) :-
    (   ground(F)
    ->  user:'$aq_retract_ground'(F, Awaited, Awaited1)
    ;   quiet_retract_each([F], false, Awaited0),
        append(Awaited0, Awaited1, Awaited)
    ),
    quiet_retract_ground(Fs, Awaited1).

%   Joins is true while a join step is live: then a fact some join state
%   waits on goes through DRed too.
quiet_retract_each([], _, []).
quiet_retract_each([F|Fs], Joins, Awaited) :-
    (   \+ user:'$aq_wrec'(F, _),
        \+ ( Joins == true, join_states(F, _) )
    ->  erase_fact(F),
        Awaited = Awaited1
    ;   has_fact(F)
    ->  Awaited = [F|Awaited1]
    ;   Awaited = Awaited1
    ),
    quiet_retract_each(Fs, Joins, Awaited1).

%   Every fact of a batch is checked before any is changed.
check_facts([]).
check_facts([F|Fs]) :-
    (   callable(F), user:'$aq_fact_pred'(F) -> true ; check_fact(F) ),
    check_facts(Fs).

check_fact(F) :-
    (   callable(F), user:'$aq_fact_pred'(F)
    ->  true
    ;   callable(F)
    ->  functor(F, N, A),
        permission_error(modify, static_procedure, N/A)
    ;   type_error(callable, F)
    ).

%   A ground fact that a stored fact already implies adds nothing; calling
%   it is four times cheaper than looking for a stored variant.
implied_fact(F) :-
    (   ground(F)
    ->  once(user:F)
    ;   has_fact(F)
    ).

has_fact(F) :-
    (   ground_fact(F)
    ->  once(user:F)
    ;   once(stored_copy(F, _))
    ).

%   Remove the stored copies of Fact (a variant of it).
erase_fact(F) :-
    (   ground_fact(F)
    ->  (   retract(user:F),            % stops at the first copy, where
            \+ user:F                   % retractall/1 looks at every clause
        ->  true                        % of the index bucket (twice the cost)
        ;   retractall(user:F)
        )
    ;   forall(stored_copy(F, Ref), erase(Ref))
    ).

%   Ref is a stored clause that is a variant of fact F (looked up with a
%   copy: F itself must not be bound by a more specific clause, or e(0, 1)
%   would pass for a copy of e(_, 1)).
stored_copy(F, Ref) :-
    copy_term(F, F1),
    user:clause(F1, true, Ref),
    user:clause(H, true, Ref),
    H =@= F.

%   F is ground and so is every stored fact of its predicate: then F is
%   stored exactly when calling it succeeds, and retractall/1 removes
%   exactly its copies, twice as fast as looking for a variant clause by
%   clause.  Known per predicate after a first scan; a non-ground aq_assert
%   ends it.
ground_fact(F) :-
    ground(F),
    (   stored_facts_ground
    ->  true
    ;   functor(F, N, A),
        (   aq_ground_facts(N, A, B)
        ->  B == true
        ;   functor(G, N, A),
            (   \+ ( user:clause(G, true), \+ ground(G) ) -> B = true ; B = false ),
            assertz(aq_ground_facts(N, A, B)),
            B == true
        )
    ).

stored_facts_ground :-
    nb_getval(aq_ground, All),
    (   All == true
    ->  true
    ;   All \== false,
        resolve_ground(All, Known),
        Known == true
    ).

%   The global aq_ground is true while every stored fact of every dynamic
%   predicate is ground (the usual case: then one global lookup answers
%   ground_fact/1, a fifth of the cost of retracting a fact of a batch),
%   false once one is not (then the flag per predicate decides), unknown
%   until the first scan (at the first registration: warm_fact_indexes/0,
%   or at the first use when the facts are changed before any), and
%   kept(Known, Generations) after aq_reset/0: Known holds while no stored
%   predicate was changed since (the generations of their last changes are
%   the same), else the facts are scanned again.
known_ground(true).
known_ground(false).

resolve_ground(kept(Known, Gens), All) :-
    facts_generations(Gens),
    !,
    All = Known,
    nb_setval(aq_ground, All).
resolve_ground(_, All) :-
    retractall(aq_ground_facts(_, _, _)),
    (   all_facts_ground -> All = true ; All = false ),
    nb_setval(aq_ground, All).

facts_generations(Gens) :-
    findall(G, ( current_predicate(user:'$aq_fact_pred'/1),
                 user:'$aq_fact_pred'(F),
                 predicate_property(user:F, last_modified_generation(G)) ),
            Gens).

%   Stored facts have the body true: calling one with free arguments gives
%   the fact itself (twice as fast as clause/2 over 100k facts).
all_facts_ground :-
    \+ ( current_predicate(user:'$aq_fact_pred'/1),
          user:'$aq_fact_pred'(G),
          user:G,
          \+ ground(G) ).

not_all_ground(F) :-
    functor(F, N, A),
    nb_getval(aq_ground, Known),
    (   known_ground(Known)
    ->  retractall(aq_ground_facts(N, A, _))
    ;   retractall(aq_ground_facts(_, _, _))   % may be stale (kept/2)
    ),
    nb_setval(aq_ground, false),
    assertz(aq_ground_facts(N, A, false)).

mark(Key) :-
    nb_getval(aq_dred, D),
    trie_insert(D, Key).

dred(Facts) :-
    dred_run(over_delete_facts(Facts), maplist(erase_fact, Facts)).

%   DRed from the derivations Seed over-deletes (in phase delete), Cleanup
%   then removing what was deleted (the facts, or a rule's clauses).
%   The phase and the trie are atomic: nb_linkval/2 stores them without the
%   copy nb_setval/2 makes (a DRed pass of one fact sets them six times).
dred_run(Seed, Cleanup) :-
    trie_new(D),
    nb_linkval(aq_dred, D),
    catch(dred_run(Seed, Cleanup, D), E, (dred_end(D), throw(E))),
    dred_end(D).

over_delete_facts(Facts) :-
    nb_getval(aq_dred, D),
    forall(member(F, Facts), ignore(trie_insert(D, f(F)))),
    forall(member(F, Facts), fact_go(F)).

dred_end(D) :-
    (   aq_agenda(_, _, _) -> retractall(aq_agenda(_, _, _)) ; true ),
    nb_linkval(aq_phase, insert),
    nb_linkval(aq_dred, '$none'),
    trie_destroy(D).

%   Phase 1 removes what it over-deletes at once (states, goal and consumer
%   records, answers): removing an item is also what stops a second visit.
%   An answer reached by a deleted derivation of higher rank keeps the one
%   that created it and stays (answer/4); nothing behind it is visited.
%   A derivation whose two premises are both over-deleted is followed from
%   whichever of them goes first, while the other is still there.  D keeps
%   the over-deleted answers that had more than one derivation (a(T, A)),
%   the over-deleted states that had more than one derivation (s(Kind,
%   Literal, State)) and the answers lost by registered queries (n(Id, A)).
dred_run(Seed, Cleanup, D) :-
    % 1. over-delete
    nb_linkval(aq_phase, delete),
    call(Seed),
    drain,
    call(Cleanup),
    % 2. re-derive the answers and states that may have another derivation,
    %    propagate them forward: that also restores the states and
    %    single-derivation answers that depend on them
    nb_linkval(aq_phase, restore),
    forall(trie_gen(D, a(T, A)), ignore(rederive(T, A))),
    forall(trie_gen(D, s(Kind, Lit, S)), ignore(rederive_state(Kind, Lit, S))),
    drain,
    nb_linkval(aq_phase, insert),
    findall(ev(Id, A), trie_gen(D, n(Id, A)), Pending0),
    msort(Pending0, Pending),
    forall(member(ev(Id, A), Pending),
           ( query_has(Id, A) -> true ; emit(Id, delete, A) )).

%   Only answers and states derived more than once are re-derived: one
%   with a single derivation that was over-deleted lost it, and comes back
%   only when the forward propagation of a restored item reaches it.
rederive(T, A) :-
    aq_tab(T, _, _, _, _),
    \+ trie_lookup(T, A, _),
    answer_derivable(T, A, R),
    RA is R + 1,
    answer(restore, T, A, RA).

%   R is the rank of the derivation found.
answer_derivable(T, A, R) :-
    copy_term(A, A1),
    user:'$aq_final'(A1, T, P, Kind, Lit, Check),
    premise(P, Kind, Lit, R),
    call(Check),
    A1 =@= A, !.

%   An over-deleted state that was derived more than once is restored (and
%   propagated forward) when it still has a one-step derivation.  One that
%   is there again (restored by the forward propagation of another
%   candidate) is marked as derived more than once again: the derivation
%   that was not deleted is still there.
rederive_state(Kind, Lit, S) :-
    (   ( state_exists(Kind, Lit, S) ; state_derivable(S) )
    ->  restore_state(Kind, Lit, S)
    ;   true
    ).

state_exists(fact, Lit, S) :-
    has_fact_record(Lit, S).
state_exists(call, _, S) :-
    nb_getval(aq_cstates, St),
    trie_lookup(St, S, _).
state_exists(neg(_, _), '$aq_not'(Lit), S) :-
    nb_getval(aq_nstates, NS),
    trie_lookup(NS, ns(S, Lit), _).

restore_state(fact, Lit, S) :- wait_fact(restore, Lit, S).
restore_state(call, Lit, S) :- wait_call(restore, Lit, S).
restore_state(neg(Kind, Str), '$aq_not'(Lit), S) :- wait_neg(restore, Kind, Lit, S, Str).

%   A one-step derivation of state S from what is there: the generated
%   clause that creates S (the last goal of its body is aq_wait_*(_, S)),
%   either '$aq_go'(Prev, Lit, _) resuming the state Prev with an answer or
%   a fact Lit, or the activation '$aq_act'(Goal, T) of table T; the goals
%   before are the builtins.  S binds Lit and Prev as far as S knows them
%   (the variables of a state include those of its literal and of the state
%   before it), and the premises are found by unification, as for answers
%   (answer_derivable/3): the stored state Prev may be more general (a
%   variable of the head is bound by a later literal).
state_derivable(S) :-
    copy_term(S, S1),
    state_step(S1, P, Kind, Lit, Check),
    premise(P, Kind, Lit, _),
    call(Check),
    S1 =@= S, !.

state_step(S, P, Kind, Lit, Check) :-
    user:clause('$aq_go'(P, Lit, _), Body),
    body_last(Body, Check, Last),
    creates(Last, S),
    (   nonvar(Lit), Lit = '$aq_not'(_)
    ->  Kind = neg
    ;   Kind = call
    ;   user:'$aq_fact_pred'(Lit),
        Kind = fact
    ).
state_step(S, act(T), none, G, Check) :-
    user:clause('$aq_act'(G, T), Body),
    body_last(Body, Check0, Last),
    creates(Last, S),
    Check = (aq_tab(T, G0, _, _, _), G = G0, Check0).

%   The activation of a rule with a body order per adornment picks the
%   order in an if-then-else (If -> Then ; Else): each branch is a body of
%   its own, checked with If or with \+ If.
body_last((A, B), Check, Last) :- !,
    body_last(B, Check0, Last),
    (   Check0 == true -> Check = A ; Check = (A, Check0) ).
body_last((If -> Then ; Else), Check, Last) :- !,
    (   body_last(Then, Check0, Last),
        Test = If
    ;   body_last(Else, Check0, Last),
        Test = (\+ If)
    ),
    (   Check0 == true -> Check = Test ; Check = (Test, Check0) ).
body_last(G, true, G).

creates(_:G, S) :- !, creates(G, S).
creates(aq_wait_fact(_, S), S).
creates(aq_wait_call(_, S), S).
creates(aq_wait_neg(_, _, S, _), S).

premise(act(T), none, _, 0) :- !,
    aq_tab(T, _, _, _, _).
premise(P, fact, Lit, 0) :-
    join_state(P), !,
    user:Lit,
    once(join_states(Lit, P)).
premise(P, fact, Lit, 0) :-       % the fact first: stored facts are indexed on their
    \+ \+ user:'$aq_wrec'(Lit, P),   % bound arguments, goal records often are not; but
    user:Lit,                       % one look at the records first skips a rule whose
    user:'$aq_wrec'(Lit, P).        % states wait elsewhere (another body order)
premise(P, neg, '$aq_not'(Lit), 0) :- !,
    nb_getval(aq_nstates, NS),
    trie_gen(NS, ns(P, Lit), n(Kind, T, passed, _)),
    neg_holds(Kind, Lit, T).
premise(P, call, Lit, R) :-
    nb_getval(aq_cstates, St),
    trie_gen(St, P, V),
    table_of(V, T),
    answer_rank(T, Lit, R).

query_has(Id, A) :-
    aq_q(Id, _, Kind, T),
    (   Kind == call
    ->  trie_lookup(T, A, _)
    ;   has_fact(A)
    ), !.

		 /*******************************
		 *      RULES AT RUN TIME       *
		 *******************************/

%!  aq_add_rule(+Rule) is det.
%
%   Add the rule `H :- B` (checked by rtl_aq_rules: untrusted) and propagate
%   what it derives to every active query: the rule is activated for every
%   table whose goal unifies with H.  Adding a rule that is there already
%   (a variant) does nothing.  A first rule for a predicate with stored facts
%   only makes it a mixed one first (mixed_predicate/1).  Throws aq_rule_error(Message) for a rule that
%   may not be added.
aq_add_rule(Rule0) :-
    copy_term(Rule0, Rule),
    aq_rule_check(Rule, _),
    (   aq_rule(_, R, _), R =@= Rule
    ->  true
    ;   Rule = (H0 :- _),
        mixed_predicate(H0),
        aq_rule_check(Rule, Lits0),             % the kinds of its literals as they are now
        (   aq_conf(mode, naive) -> maplist(as_call, Lits0, Lits) ; Lits = Lits0 ),
        flag(aq_rule_id, N0, N0 + 1),
        N is N0 + 1,
        aq_rule_clauses(Rule, Lits, N, Clauses),
        Rule = (H :- _),
        functor(H, Name, Arity), functor(P, Name, Arity),
        (   user:'$aq_kind'(P, _) -> true ; assertz(user:'$aq_kind'(P, call)) ),
        maplist(assert_clause, Clauses, Refs),
        assertz(aq_rule(N, Rule, Refs)),
        join_steps_changed,
        Clauses = [Act|_],
        neg_update(activate_rule(insert, Act))
    ).

%   A predicate with stored facts only that gets a rule becomes a mixed one, as a dynamic
%   predicate does under XSB's incremental tabling: its literals, resolved in place against
%   the stored facts so far, go through a table from now on, with one more rule that reads
%   its stored facts (the rule the compiler adds for a predicate with rules and facts).  The
%   generated clauses that wait on its facts are rewritten to wait on its table, and the
%   active queries are evaluated again (their answers stay: the predicate's answers are its
%   facts until the new rule is activated).  The naive mode reads every stored predicate
%   through a table already.
mixed_predicate(H) :-
    functor(H, N, A), functor(P, N, A),
    (   \+ aq_conf(mode, naive),
        user:'$aq_kind'(P, fact)
    ->  findall(Id-Old, ( aq_q(Id, _, _, _), aq_answers(Id, Old) ), Olds),
        retract(user:'$aq_kind'(P, fact)),
        assertz(user:'$aq_kind'(P, call)),
        forall(generated_clause(Head), rewrite_waits(P, Head)),
        flag(aq_rule_id, K0, K0 + 1),
        K is K0 + 1,
        aq_rule_clauses((P :- P), [fact(P)], K, Clauses),
        maplist(assert_clause, Clauses, _),
        assertz(aq_mixed(P, K)),
        retractall(aq_fact_only(_, _, _)),
        register_again(Olds)
    ;   true
    ).

generated_clause('$aq_act'(_, _)).
generated_clause('$aq_go'(_, _, _)).
generated_clause('$aq_final'(_, _, _, _, _, _)).

%   Every clause of Head that waits on P's facts, waiting on P's table instead (the clause
%   references of rules added at run time follow).
rewrite_waits(P, Head) :-
    forall(clause(user:Head, Body, Ref),
           (   mixed_head(P, Head, Head1),
               mixed_goal(P, Body, Body1),
               Head1-Body1 \== Head-Body
           ->  assertz(user:(Head1 :- Body1), New),
               erase(Ref),
               forall(( aq_rule(N, R, Refs), memberchk(Ref, Refs) ),
                      ( retract(aq_rule(N, R, Refs)),
                        maplist(replaced_ref(Ref, New), Refs, Refs1),
                        assertz(aq_rule(N, R, Refs1)) ))
           ;   true
           )).

replaced_ref(Old, New, Ref, Ref1) :-
    (   Ref == Old -> Ref1 = New ; Ref1 = Ref ).

mixed_head(P, '$aq_final'(H, T, S, fact, L, C), '$aq_final'(H, T, S, call, L, C)) :-
    of_predicate(L, P), !.
mixed_head(_, Head, Head).

mixed_goal(_, G, G) :- var(G), !.
mixed_goal(P, M:G0, M:G) :- !, mixed_goal(P, G0, G).
mixed_goal(P, (A0, B0), (A, B)) :- !, mixed_goal(P, A0, A), mixed_goal(P, B0, B).
mixed_goal(P, (A0 ; B0), (A ; B)) :- !, mixed_goal(P, A0, A), mixed_goal(P, B0, B).
mixed_goal(P, (A0 -> B0), (A -> B)) :- !, mixed_goal(P, A0, A), mixed_goal(P, B0, B).
mixed_goal(P, aq_wait_fact(L, S), aq_wait_call(L, S)) :- of_predicate(L, P), !.
mixed_goal(P, aq_wait_neg(fact, L, S, Str), aq_wait_neg(call, L, S, Str)) :- of_predicate(L, P), !.
mixed_goal(_, G, G).

of_predicate(L, P) :-
    nonvar(L),
    \+ L \= P.

%!  aq_state_code(+Terms) is det.
%
%   The check of a snapshot's rule code (rtl_state.pl, which reads it as data): every clause
%   of the generated predicates `'$aq_act'/2`, `'$aq_go'/3` and `'$aq_final'/6` among Terms
%   (rtl_state's `clause(user, Head, Body)` terms) is one the loaded program has now, or one
%   that a rule record `aq_rule(N, Rule, _)` of the snapshot compiles to after passing
%   aq_rule_check/2, as a rule added by a script line does. Throws aq_rule_error(Message)
%   otherwise. The predicate kinds of the snapshot's rules are there while they are compiled
%   (and only then: nothing else changes).
aq_state_code(Terms) :-
    findall(N-Rule, member(fact(rtl_aq, aq_rule(N, Rule, _)), Terms), Rules),
    findall(P-K, ( member(clause(user, '$aq_kind'(P, K), true), Terms), \+ user:'$aq_kind'(P, _) ), Kinds),
    findall(P-K, ( member(fact(rtl_aq, aq_mixed(P, K)), Terms), integer(K) ), Mixed),
    setup_call_cleanup(
        foldl(assert_kind, Kinds, [], Refs),
        findall(Hash, ( ( current_code(H, B) ; rules_code(Rules, H, B) ; mixed_code(Mixed, H, B) ),
                        mixed_versions(Mixed, H-B, Hash) ), Hashes0),
        forall(member(Ref, Refs), erase(Ref))),
    sort(Hashes0, Hashes),
    forall(( member(clause(user, H, B), Terms), aq_code_head(H) ),
           (   variant_sha1(H-B, Hash), ord_memberchk(Hash, Hashes)
           ->  true
           ;   functor(H, Name, Arity),
               format(atom(M), 'a clause of ~q is not the code of a rule of the program or of the snapshot', [Name/Arity]),
               throw(aq_rule_error(M))
           )).

%!  aq_state_kinds(+Terms, -Kinds:list) is det.
%
%   The predicate kinds of a snapshot (its `clause(user, '$aq_kind'(P, K), true)` terms), as
%   pairs P-K, each checked: a stored predicate of the program (`'$aq_fact_pred'/1`, as it
%   was compiled) has kind `fact`, or `call` once the snapshot made it mixed (an `aq_mixed`
%   record); any other predicate has kind `call` and is one a rule may define (a rule added
%   at run time gives its head that kind, which stays when the rule is removed).  Only a
%   `fact` literal is ever called (against the stored facts); a `call` literal is answered
%   through a table, by the generated code.  Throws aq_rule_error(Message) otherwise.
aq_state_kinds(Terms, Kinds) :-
    findall(P-K, member(clause(user, '$aq_kind'(P, K), true), Terms), Kinds),
    forall(member(P-K, Kinds),
           (   state_kind_ok(Terms, P, K)
           ->  true
           ;   format(atom(M), 'the snapshot gives ~W the kind ~q, which is not its kind in the program or the snapshot''s rules',
                      [P, [quoted(true), max_depth(4)], K]),
               throw(aq_rule_error(M))
           )).

state_kind_ok(Terms, P, K) :-
    callable(P), P \= _:_,
    functor(P, N, A), functor(P0, N, A), P =@= P0,
    (   user:'$aq_fact_pred'(P0)
    ->  (   K == fact -> true ; K == call, memberchk(fact(rtl_aq, aq_mixed(P1, _)), Terms), P1 =@= P0 )
    ;   K == call,
        (   user:'$aq_kind'(P0, _)
        ->  true
        ;   catch(aq_rule_check((P0 :- true), _), aq_rule_error(_), fail)
        )
    ).

%!  aq_state_literal(+Kinds, +Literal, -Kind) is semidet.
%
%   Literal (a goal of a table, a consumer's or a query's literal, an answer) is an atom of
%   a predicate that has Kind in Kinds (aq_state_kinds/2), or `'$aq_not'(L)` of one (Kind
%   `neg`).  Not a module-qualified goal, not anything else.
aq_state_literal(Kinds, Lit, Kind) :-
    nonvar(Lit),
    (   Lit = '$aq_not'(L)
    ->  aq_state_literal(Kinds, L, _), Kind = neg
    ;   callable(Lit), Lit \= _:_,
        functor(Lit, N, A), functor(P, N, A),
        memberchk(P-Kind, Kinds)
    ).

%!  aq_state_negations(+Kinds, +NStates) is semidet.
%
%   Every entry of the nstates trie of a snapshot (aq_wait_neg/4), `ns(State, Literal)` to
%   `n(Kind, Table, Status, Derivations)`, has a Literal of its Kind (`fact`: a stored
%   predicate, checked against the stored facts; `call`: through Table).
aq_state_negations(Kinds, NS) :-
    forall(trie_gen(NS, K, V),
           (   nonvar(K), K = ns(_, Lit), nonvar(V), V = n(Kind, _, Status, D),
               aq_state_negated(Kinds, Kind, Lit),
               memberchk(Status, [passed, blocked]), integer(D)
           )).

%   A negated literal and how it is checked (neg_holds/3): `fact` only for a stored predicate.
aq_state_negated(Kinds, How, Lit) :-
    atom(How), memberchk(How, [fact, call]),
    aq_state_literal(Kinds, Lit, Kind), Kind \== neg,
    ( How == fact -> Kind == fact ; true ).

assert_kind(P-K, Refs, [Ref|Refs]) :-
    assertz(user:'$aq_kind'(P, K), Ref).

aq_code_head('$aq_act'(_, _)).
aq_code_head('$aq_go'(_, _, _)).
aq_code_head('$aq_final'(_, _, _, _, _, _)).

current_code(H, B) :-
    aq_code_head(H),
    catch(clause(user:H, B), _, fail).

% The clauses that read the stored facts of the predicates a snapshot made mixed
% (mixed_predicate/1), and the hash of each clause as it stands and as each conversion of the
% snapshot rewrote it (the conversions are in the order they happened).
mixed_code(Mixed, H, B) :-
    member(P-K, Mixed),
    aq_rule_clauses((P :- P), [fact(P)], K, Clauses),
    member(C, Clauses),
    (   C = (H :- B) -> true ; H = C, B = true ).

mixed_versions(Mixed, H-B, Hash) :-
    (   variant_sha1(H-B, Hash)
    ;   append(_, [P-_|Later], Mixed),
        mixed_head(P, H, H1),
        mixed_goal(P, B, B1),
        H1-B1 \== H-B,
        mixed_versions(Later, H1-B1, Hash)
    ).

rules_code(Rules, H, B) :-
    member(N-Rule0, Rules),
    (   integer(N), copy_term(Rule0, Rule), catch(aq_rule_check(Rule, Lits0), aq_rule_error(M), true)
    ->  (   nonvar(M)
        ->  format(atom(Message), 'its rule ~q is refused: ~w', [N, M]),
            throw(aq_rule_error(Message))
        ;   true
        )
    ;   throw(aq_rule_error('a rule record of the snapshot is not a rule'))
    ),
    (   aq_conf(mode, naive) -> maplist(as_call, Lits0, Lits) ; Lits = Lits0 ),
    aq_rule_clauses(Rule, Lits, N, Clauses),
    member(C, Clauses),
    (   C = (H :- B) -> true ; H = C, B = true ).

%   The steps of the join states (join_step/4) as the clauses are now.
join_steps_changed :-
    (   nb_getval(aq_joins, unknown) -> true ; find_join_steps ).

as_call(fact(G), call(G)) :- !.
as_call(L, L).

assert_clause(C, Ref) :- assertz(user:C, Ref).

%   Run the activation clause of a rule for every table it applies to.
activate_rule(Phase, Act) :-
    nb_setval(aq_phase, Phase),
    (   Act = ('$aq_act'(H, T) :- Body) -> true ; Act = '$aq_act'(H, T), Body = true ),
    forall(aq_tab(Tab, G, _, _, _),
           ( copy_term(H-T-Body, H1-T1-Body1),
             (   copy_term(G, G1), G1 = H1
             ->  T1 = Tab, ignore(user:Body1)
             ;   true
             ) )),
    (   Phase == insert -> drain ; true ).

%!  aq_remove_rule(+Rule) is det.
%
%   Remove a rule added by aq_add_rule/1 (a variant of it) and update every
%   active query by DRed: what the rule derived is over-deleted, the rule's
%   clauses go, and what has another derivation is derived again.  Throws
%   aq_rule_error(Message) when no such rule was added.
aq_remove_rule(Rule) :-
    (   aq_rule(N, R, Refs), R =@= Rule
    ->  clause(aq_rule(N, _, _), true, RuleRef),
        Refs = [ActRef|_],
        clause(user:AH, AB, ActRef),
        neg_update(dred_run(activate_rule(delete, (AH :- AB)),
                            ( maplist(erase, Refs), erase(RuleRef) ))),
        join_steps_changed
    ;   throw(aq_rule_error('no such rule was added (only rules added at run time can be removed)'))
    ).
