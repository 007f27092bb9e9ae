:- module(rtl_state,
          [ rtl_state_save/2,           % +File, +Identity
            rtl_state_save/3,           % +File, +Identity, +Program
            rtl_state_restore/2,        % +File, +Identity
            rtl_state_restore/3,        % +File, +Identity, +Program
            rtl_state_capture/1,        % -State
            rtl_state_digest/1,         % -Hash
            rtl_state_digest/2          % +Program, -Hash
          ]).

/** <module> Snapshots of the runtime state, for restarts that lose nothing

A snapshot holds what the runtime and the running program keep between two input events,
as data: the facts of the predicates and the values of the global variables the runtime
declares as state below (state_predicate/2, state_global/2: the one list save and restore
both use), the rules added at run time and deleted since the load (rtl_rules_state/3), the
answer tables (tries) and the flag/3 counters (`rtl_`, `aq_`). Nothing in a snapshot is
code: a clause body, a directive or a goal is never read from it and run. Restore reads the
whole file with read_term/3 (no operators, no expansion, nothing called), checks every term
against the declaration of its predicate or global (its module, name, arity and argument
types: a goal held in the state, as a subscription condition or a timer, must be a call of
the program's own predicates or pass the check of untrusted goals, rtl_check_goal/3, as it
did when it came in; a rule added at run time passes rtl_check_rule/4 again) and only then
changes the state. A snapshot of another format version or identity, or with anything
else in it, is refused with `error(rtl_state_error(Message), _)` and nothing changes.

The program is the event program of rtl_program/1, whose state is the facts of the
partial-match stores of its rules (ele_partial_store/2), or one given as `Module-PIs` to the
/3 forms: an active-query program (rtl_aq_api.pl) keeps its facts, goal records, predicate
kinds and generated rule code in `user` and names those predicates; a snapshot's kinds
(rtl_aq:aq_state_kinds/2) and code (rtl_aq:aq_state_code/1) are checked against the program
and the snapshot's rule records, and the literals of the rtl_aq records against those kinds.
The program's module name may differ (an Engine loaded second in a process): its occurrences
are renamed.

Tries are written as their entries and made again on restore, shared where they were
shared. A clause reference (the clauses of a rule added to active queries at run time) is
written as the predicate and position of its clause and found again on restore. Other blobs
(streams) cannot be written: a global holding one is skipped, a clause holding one makes the
save fail with an error.

The file is text, one term a line (rtl_write_readable/2 of rtl_text.pl): `rtl_state(Version, Identity,
Module)`, `rules(Added, Removed)`, `trie(Id, Entries)` per trie, `fact(Module, Head)` per
fact (those holding clause references last), `clause(Module, Head, Body)` for the named
predicates of an active-query program, `global(Key, Value)`, `flag(Key, Value)` and
`end(Count)`, Count the number of terms between the first and the last. Identity is given
by the caller (a hash of the compiled program and of the runtime, recovery.py). The caller
makes the write atomic (temporary file, fsync, rename) and checks a checksum before
restoring (retalisc/driver/recovery.py).
*/

:- use_module(rtl_error_text, [rtl_error_text/2]).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(pairs)).
:- use_module(rtl_ele).
:- use_module(rtl_rules, [rtl_rules_state/3, rtl_rules_check_state/4, rtl_rules_restore_state/3]).
:- use_module(rtl_sandbox, [rtl_check_goal/4]).
:- use_module(rtl_io, [rtl_too_deep_text/2]).
:- use_module(rtl_slr, [rtl_slr_type_hook/1, rtl_slr_watch_predicate/1]).
:- use_module(library(readutil)).
:- use_module(rtl_text, [rtl_write_readable/2]).
:- use_module(rtl_seen, [rtl_seen_owner/2, rtl_seen_fresh_module/1]).

state_version(2).

% ---- the declaration of the state: what a snapshot holds ---------------------------------

%!  state_predicate(?Module, ?Head) is nondet.
%
%   The facts of Module:Head are state; Head's arguments are the types of theirs (arg_ok/4).
%   Not state (not declared): what belongs to the process rather than to the stream (output
%   sinks, open streams, the values of one call, caches, the hooks of other code).
%   Besides these, the partial-match stores of the program's rules (ele_partial_store/2),
%   the events of the generations of rtl_seen.pl (`rtl_seen_<N>:seen/3`, `seen_atomic/1`),
%   the watch predicates of rtl_slr.pl (`'$slr_watch Name/Arity'/3`) and the predicates an
%   active-query program names are state (family_predicate/4). An argument of type
%   `this_program` makes a fact the program's own: a snapshot holds those of its program
%   only, and a restore replaces those only (the seen store of rtl_seen.pl is per program).

state_predicate(rtl_flags, flag_value(atom, data)).
state_predicate(rtl_ele, output_hook(output_hook)).
state_predicate(rtl_ele, type_output_hook(data, type_output_hook)).
state_predicate(rtl_event_types, known_type(atom, integer)).
state_predicate(rtl_seen, generation(this_program, seen_module, data)).
state_predicate(rtl_seen, free_generation(this_program, seen_module)).
state_predicate(rtl_slr, instance(integer, program, data, data, conditions, data, data, data, data)).
state_predicate(rtl_slr, id_handle(program, data, integer)).
state_predicate(rtl_slr, watch_predicate(atom, integer, watch_predicate)).
state_predicate(rtl_slr, record(integer, data, data, data)).
state_predicate(rtl_slr, stream_memory(data, data, data, data)).
state_predicate(rtl_slr, need(data, data)).
state_predicate(rtl_slr, expiry(integer, program, data)).
state_predicate(rtl_slr, bounds_name(integer, bounds_global)).
state_predicate(rtl_subscriptions, subscription(program, data, atom, data, conditions, data, data, data)).
state_predicate(rtl_subscriptions, by_key(integer, program, atom, integer, integer, data, atom)).
state_predicate(rtl_subscriptions, by_mask(program, atom, integer, integer, integer)).
state_predicate(rtl_sync, pending(integer, data, goal, data, data, data)).
state_predicate(rtl_sync, condition(integer, data, data, data)).
state_predicate(rtl_sync, call_monitor(data, integer)).
state_predicate(rtl_sync, declared_delay(program, atom, integer, data)).
state_predicate(rtl_sync, learned_delay(program, atom, integer, data)).
state_predicate(rtl_sync, updated_until(program, atom, integer, data)).
state_predicate(rtl_sync, goal_set_of(program, atom, integer, data, data)).
state_predicate(rtl_tf, buffer_ns(program, integer)).           % the tree itself: state_data/4
state_predicate(rtl_tf, waiting(program, data, data, data, data, data, goal)).
state_predicate(rtl_time_index, entry(data, data, data, data, data)).
state_predicate(rtl_time_index, low_bucket(data, data, data, data)).
state_predicate(rtl_timers, timer(data, data, data, goal)).
state_predicate(rtl_trace, logged(data, data, data, data, data, data)).
state_predicate(rtl_trace, traced_store(program, atom, data, data, data)).
state_predicate(rtl_trace, traced_head(data, data)).
state_predicate(rtl_trace, trace_count(data, data, data)).
state_predicate(rtl_trace, late_rule(data, data, data)).
state_predicate(rtl_rules, removed_rule(program, atom)).
%   The records of active queries (rtl_aq.pl): a literal (aq_literal) is an atom of a
%   predicate of the program or of the snapshot's rules (rtl_aq:aq_state_literal/3); what is
%   called against the stored facts (a query or negation of kind `fact`) is of a stored one.
state_predicate(rtl_aq, aq_tab(data, aq_literal, data, data, data)).
state_predicate(rtl_aq, aq_tpred(data, aq_literal, data)).
state_predicate(rtl_aq, aq_c(data, aq_literal, data)).
state_predicate(rtl_aq, aq_agenda(data, aq_literal, data)).
state_predicate(rtl_aq, aq_q(data, aq_query_goal, atom, data)).
state_predicate(rtl_aq, aq_negq(integer, atom, aq_negated, data, data)).
state_predicate(rtl_aq, aq_join_step(aq_literal, data, aq_literal, data)).
state_predicate(rtl_aq, aq_join_eligible(aq_literal, data, aq_literal, data)).
state_predicate(rtl_aq, aq_mixed(aq_stored_predicate, integer)).
state_predicate(rtl_aq, aq_conf(atom, aq_option_value)).
state_predicate(rtl_aq, aq_ev(data, aq_event_op, data)).      % notified: Op(Answer)
state_predicate(rtl_aq, aq_buf(data, aq_event_op, data)).
state_predicate(rtl_aq, Head) :-
    member(Name/Arity, [aq_ground_facts/3, aq_warm/3, aq_dead/1,
                        aq_join_state/1, aq_join_consumers/3, aq_join_off/2, aq_fact_only/3]),
    length(Types, Arity),
    maplist(=(data), Types),
    Head =.. [Name|Types].
state_predicate(rtl_aq, aq_hook(kept)).
state_predicate(rtl_aq, aq_rule(data, data, clause_refs)).     % the clauses of a run-time rule

%!  state_global(?Key, ?Type) is nondet.
%
%   The global variables (nb_setval/2) that are state, and the type of their values; keys
%   `'rtl_detected <Rule>'` and `'$rtl_slr_bounds_<N>'` too (global_family/2), and the
%   counters of rtl_flags.pl (`rtl_stat_events`, `rtl_stat_derived`, ...: rtl_stat_global/2).

state_global(Key, data) :-
    member(Key, [rtl_blockers_swept_by_type, rtl_clock, rtl_complete_since, rtl_detection_labels,
                 rtl_dry_run, rtl_echo_input, rtl_horizon, rtl_kept_generation, rtl_kept_generations,
                 rtl_kept_rotated, rtl_largest_window, rtl_late_before, rtl_late_delay,
                 rtl_late_sweep, rtl_latest_start, rtl_longest_by_type, rtl_made_mode, rtl_max_steps, rtl_next_sweep,
                 rtl_next_timer, rtl_output_hooks, rtl_paced_rest, rtl_raised, rtl_replay_position,
                 rtl_retract_position, rtl_rule_counter, rtl_seen_size, rtl_subscription_counter,
                 rtl_slr_next_expiry, rtl_sweep_after, rtl_trace_line, rtl_trace_line_seen, rtl_trace_phase,
                 rtl_trace_seq, rtl_trace_text,
                 aq_buffer, aq_cstates, aq_dred, aq_ground, aq_joins, aq_phase,
                 aq_registering, aq_subgoals]).
state_global(aq_nstates, aq_nstates).     % its entries' negated literals are called
state_global(rtl_seen_generation, seen_module).
state_global(Key, integer) :-
    rtl_stat_global(_, Key).

%!  state_data(?Module, ?Dump, ?Check, ?Load) is nondet.
%
%   State that Module keeps outside the Prolog database (the tf library's C store), as
%   data: call(Module:Dump, Terms) gives it as a list of ground terms (written one a line,
%   `data(Module, Term)`); on restore call(Module:Check, Terms) succeeds for the snapshot's
%   terms of Module (else the snapshot is refused and nothing changes), and once the rest of
%   the state is in place call(Module:Load, Terms) replaces the held state by them.

state_data(rtl_tf, tf_state_dump, tf_state_check, tf_state_load).

global_family('rtl_detected ', data).
global_family('$rtl_slr_bounds_', data).

% The hooks the runtime registers (rtl_add_output_hook/1, rtl_add_type_output_hook/2).
state_hook(rtl_subscriptions:deliver).
state_hook(rtl_sync:clock_moved).
state_hook(rtl_tf:observe).
state_hook(rtl_tf:clock_moved).
state_hook(rtl_sync:availability).
state_hook(rtl_trace:log_event).
state_hook(rtl_trace:trace_phase).
state_hook(rtl_trace:late_event).

% family_predicate(+Context, ?Module, ?Name, ?Arity): state predicates named by other state.
family_predicate(ctx(M, _, Stores, _, _), M, Name, Arity) :-
    member(Name/Arity, Stores).
family_predicate(_, Module, seen, 3) :- seen_module(Module).
family_predicate(_, Module, seen_atomic, 1) :- seen_module(Module).
family_predicate(_, rtl_slr, Name, 3) :- watch_name(Name).

family_types(_, _, seen, [data, data, data]) :- !.
family_types(_, _, seen_atomic, [data]) :- !.
family_types(_, rtl_slr, _, [data, program, integer]) :- !.
family_types(_, _, _, Types) :- Types = any.           % a store of the program: data

seen_module(Module) :-
    atom(Module),
    atom_concat(rtl_seen_, Digits, Module),
    atom_codes(Digits, Codes), Codes \== [],
    forall(member(C, Codes), code_type(C, digit)).

watch_name(Name) :-
    rtl_slr_watch_predicate(Name).

% ---- saving ----------------------------------------------------------------------------

% program(-Program): the event program, M-all (its state: the stores of its rules).
program(M-all) :-
    rtl_program(M), !.
program(_) :-
    state_error("no program is loaded", []).

%!  rtl_state_save(+File, +Identity) is det.
%!  rtl_state_save(+File, +Identity, +Program) is det.
%
%   Write the state to File (created or overwritten), tagged with Identity (any ground
%   term): that of the event program, or of Program, `Module-all` or `Module-PIs` (a list
%   of Name/Arity: the state predicates of Module).

rtl_state_save(File, Identity) :-
    program(Program),
    rtl_state_save(File, Identity, Program).

rtl_state_save(File, Identity, Program) :-
    state_version(V),
    setup_call_cleanup(open(File, write, Out, [encoding(utf8)]),
                       write_state(Out, V, Identity, Program),
                       close(Out)).

write_state(Out, V, Identity, Program) :-
    Program = M-_,
    write_term_line(Out, rtl_state(V, Identity, M)),
    saved_modules(Program, Modules),
    rules_state(Program, Added, Removed),
    empty_assoc(T0),
    captured_predicates(Program, PIs),
    catch(foldl(clause_terms(Program), PIs, PredTerms, T0-0, S1),
          rtl_state_unwritable(PI, Blob),
          state_error("~q holds ~p, which a snapshot cannot hold", [PI, Blob])),
    captured_globals(Globals0),
    unblob_globals(Globals0, Globals, S1, S2),
    trie_entries(S2, TrieEntries),
    captured_flags(Flags),
    pairs_keys_values(PIsTerms, PIs, PredTerms),
    partition(plain_predicate, PIsTerms, Plain0, WithRefs0),
    pairs_values(Plain0, Plain),
    pairs_values(WithRefs0, WithRefs),
    Terms = [modules(Modules), rules(Added, Removed)|Rest],
    findall(trie(Id, Es), member(Id-Es, TrieEntries), Tries),
    findall(global(K, Val), member(K-Val, Globals), GlobalTerms),
    findall(flag(K, Val), member(K-Val, Flags), FlagTerms),
    findall(data(Mod, T), ( state_data(Mod, Dump, _, _), current_module(Mod), call(Mod:Dump, Ts), member(T, Ts) ),
            DataTerms),
    append(Plain, WithRefs, Facts0),               % clause references point into the others
    append(Facts0, Facts),
    append([Tries, Facts, GlobalTerms, FlagTerms, DataTerms], Rest),
    forall(member(T, Terms), write_term_line(Out, T)),
    length(Terms, Count),
    write_term_line(Out, end(Count)).

write_term_line(Out, Term) :-
    rtl_write_readable(Out, Term),
    write(Out, '.\n').

% Clause references are in the arguments declared `clause_refs` only.
plain_predicate(M:Name/Arity-_) :-
    \+ refs_predicate(M, Name, Arity).

refs_predicate(M, Name, Arity) :-
    functor(Decl, Name, Arity),
    state_predicate(M, Decl),
    arg(_, Decl, clause_refs), !.

% The declared modules loaded now: the snapshot replaces the state of these.
saved_modules(M-_, Modules) :-
    findall(Module, ( state_predicate(Module, _), current_module(Module) ), Modules0),
    sort([M|Modules0], Modules).

rules_state(M-all, Added, Removed) :- !,
    rtl_rules_state(M, Added, Removed).
rules_state(_, [], []).

% The terms of the clauses of PI: fact(M, Head), or clause(M, Head, Body) for a predicate an
% active-query program names.
clause_terms(Program, M:Name/Arity, Terms, S0, S) :-
    functor(H, Name, Arity),
    findall(H-B, clause(M:H, B), Clauses0),
    (   catch(fast_term_serialized(Clauses0, _), error(permission_error(fast_serialize, blob, _), _), fail)
    ->  Clauses = Clauses0, S = S0
    ;   catch(unblob(Clauses0, Clauses, S0, S), rtl_state_unwritable(Blob),
              throw(rtl_state_unwritable(M:Name/Arity, Blob)))
    ),
    (   Program = M-Which, Which \== all, memberchk(Name/Arity, Which)
    ->  findall(clause(M, H1, B1), member(H1-B1, Clauses), Terms)
    ;   Program = P-_,
        findall(fact(M, H1), ( member(H1-B1, Clauses), fact_body(M:Name/Arity, B1), own_fact(P, M, H1) ), Terms)
    ).

% A fact with a `this_program` argument belongs to that program.
own_fact(P, M, Head) :-
    (   this_program_arg(M, Head, I)
    ->  arg(I, Head, P0), P0 == P
    ;   true
    ).

this_program_arg(M, Head, I) :-
    functor(Head, Name, Arity),
    functor(Decl, Name, Arity),
    state_predicate(M, Decl),
    arg(I, Decl, this_program), !.

fact_body(PI, Body) :-
    (   Body == true -> true
    ;   state_error("~q has a clause with a body, which is not state", [PI])
    ).

captured_predicates(Program, PIs) :-
    Program = M-Which,
    findall(M:Name/Arity, ( Which \== all, member(Name/Arity, Which) ), Named),
    (   Which == all
    ->  findall(Name/Arity, current_store(M, Name, Arity), Stores)
    ;   Stores = []
    ),
    findall(Module:Name/Arity,
            (   state_predicate(Module, Head), current_module(Module),
                functor(Head, Name, Arity)
            ;   member(Name/Arity, Stores), Module = M
            ;   Program = P-_, rtl_seen_owner(Module, P), current_module(Module),
                member(Name/Arity, [seen/3, seen_atomic/1])
            ;   Module = rtl_slr, current_predicate(rtl_slr:Name/3), watch_name(Name), Arity = 3
            ),
            PIs0),
    append(Named, PIs0, PIs1),
    include(existing_dynamic, PIs1, PIs2),
    sort(PIs2, PIs).

existing_dynamic(M:Name/Arity) :-
    functor(H, Name, Arity),
    current_predicate(M:Name/Arity),
    predicate_property(M:H, dynamic),
    \+ predicate_property(M:H, imported_from(_)).

current_store(M, Name, Arity) :-
    current_predicate(M:ele_partial_store/2),
    M:ele_partial_store(Name, Arity).

captured_globals(Pairs) :-
    findall(K-V, ( nb_current(K, V), atom(K), declared_global(K, _) ), Pairs0),
    keysort(Pairs0, Pairs).

declared_global(K, Type) :-
    (   state_global(K, Type0) -> Type = Type0
    ;   global_family(Prefix, Type), sub_atom(K, 0, _, _, Prefix)
    ->  true
    ).

captured_flags(Pairs) :-
    findall(K-V, ( current_flag(K), atom(K), flag_key(K), flag(K, V, V), V \== 0 ), Pairs0),
    keysort(Pairs0, Pairs).

flag_key(K) :-
    (   sub_atom(K, 0, _, _, rtl_) -> true ; sub_atom(K, 0, _, _, aq_) ).

% The entries of every trie met, with the tries inside them replaced as well (an entry may
% hold a trie, which is then written too). Tries get their ids in the order they are met:
% the tries with ids From..N-1 are written in one round, which may meet new ones (ids from
% N on) for the next round.
trie_entries(S, Entries) :-
    trie_entries(S, 0, Entries).

trie_entries(S0-N0, From, Entries) :-
    (   From >= N0
    ->  Entries = []
    ;   assoc_to_list(S0, All),
        findall(Id-Trie, ( member(Trie-Id, All), Id >= From ), Round0),
        keysort(Round0, Round),
        foldl(trie_round, Round, Entries0, S0-N0, S1),
        append(Entries0, Rest, Entries),
        trie_entries(S1, N0, Rest)
    ).

trie_round(Id-Trie, Id-Es, S0, S) :-
    findall(K-Val, trie_gen(Trie, K, Val), Es0),
    unblob(Es0, Es, S0, S).

unblob_globals([], [], S, S).
unblob_globals([K-V0|Gs0], Gs, S0, S) :-
    (   catch(fast_term_serialized(V0, _), error(permission_error(fast_serialize, blob, _), _), fail)
    ->  Gs = [K-V0|Gs1], S1 = S0
    ;   catch(unblob(V0, V, S0, S1), rtl_state_unwritable(_), fail)
    ->  Gs = [K-V|Gs1]
    ;   Gs = Gs1, S1 = S0                       % a stream or another handle: not state
    ),
    unblob_globals(Gs0, Gs1, S1, S).

% unblob(+Term, -Copy, +Tries0-Next0, -Tries-Next): Copy is Term with every trie replaced
% by '$rtl_trie'(Id) and every clause reference by '$rtl_clause'(Module:Name/Arity, Index).
unblob(T, T, S, S) :-
    var(T), !.
unblob(T, T, S, S) :-
    plain_atomic(T), !.
unblob(T, C, S0-N0, S) :-
    blob(T, Type), Type \== text, !,
    (   Type == trie
    ->  (   get_assoc(T, S0, Id)
        ->  S = S0-N0
        ;   Id = N0, N is N0 + 1, put_assoc(T, S0, Id, S1), S = S1-N
        ),
        C = '$rtl_trie'(Id)
    ;   Type == clause, clause_position(T, C0)
    ->  C = C0, S = S0-N0
    ;   throw(rtl_state_unwritable(T))
    ).

unblob(T, T, S, S) :-
    atomic(T), !.
unblob(T, C, S0, S) :-
    compound_name_arguments(T, Name, Args),
    foldl(unblob, Args, CArgs, S0, S),
    compound_name_arguments(C, Name, CArgs).

% The predicate of a (live) clause reference and the position of its clause there.
clause_position(Ref, '$rtl_clause'(M:Name/Arity, Index)) :-
    \+ clause_property(Ref, erased),
    clause_property(Ref, predicate(PI)),
    (   PI = M:Name/Arity -> true ; PI = Name/Arity, M = user ),
    functor(H, Name, Arity),
    nth_clause(M:H, Index, Ref).

% ---- restoring ------------------------------------------------------------------------

%!  rtl_state_restore(+File, +Identity) is det.
%!  rtl_state_restore(+File, +Identity, +Program) is det.
%
%   Replace the state by the one saved in File. Raises
%   `error(rtl_state_error(Message), _)` (Message a string) and changes nothing when the
%   file is not a complete snapshot of this version and Identity, or holds anything that is
%   not declared state of the right shape.

rtl_state_restore(File, Identity) :-
    program(Program),
    rtl_state_restore(File, Identity, Program).

rtl_state_restore(File, Identity, Program) :-
    read_snapshot(File, Terms),
    check_snapshot(Terms, Identity, Program, Plan),
    apply_state(Plan),
    rtl_dispatch_changed.

read_snapshot(File, Terms) :-
    catch(setup_call_cleanup(open(File, read, In, [encoding(utf8)]),
                             read_terms(In, Terms),
                             close(In)),
          E,
          (   E = error(rtl_state_error(_), _)
          ->  throw(E)
          ;   rtl_error_text(E, Text),
              state_error("not a readable snapshot: ~s", [Text])
          )).

% Data only: read_term/3 runs nothing (no directives, no term expansion) and uses no
% operator of the snapshot's; it makes neither cyclic terms nor attributed variables. Each
% line is read by itself, one term (rtl_write_readable/2 writes none over two lines), so that
% a line nested deeper than snapshot_max_depth/1 is refused before it is read (the reader
% recurses on the C stack).
read_terms(In, Terms) :-
    snapshot_max_depth(MaxDepth),
    read_terms(In, MaxDepth, Terms).

read_terms(In, MaxDepth, Terms) :-
    read_line_to_string(In, Line),
    (   Line == end_of_file
    ->  Terms = []
    ;   rtl_too_deep_text(Line, MaxDepth)
    ->  state_error("the snapshot holds a term nested deeper than ~D levels", [MaxDepth])
    ;   setup_call_cleanup(open_string(Line, LineIn), line_term(LineIn, T), close(LineIn)),
        (   T == end_of_file
        ->  read_terms(In, MaxDepth, Terms)
        ;   acyclic_term(T), term_attvars(T, [])
        ->  Terms = [T|Rest],
            read_terms(In, MaxDepth, Rest)
        ;   state_error("the snapshot holds a cyclic term or an attributed variable", [])
        )
    ).

line_term(In, T) :-
    read_term(In, T, [syntax_errors(error), double_quotes(string), back_quotes(codes),
                      module(rtl_state)]),
    (   at_end_of_stream(In) -> true
    ;   state_error("the snapshot has a line with more than one term", [])
    ).

%   How deep a term of a snapshot may be: the input events (max_term_depth) with the
%   runtime's own nesting around them.
snapshot_max_depth(MaxDepth) :-
    rtl_flag(max_term_depth, EventDepth),
    MaxDepth is EventDepth + 1000.

check_snapshot(Terms, Identity, Program, Plan) :-
    state_version(V),
    (   Terms = [rtl_state(V0, Identity0, OldM)|Body], atom(OldM)
    ->  true
    ;   state_error("not a retalisc snapshot", [])
    ),
    (   V0 == V -> true
    ;   state_error("the snapshot has format version ~q, this runtime reads version ~w", [V0, V])
    ),
    (   Identity0 == Identity -> true
    ;   state_error("the snapshot was made by another program or runtime version (~q, not ~q)",
                    [Identity0, Identity])
    ),
    (   append(Middle, [end(Count)], Body),
        length(Middle, Count),
        Middle = [modules(Modules0), rules(Added0, Removed0)|Rest]
    ->  true
    ;   state_error("the snapshot is incomplete", [])
    ),
    Program = M-Which,
    rename(OldM, M, Modules0-Added0-Removed0, Modules-Added-Removed),
    (   is_list(Modules),
        forall(member(Mod, Modules), ( Mod == M ; state_predicate(Mod, _) ))
    ->  true
    ;   state_error("its modules ~q are not modules of the runtime's state", [Modules])
    ),
    (   Which == all
    ->  catch(rtl_rules_check_state(M, Added, Removed, Stores), rtl_rules_state(F, A),
              state_error(F, A))
    ;   Added-Removed == []-[]
    ->  Stores = []
    ;   state_error("an active-query snapshot holds no event rules", [])
    ),
    partition(data_term, Rest, DataTerms, Rest1),
    partition_terms(Rest1, TrieTerms, FactTerms, GlobalTerms, FlagTerms),
    check_data(DataTerms, Modules, Data),
    new_tries(TrieTerms, OldM, M, Map),
    (   Which == all                    % active queries of this process keep their code
    ->  findall(P-K, ( current_predicate(user:'$aq_kind'/2), user:'$aq_kind'(P, K) ), Kinds)
    ;   catch(rtl_aq:aq_state_kinds(FactTerms, Kinds), aq_rule_error(Why0), state_error("~w", [Why0]))
    ),
    Ctx = ctx(M, Which, Stores, Modules, Kinds),
    empty_assoc(NoTypes),
    foldl(check_fact(Ctx, Map), FactTerms, Facts0, NoTypes, _),
    check_clause_references(Facts0),
    (   Which == all
    ->  true
    ;   catch(rtl_aq:aq_state_code(Facts0), aq_rule_error(Why), state_error("~w", [Why]))
    ),
    maplist(check_global(Ctx, Map), GlobalTerms, Globals0),
    maplist(check_flag, FlagTerms, Flags),
    seen_modules_placed(M, Facts0, Globals0, Facts, Globals),
    Plan = plan(M, Which, Modules, Added, Removed, Facts, Globals, Flags, Map, Data).

% The generation modules of the snapshot's seen store (rtl_seen.pl): each holding events is
% one of the program's generations in the snapshot, and one another program of this process
% holds is given a fresh name.
seen_modules_placed(M, Facts0, Globals0, Facts, Globals) :-
    findall(G, ( member(fact(rtl_seen, H), Facts0), ( H = generation(_, G, _) ; H = free_generation(_, G) ) ),
            Named0),
    (   memberchk(rtl_seen_generation-Open, Globals0), Open \== [] -> Named1 = [Open|Named0] ; Named1 = Named0 ),
    msort(Named1, NamedAll),
    sort(NamedAll, Named),
    (   NamedAll \== Named
    ->  state_error("the snapshot names a generation of the seen store twice", [])
    ;   member(fact(SM, _), Facts0), seen_module(SM), \+ memberchk(SM, Named)
    ->  state_error("the snapshot holds events of ~q, which is not a generation of its program", [SM])
    ;   true
    ),
    findall(G-New, ( member(G, Named), rtl_seen_owner(G, P), P \== M, rtl_seen_fresh_module(New) ), Renames),
    (   Renames == []
    ->  Facts = Facts0, Globals = Globals0
    ;   maplist(seen_renamed(Renames), Facts0, Facts),
        maplist(seen_renamed(Renames), Globals0, Globals)
    ).

seen_renamed(Renames, fact(SM, H), fact(SM1, H1)) :- !,
    renamed_module(Renames, SM, SM1),
    (   H = generation(P, G, E) -> renamed_module(Renames, G, G1), H1 = generation(P, G1, E)
    ;   H = free_generation(P, G) -> renamed_module(Renames, G, G1), H1 = free_generation(P, G1)
    ;   H1 = H
    ).
seen_renamed(Renames, rtl_seen_generation-G, rtl_seen_generation-G1) :- !,
    renamed_module(Renames, G, G1).
seen_renamed(_, T, T).

renamed_module(Renames, G, G1) :-
    (   atom(G), memberchk(G-G1, Renames) -> true ; G1 = G ).

data_term(data(_, _)).

% check_data(+DataTerms, +Modules, -Data): Mod-Terms for each module of state_data/4 the
% snapshot replaces, its terms checked by its Check.
check_data(DataTerms, Modules, Data) :-
    (   member(data(Mod, _), DataTerms), \+ ( state_data(Mod, _, _, _), memberchk(Mod, Modules) )
    ->  state_error("the snapshot holds data of ~q, which is not state", [Mod])
    ;   true
    ),
    findall(Mod-Check-Ts,
            ( state_data(Mod, _, Check, _), memberchk(Mod, Modules),
              findall(T, member(data(Mod, T), DataTerms), Ts) ),
            Data0),
    forall(member(Mod-Check-Ts, Data0),
           (   ground(Ts), catch(call(Mod:Check, Ts), _, fail)
           ->  true
           ;   state_error("the snapshot's data of ~q is not its state", [Mod])
           )),
    findall(Mod-Ts, member(Mod-_-Ts, Data0), Data).

rename(OldM, NewM, T0, T) :-
    empty_assoc(None),
    reblob_(T0, T, OldM, NewM, None).

partition_terms([], [], [], [], []).
partition_terms([T|Ts], Tries, Facts, Globals, Flags) :-
    (   T = trie(_, _) -> Tries = [T|Tries1], partition_terms(Ts, Tries1, Facts, Globals, Flags)
    ;   ( T = fact(_, _) ; T = clause(_, _, _) )
    ->  Facts = [T|Facts1], partition_terms(Ts, Tries, Facts1, Globals, Flags)
    ;   T = global(_, _) -> Globals = [T|Globals1], partition_terms(Ts, Tries, Facts, Globals1, Flags)
    ;   T = flag(_, _) -> Flags = [T|Flags1], partition_terms(Ts, Tries, Facts, Globals, Flags1)
    ;   state_error("the snapshot holds ~W, which is not state", [T, [quoted(true), max_depth(6)]])
    ).

% The tries of the snapshot, new (no state changes), filled with their entries.
new_tries(TrieTerms, OldM, M, map(OldM, M, ById)) :-
    (   forall(member(trie(Id, Es), TrieTerms), ( integer(Id), is_list(Es), maplist(entry, Es) ))
    ->  true
    ;   state_error("a trie of the snapshot is not a list of entries", [])
    ),
    findall(Id-T, ( member(trie(Id, _), TrieTerms), trie_new(T) ), IdTries),
    (   list_to_assoc(IdTries, ById) -> true ; state_error("two tries of the snapshot have one id", []) ),
    forall(member(trie(Id, Es), TrieTerms),
           (   get_assoc(Id, ById, Trie),
               forall(member(K0-V0, Es),
                      ( reblob_data(map(OldM, M, ById), K0, K), reblob_data(map(OldM, M, ById), V0, V),
                        trie_insert(Trie, K, V) ))
           )).

entry(_-_).

% As reblob/3, clause references left as they are (resolved when the facts are asserted).
reblob_data(map(OldM, NewM, ById), T0, T) :-
    catch(reblob_(T0, T, OldM, NewM, later(ById)), error(rtl_state_error(_), _), fail), !.
reblob_data(_, T, _) :-
    state_error("~W refers to a trie the snapshot does not hold", [T, [quoted(true), max_depth(6)]]).

% check_fact(+Ctx, +Map, +Term, -Checked, +Types0, -Types): Term is a fact of a declared
% state predicate (or a clause of a predicate an active-query program names) with arguments
% of its declared types; Types caches the declared types of each predicate met.
check_fact(Ctx, Map, Term0, Term, Cache0, Cache) :-
    Ctx = ctx(M, Which, _, _, _),
    Map = map(OldM, _, ById),
    (   Term0 = fact(Mod0, Head0) -> Body0 = true ; Term0 = clause(Mod0, Head0, Body0) ),
    (   atom(Mod0), callable(Head0)
    ->  true
    ;   state_error("the snapshot holds ~W, which is not a fact", [Term0, [quoted(true), max_depth(6)]])
    ),
    ( Mod0 == OldM -> Mod = M ; Mod = Mod0 ),
    functor(Head0, Name, Arity),
    PI = Mod:Name/Arity,
    (   empty_assoc(ById), OldM == M
    ->  Head = Head0, Body = Body0
    ;   reblob_data(Map, Head0, Head), reblob_data(Map, Body0, Body)
    ),
    (   Term0 = clause(_, _, _)
    ->  (   Which \== all, Mod == M, memberchk(Name/Arity, Which),
            ( Body == true ; rtl_aq:aq_code_head(Head) )      % checked by aq_state_code/1
        ->  Term = clause(Mod, Head, Body), Cache = Cache0
        ;   state_error("the snapshot holds a clause of ~q with a body: a snapshot holds facts only", [PI])
        )
    ;   Which \== all, Mod == M, memberchk(Name/Arity, Which)     % saved as clause/3, checked so
    ->  state_error("the snapshot holds a fact term of ~q, which an active-query snapshot writes as a clause", [PI])
    ;   (   get_assoc(PI, Cache0, Types)
        ->  Cache = Cache0
        ;   declared_types(Ctx, Mod, Name, Arity, Types)
        ->  put_assoc(PI, Cache0, Types, Cache)
        ;   state_error("the snapshot holds a fact of ~q, which is not declared state", [PI])
        ),
        (   Types == any
        ->  true
        ;   Head =.. [_|Args],
            check_args(Types, Args, 1, Ctx, PI, Head)
        ),
        Term = fact(Mod, Head)
    ).

declared_types(Ctx, Mod, Name, Arity, Types) :-
    Ctx = ctx(M, _, _, Modules, _),
    functor(Decl, Name, Arity),
    (   memberchk(Mod, Modules), state_predicate(Mod, Decl)
    ->  Decl =.. [_|Types]
    ;   ( memberchk(Mod, Modules) ; Mod == M ; seen_module(Mod) ),
        family_predicate(Ctx, Mod, Name, Arity)
    ->  family_types(Ctx, Mod, Name, Types)
    ).

check_args([], [], _, _, _, _).
check_args([Type|Types], [Arg|Args], I, Ctx, PI, Head) :-
    (   catch(arg_ok(Type, Ctx, PI-I-Head, Arg), _, fail)    % rtl_aq may not be loaded
    ->  true
    ;   state_error("a fact of ~q does not have the declared shape (argument ~w is not ~w): ~W",
                    [PI, I, Type, Head, [quoted(true), max_depth(6)]])
    ),
    I1 is I + 1,
    check_args(Types, Args, I1, Ctx, PI, Head).

%!  arg_ok(+Type, +Context, +Where, +Value) is semidet.

arg_ok(data, _, _, _).
arg_ok(clause_refs, _, _, V) :-
    is_list(V),
    forall(member(R, V), ( nonvar(R), R = '$rtl_clause'(_:_/_, Index), integer(Index) )).
arg_ok(atom, _, _, V) :- atom(V).
arg_ok(integer, _, _, V) :- integer(V).
arg_ok(program, Ctx, _, V) :- program_module(Ctx, V).
arg_ok(this_program, ctx(M, _, _, _, _), _, V) :- V == M.
arg_ok(seen_module, _, _, V) :- ( V == [] -> true ; seen_module(V) ).     % [] for none
arg_ok(watch_predicate, _, _, V) :- watch_name(V).
arg_ok(bounds_global, _, _, V) :- atom(V), sub_atom(V, 0, _, _, '$rtl_slr_bounds_').
arg_ok(output_hook, _, _, V) :- ground(V), state_hook(V).
arg_ok(type_output_hook, _, _, V) :-                % data: a hook term
    (   rtl_slr_type_hook(V) -> true ; ground(V), state_hook(V) ).
arg_ok(goal, Ctx, _, V) :-
    nonvar(V), V = Q:G, program_module(Ctx, Q), state_goal(Q, G).
arg_ok(conditions, Ctx, _-_-Head, V) :-    % run in the program module the fact names
    is_list(V),
    Head =.. [_|Args],
    once(( member(M, Args), program_module(Ctx, M) )),
    maplist(state_goal(M), V).
arg_ok(aq_literal, ctx(_, _, _, _, Kinds), _, V) :-
    rtl_aq:aq_state_literal(Kinds, V, _).
arg_ok(aq_query_goal, ctx(_, _, _, _, Kinds), _-_-aq_q(_, _, How, _), V) :-   % query_answers/2
    rtl_aq:aq_state_literal(Kinds, V, Kind), Kind \== neg,
    ( How == fact -> Kind == fact ; How == call ).
arg_ok(aq_negated, ctx(_, _, _, _, Kinds), _-_-aq_negq(_, How, _, _, _), V) :-  % neg_holds/3
    rtl_aq:aq_state_negated(Kinds, How, V).
arg_ok(aq_stored_predicate, _, _, V) :-        % made mixed: its code is made from it
    callable(V), functor(V, N, A), functor(P, N, A), V =@= P,
    user:'$aq_fact_pred'(P).
arg_ok(aq_option_value, _, _-_-aq_conf(Key, _), V) :- rtl_aq:aq_state_conf(Key, V).
arg_ok(aq_event_op, _, _, V) :- atom(V), rtl_aq:aq_event_op(V).
arg_ok(aq_nstates, ctx(_, _, _, _, Kinds), _, V) :-
    blob(V, trie), rtl_aq:aq_state_negations(Kinds, V).
arg_ok(kept, _, Mod:Name/Arity-I-_, V) :-     % as the process has it now (a hook of the caller)
    functor(H, Name, Arity),
    catch(clause(Mod:H, true), _, fail),
    arg(I, H, V0),
    V0 =@= V, !.

%   The program, or another program loaded in this process (the runtime keeps one state per
%   process: docs/recovery.md).
program_module(ctx(M, _, _, _, _), V) :-
    atom(V),
    (   V == M -> true ; current_predicate(V:ele_trigger/3) ).

%   A goal kept in the state (a condition, a timer, a postponed query): a call of one of the
%   program's own predicates (its code, trusted like the program file), or a goal that
%   passes the check of untrusted goals unchanged (a condition that came from outside passed
%   it then, and was kept in its guarded form: rtl_check_goal/4).
state_goal(M, G) :-
    callable(G),
    (   G \= _:_,
        predicate_property(M:G, implementation_module(M)),
        \+ predicate_property(M:G, built_in)
    ->  true
    ;   catch(rtl_check_goal(query([]), M, G, Guarded), _, fail),
        Guarded =@= G                       % kept as it was guarded when it came in
    ).

% A clause reference '$rtl_clause'(PI, Index) points at a clause the snapshot holds, or
% (a predicate of a module the snapshot does not replace) at one there is now.
check_clause_references(Facts) :-
    forall(( member(fact(Mod, H), Facts), functor(H, Name, Arity), refs_predicate(Mod, Name, Arity),
             sub_term(Sub, H), compound(Sub), Sub = '$rtl_clause'(PI, Index) ),
           (   clause_reference_ok(Facts, PI, Index)
           ->  true
           ;   state_error("the snapshot refers to clause ~q of ~q, which it does not hold", [Index, PI])
           )).

clause_reference_ok(Facts, Mod:Name/Arity, Index) :-
    atom(Mod), atom(Name), integer(Arity), Arity >= 0, integer(Index), Index >= 1,
    functor(H, Name, Arity),
    (   \+ \+ ( memberchk(fact(Mod, H), Facts) ; memberchk(clause(Mod, H, _), Facts) )
    ->  aggregate_all(count, ( member(F, Facts), ( F = fact(Mod, H) ; F = clause(Mod, H, _) ) ), N),
        Index =< N
    ;   catch(nth_clause(Mod:H, Index, _), _, fail)
    ).

check_global(Ctx, Map, global(K, V0), K-V) :-
    (   atom(K), declared_global(K, Type)
    ->  true
    ;   state_error("the snapshot sets the global variable ~q, which is not declared state", [K])
    ),
    reblob_data(Map, V0, V),
    (   catch(arg_ok(Type, Ctx, global-1-global(K, V), V), _, fail)
    ->  true
    ;   state_error("the global variable ~q of the snapshot is not ~w", [K, Type])
    ).

check_flag(flag(K, V), K-V) :-
    (   atom(K), flag_key(K), integer(V)
    ->  true
    ;   state_error("the snapshot sets the flag ~q to ~q, which is not a counter of the runtime", [K, V])
    ).

state_error(Format, Args) :-
    format(string(Message), Format, Args),
    throw(error(rtl_state_error(Message), _)).

apply_state(plan(M, Which, Modules, Added, Removed, Facts, Globals, Flags, Map, Data)) :-
    (   Which == all -> rtl_rules_restore_state(M, Added, Removed) ; true ),
    % A module loaded after the snapshot was taken (active queries next to an event program
    % in one process) keeps its state: only the modules the snapshot has are replaced.
    captured_predicates(M-Which, Current),
    forall(( member(CM:Name/Arity, Current), ( memberchk(CM, Modules) ; seen_module(CM) ) ),
           ( functor(H, Name, Arity), own_head(M, CM, H), retractall(CM:H) )),
    partition(plain_fact, Facts, Plain, WithRefs),
    forall(member(T, Plain), assert_term(T)),
    forall(member(T0, WithRefs), ( reblob(Map, T0, T), assert_term(T) )),
    captured_globals(CurrentGlobals),
    forall(( member(K-_, CurrentGlobals), \+ memberchk(K-_, Globals), owned_by(K, Modules) ), nb_delete(K)),
    forall(member(K-V, Globals), nb_setval(K, V)),
    captured_flags(CurrentFlags),               % 0 (as a new flag) unless the snapshot has it
    forall(( member(K-_, CurrentFlags), \+ memberchk(K-_, Flags), owned_by(K, Modules) ), flag(K, _, 0)),
    forall(member(K-V, Flags), flag(K, _, V)),
    forall(( member(Mod-Ts, Data), state_data(Mod, _, _, Load) ), call(Mod:Load, Ts)),
    forall(( index_rebuild(Mod, Rebuild), memberchk(Mod, Modules) ), call(Mod:Rebuild, M)).

% index_rebuild(?Module, ?Goal): Module files its state under hashes of patterns
% (rtl_pattern_key.pl); call(Module:Goal, Program) files it again once the state is in place,
% so that a snapshot's keys are never trusted (term_hash/2 may differ between versions of
% SWI-Prolog, and a crafted snapshot could file an instance under a key it does not have).
index_rebuild(rtl_slr, rtl_slr_rebuild_index).
index_rebuild(rtl_subscriptions, rtl_subscriptions_rebuild_index).

% The most general head of the facts of CM:H that are program M's.
own_head(M, CM, H) :-
    (   this_program_arg(CM, H, I) -> arg(I, H, M) ; true ).

plain_fact(clause(_, _, _)).
plain_fact(fact(M, H)) :-
    functor(H, Name, Arity),
    \+ refs_predicate(M, Name, Arity).

assert_term(fact(Mod, Head)) :-
    functor(Head, Name, Arity),
    (   current_predicate(Mod:Name/Arity) -> true ; dynamic(Mod:Name/Arity) ),
    assertz(Mod:Head).
assert_term(clause(Mod, Head, Body)) :-
    functor(Head, Name, Arity),
    (   current_predicate(Mod:Name/Arity) -> true ; dynamic(Mod:Name/Arity) ),
    assert_clause(Mod, Head, Body).

% The globals and flags of active queries (aq_) belong to rtl_aq; the others to the runtime
% every snapshot has.
owned_by(K, Modules) :-
    (   sub_atom(K, 0, _, _, aq_) -> memberchk(rtl_aq, Modules) ; true ).

% clause/2 gives the body qualified by its module when that is not the predicate's.
assert_clause(M, H, B) :-
    (   B = Ctx:B0, atom(Ctx)
    ->  Ctx:assertz((M:H :- B0))
    ;   assertz(M:(H :- B))
    ).

reblob(map(OldM, NewM, ById), T0, T) :-
    reblob_(T0, T, OldM, NewM, ById).

reblob_(T, T, _, _, _) :-
    var(T), !.
reblob_(T, C, OldM, NewM, _) :-
    atomic(T), !,
    (   T == OldM -> C = NewM ; C = T ).
reblob_('$rtl_trie'(Id), Trie, _, _, Tries) :-
    integer(Id), !,
    (   Tries = later(ById) -> true ; ById = Tries ),
    (   get_assoc(Id, ById, Trie)
    ->  true
    ;   state_error("the snapshot refers to trie ~w, which it does not hold", [Id])
    ).
reblob_('$rtl_clause'(M0:Name/Arity, Index), Ref, OldM, NewM, Tries) :-
    atom(M0), integer(Index), !,
    (   M0 == OldM -> M = NewM ; M = M0 ),
    (   Tries = later(_)
    ->  Ref = '$rtl_clause'(M:Name/Arity, Index)
    ;   functor(H, Name, Arity),
        (   nth_clause(M:H, Index, Ref)
        ->  true
        ;   state_error("the snapshot refers to clause ~w of ~q, which it does not hold",
                        [Index, M:Name/Arity])
        )
    ).
reblob_(T, C, OldM, NewM, ById) :-
    compound_name_arguments(T, Name, Args),
    reblob_list(Args, CArgs, OldM, NewM, ById),
    compound_name_arguments(C, Name, CArgs).

reblob_list([], [], _, _, _).
reblob_list([A|As], [C|Cs], OldM, NewM, ById) :-
    reblob_(A, C, OldM, NewM, ById),
    reblob_list(As, Cs, OldM, NewM, ById).
%!  rtl_state_capture(-State) is det.
%
%   The state a snapshot holds, as one term without blobs (tries as their sorted entries,
%   the program module as `'$program'`, predicates without clauses left out), to compare
%   two states (tests). A trie is written out wherever it occurs: for small states only.

rtl_state_capture(State) :-
    program(Program),
    rtl_state_capture(Program, State).

rtl_state_capture(Program, state(Preds, Globals, Flags)) :-
    Program = M-_,
    captured_predicates(Program, PIs),
    findall(pred(CM, Name, Arity, Clauses),
            ( member(CM0:Name/Arity, PIs),
              functor(H, Name, Arity),
              findall(C, ( clause(CM0:H, B), canonical(M, H-B, C0), unnamed_seen(C0, C),
                           numbervars(C, 0, _) ), Clauses),
              Clauses \== [],                  % a predicate without clauses is no state
              ( CM0 == M -> CM = '$program' ; seen_module(CM0) -> CM = '$seen' ; CM = CM0 ) ),
            Preds0),
    merged_seen(Preds0, Preds),
    captured_globals(Globals0),
    findall(K-V, ( member(K-V0, Globals0), \+ unwritable_blob(V0), canonical(M, V0, V1), unnamed_seen(K-V1, K-V) ),
            Globals),
    captured_flags(Flags0),
    exclude(=(rtl_seen_generations-_), Flags0, Flags).

% The generation modules of the seen store are named as they came free in this process (a
% restore next to another Engine renames them): the digest leaves their names out.
unnamed_seen(generation(P, _, E)-true, generation(P, '$seen', E)-true) :- !.
unnamed_seen(free_generation(P, _)-true, free_generation(P, '$seen')-true) :- !.
unnamed_seen(rtl_seen_generation-G, rtl_seen_generation-C) :- !,
    ( G == [] -> C = [] ; C = '$seen' ).
unnamed_seen(T, T).

merged_seen(Preds0, Preds) :-
    partition([pred(CM, _, _, _)]>>(CM == '$seen'), Preds0, Seen, Others),
    findall(pred('$seen', Name, Arity, Clauses),
            ( member(Name/Arity, [seen/3, seen_atomic/1]),
              findall(C, ( member(pred(_, Name, Arity, Cs), Seen), member(C, Cs) ), Clauses0),
              Clauses0 \== [],
              msort(Clauses0, Clauses) ),
            Merged),
    append(Others, Merged, Preds).

unwritable_blob(V) :-
    \+ plain_atomic(V),
    blob(V, Type), Type \== trie, Type \== clause.

% Atoms, [] (a reserved symbol), numbers and strings: what fast_write/2 writes as it is.
plain_atomic(T) :-
    (   atom(T) -> true
    ;   T == [] -> true
    ;   atomic(T), \+ blob(T, _)
    ).

canonical(_, T, T) :- var(T), !.
canonical(M, T, C) :-
    \+ plain_atomic(T), blob(T, clause), !,
    clause_position(T, '$rtl_clause'(CM:PI, Index)),
    canonical(M, '$clause'(CM:PI, Index), C).
canonical(M, T, C) :-
    \+ plain_atomic(T), blob(T, trie), !,
    findall(K-V, trie_gen(T, K, V), Es0),
    maplist(canonical(M), Es0, Es1),
    maplist(numbered, Es1, Es2),                % entries with variables sort by their shape
    msort(Es2, Es),
    C = '$trie'(Es).
canonical(M, T, C) :-
    atomic(T), !,
    (   T == M -> C = '$program' ; C = T ).
canonical(M, T, C) :-
    compound_name_arguments(T, Name, Args),
    maplist(canonical(M), Args, CArgs),
    compound_name_arguments(C, Name, CArgs).

numbered(T, C) :-
    copy_term(T, C),
    numbervars(C, 0, _).

%!  rtl_state_digest(-Hash:atom) is det.
%
%   A hash of rtl_state_capture/1.

rtl_state_digest(Hash) :-
    program(Program),
    rtl_state_digest(Program, Hash).

rtl_state_digest(Program, Hash) :-
    rtl_state_capture(Program, State),
    variant_sha1(State, Hash).

rtl_error_text:runtime_error_text(rtl_state_error(Message), Text) :-
    text_to_string(Message, Text).

:- multifile prolog:error_message//1.
prolog:error_message(rtl_state_error(Message)) -->
    [ '~s'-[Message] ].
