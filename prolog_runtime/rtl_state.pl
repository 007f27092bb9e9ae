:- module(rtl_state,
          [ rtl_state_save/2,           % +File, +Identity
            rtl_state_save/3,           % +File, +Identity, +Program
            rtl_state_restore/2,        % +File, +Identity
            rtl_state_restore/3,        % +File, +Identity, +Program
            rtl_state_capture/1,        % -State
            rtl_state_digest/1,         % -Hash
            rtl_state_digest/2          % +Program, -Hash
          ]).

/** <module> Snapshots of the whole runtime state, for restarts that lose nothing

A snapshot holds everything the runtime and the running program keep between two input
events, found generically so that state added by new runtime modules is captured without
a change here:

  - every clause of every dynamic predicate of the program module and of every module
    whose name starts with `rtl_` (the runtime modules, and the generation modules of
    rtl_seen.pl, `rtl_seen_<N>`): partial matches, negation stores, memory instances and
    their records, subscriptions, rules added at runtime, postponed synchronized matches,
    learned delays, active queries and their tables, flags;
  - every global variable (nb_setval/2) whose name starts with `rtl_`, `$rtl_` or `aq_`,
    and the counters of rtl_ele.pl (`events`, `derived`, ...): the clock, the sweep
    schedule, the bounds of memory instances;
  - every flag/3 key starting with `rtl_` (handle and generation numbers).

Tries (the answer tables of active queries) are written as their entries and made again
on restore, shared where they were shared. A clause reference (the clauses of a rule
added to active queries at run time) is written as the predicate and position of its
clause and found again on restore. Other blobs (streams) cannot be written: a global
holding one is skipped, a clause holding one makes the save fail with an error.

The program is the event program of rtl_program/1 (all the dynamic predicates of its
module are state), or one given as `Module-PIs` to the /3 forms: an active-query program
(rtl_aq_api.pl) keeps its facts, goal records and run-time rules in `user` and names those
predicates. What
must not be restored is listed by excluded_predicate/1 and excluded_global/1 (output sinks,
streams, per-call state), which other modules may extend (multifile).

The file is a sequence of fast_write/2 terms: `rtl_state(Version, Identity, Module)`,
`tries(Entries)`, `pred(Module, Name, Arity, Clauses)` per predicate (`pred_refs/4`, after
the others, for one whose clauses hold clause references), `globals(Pairs)`,
`flags(Pairs)` and `end(Count)`. Identity is given by the caller (a hash of the compiled
program and of the runtime, retalisc/driver/recovery.py); a snapshot whose version or
identity differs, or that does not end with `end/1`, is refused before anything is
changed: restore reads the whole file first, then replaces the state. The program's
module name may differ (an Engine loaded second in a process): its occurrences are renamed.

The caller makes the write atomic (temporary file, fsync, rename) and checks a checksum
before restoring (retalisc/driver/recovery.py).
*/

:- use_module(rtl_error_text, [rtl_error_text/2]).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(pairs)).
:- use_module(rtl_ele).

state_version(1).

%!  excluded_predicate(?PI) is nondet.
%!  excluded_global(?Key) is nondet.
%
%   Multifile: state that belongs to the process, not to the stream (output sinks, open
%   streams, the values of one call), which restore leaves as it is.

:- multifile excluded_predicate/1, excluded_global/1.

excluded_predicate(rtl_ele:rtl_output_line/1).
excluded_predicate(rtl_subscriptions:consumer_file/2).
excluded_predicate(rtl_horizon:warning_text/1).
excluded_predicate(rtl_ele:counter_key_of/2).     % a cache of atoms

excluded_global(rtl_program).
excluded_global(rtl_action_stream).
excluded_global(rtl_output_sink).
excluded_global(rtl_run_started).
excluded_global(rtl_loaded_at).
excluded_global(rtl_stream_options).
excluded_global(rtl_exiting).
excluded_global(rtl_consumer_dir).
excluded_global(rtl_halt_event).
excluded_global(rtl_halt_load).
excluded_global(rtl_end_stopped).
excluded_global(rtl_input_ended).
excluded_global(rtl_drop_pending).
excluded_global(rtl_slr_log).
excluded_global(rtl_slr_view).

% program(-Program): the event program, M-all (every dynamic predicate of M).
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
    setup_call_cleanup(open(File, write, Out, [type(binary)]),
                       write_state(Out, V, Identity, Program),
                       close(Out)).

write_state(Out, V, Identity, Program) :-
    Program = M-_,
    fast_write(Out, rtl_state(V, Identity, M)),
    empty_assoc(T0),
    captured_predicates(Program, PIs),
    catch(foldl(pred_term, PIs, PredTerms, T0-0, S1),
          rtl_state_unwritable(PI, Blob),
          state_error("~q holds ~p, which a snapshot cannot hold", [PI, Blob])),
    captured_globals(Globals0),
    unblob_globals(Globals0, Globals, S1, S2),
    trie_entries(S2, TrieEntries),
    fast_write(Out, tries(TrieEntries)),
    partition(plain_pred_term, PredTerms, Plain, WithRefs),
    forall(member(P, Plain), fast_write(Out, P)),      % clause references point into these
    forall(member(P, WithRefs), fast_write(Out, P)),
    fast_write(Out, globals(Globals)),
    captured_flags(Flags),
    fast_write(Out, flags(Flags)),
    length(PredTerms, Count),
    fast_write(Out, end(Count)).

plain_pred_term(pred(_, _, _, _)).

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

pred_term(M:Name/Arity, Term, S0, S) :-
    functor(H, Name, Arity),
    findall(H-B, clause(M:H, B), Clauses0),
    (   catch(fast_term_serialized(Clauses0, _), error(permission_error(fast_serialize, blob, _), _), fail)
    ->  Term = pred(M, Name, Arity, Clauses0), S = S0
    ;   catch(unblob(Clauses0, Clauses, S0, S), rtl_state_unwritable(Blob),
              throw(rtl_state_unwritable(M:Name/Arity, Blob))),
        (   sub_term(Sub, Clauses), compound(Sub), Sub = '$rtl_clause'(_, _)
        ->  Term = pred_refs(M, Name, Arity, Clauses)
        ;   Term = pred(M, Name, Arity, Clauses)
        )
    ).

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

captured_module(M, Program-_) :-
    (   M = Program
    ;   current_module(M), M \== Program,
        sub_atom(M, 0, _, _, rtl_),
        \+ current_predicate(M:ele_trigger/3)     % another program loaded in the process
    ).

captured_predicates(Program, PIs) :-
    findall(M:Name/Arity,
            ( captured_module(M, Program),
              current_predicate(M:Name/Arity),
              program_predicate(Program, M, Name/Arity),
              functor(H, Name, Arity),
              predicate_property(M:H, dynamic),
              \+ predicate_property(M:H, imported_from(_)),
              \+ excluded_predicate(M:Name/Arity)
            ),
            PIs0),
    sort(PIs0, PIs).

program_predicate(M-Which, CM, PI) :-
    (   CM == M, Which \== all -> memberchk(PI, Which) ; true ).

captured_global_key(K) :-
    (   sub_atom(K, 0, _, _, rtl_)
    ;   sub_atom(K, 0, _, _, '$rtl_')
    ;   sub_atom(K, 0, _, _, aq_)
    ;   rtl_stat(K, _)
    ),
    !,
    \+ excluded_global(K).

captured_globals(Pairs) :-
    findall(K-V, ( nb_current(K, V), atom(K), captured_global_key(K) ), Pairs0),
    keysort(Pairs0, Pairs).

captured_flags(Pairs) :-
    findall(K-V, ( current_flag(K), atom(K), flag_key(K), flag(K, V, V), V \== 0 ), Pairs0),
    keysort(Pairs0, Pairs).

flag_key(K) :-
    (   sub_atom(K, 0, _, _, rtl_) -> true ; sub_atom(K, 0, _, _, aq_) ).

%!  rtl_state_restore(+File, +Identity) is det.
%!  rtl_state_restore(+File, +Identity, +Program) is det.
%
%   Replace the state by the one saved in File. Raises
%   `error(rtl_state_error(Message), _)` (Message a string) and changes nothing when the
%   file is not a complete snapshot of this version and Identity.

rtl_state_restore(File, Identity) :-
    program(Program),
    rtl_state_restore(File, Identity, Program).

rtl_state_restore(File, Identity, Program) :-
    read_snapshot(File, Terms),
    check_snapshot(Terms, Identity, OldM, Tries, Preds, Globals, Flags),
    apply_state(Program, OldM, Tries, Preds, Globals, Flags).

read_snapshot(File, Terms) :-
    catch(setup_call_cleanup(open(File, read, In, [type(binary)]),
                             read_terms(In, Terms),
                             close(In)),
          E,
          (   E = error(rtl_state_error(_), _)
          ->  throw(E)
          ;   rtl_error_text(E, Text),
              state_error("~w is not a readable snapshot: ~s", [File, Text])
          )).


read_terms(In, Terms) :-
    (   at_end_of_stream(In)
    ->  Terms = []
    ;   fast_read(In, T),
        (   T = end(_) -> Terms = [T] ; Terms = [T|Rest], read_terms(In, Rest) )
    ).

check_snapshot(Terms, Identity, OldM, Tries, Preds, Globals, Flags) :-
    state_version(V),
    (   Terms = [rtl_state(V0, Identity0, OldM)|Body]
    ->  true
    ;   state_error("not a retalisc snapshot", [])
    ),
    (   V0 == V -> true
    ;   state_error("the snapshot has format version ~w, this runtime reads version ~w", [V0, V])
    ),
    (   Identity0 == Identity -> true
    ;   state_error("the snapshot was made by another program or runtime version (~w, not ~w)",
                    [Identity0, Identity])
    ),
    (   append(Middle, [end(Count)], Body),
        Middle = [tries(Tries)|Rest],
        append(Preds, [globals(Globals), flags(Flags)], Rest),
        length(Preds, Count),
        \+ ( member(P, Preds), P \= pred(_, _, _, _), P \= pred_refs(_, _, _, _) )
    ->  true
    ;   state_error("the snapshot is incomplete", [])
    ).

state_error(Format, Args) :-
    format(string(Message), Format, Args),
    throw(error(rtl_state_error(Message), _)).

apply_state(Program, OldM, TrieEntries, Preds, Globals, Flags) :-
    Program = M-_,
    length(TrieEntries, NT),
    length(Tries, NT),
    maplist(new_trie, Tries),
    pairs_keys_values(TrieEntries, Ids, _),
    pairs_keys_values(IdTries, Ids, Tries),
    list_to_assoc(IdTries, ById),
    Map = map(OldM, M, ById),
    maplist(fill_trie(Map), TrieEntries),
    % A module loaded after the snapshot was taken (active queries next to an event program
    % in one process) keeps its state: only the modules the snapshot has are replaced.
    findall(SM, ( member(P, Preds), arg(1, P, SM0), ( SM0 == OldM -> SM = M ; SM = SM0 ) ), SMs0),
    sort([M|SMs0], SMs),
    captured_predicates(Program, Current),
    forall(( member(CM:Name/Arity, Current), memberchk(CM, SMs) ),
           ( functor(H, Name, Arity), retractall(CM:H) )),
    maplist(restore_pred(Map), Preds),
    captured_globals(CurrentGlobals),
    forall(( member(K-_, CurrentGlobals), \+ memberchk(K-_, Globals), owned_by(K, SMs) ), nb_delete(K)),
    forall(member(K-V0, Globals), ( reblob(Map, V0, V), nb_setval(K, V) )),
    captured_flags(CurrentFlags),               % 0 (as a new flag) unless the snapshot has it
    forall(( member(K-_, CurrentFlags), \+ memberchk(K-_, Flags), owned_by(K, SMs) ), flag(K, _, 0)),
    forall(member(K-V, Flags), flag(K, _, V)).

% The globals and flags of active queries (aq_) belong to rtl_aq; the others to the runtime
% every snapshot has.
owned_by(K, Modules) :-
    (   sub_atom(K, 0, _, _, aq_) -> memberchk(rtl_aq, Modules) ; true ).

new_trie(T) :- trie_new(T).

fill_trie(Map, Id-Entries) :-
    Map = map(_, _, ById),
    get_assoc(Id, ById, Trie),
    forall(member(K0-V0, Entries),
           ( reblob(Map, K0, K), reblob(Map, V0, V), trie_insert(Trie, K, V) )).

restore_pred(Map, Term) :-
    Term =.. [Kind, M0, Name, Arity, Clauses],
    Map = map(OldM, NewM, _),
    (   M0 == OldM -> M = NewM ; M = M0 ),
    dynamic(M:Name/Arity),
    (   ( Kind == pred_refs ; needs_reblob(Map, Clauses) )
    ->  forall(member(C0, Clauses), ( reblob(Map, C0, H-B), assert_clause(M, H, B) ))
    ;   forall(member(H-B, Clauses), assert_clause(M, H, B))
    ).

% clause/2 gives the body qualified by its module when that is not the predicate's.
assert_clause(M, H, B) :-
    (   B = Ctx:B0, atom(Ctx)
    ->  Ctx:assertz((M:H :- B0))
    ;   assertz(M:(H :- B))
    ).

% Clauses need rewriting when tries are restored or the program module was renamed.
needs_reblob(map(OldM, NewM, ById), _) :-
    (   OldM \== NewM -> true ; \+ empty_assoc(ById) ).

reblob(map(OldM, NewM, ById), T0, T) :-
    reblob_(T0, T, OldM, NewM, ById).

reblob_(T, T, _, _, _) :-
    var(T), !.
reblob_(T, C, OldM, NewM, _) :-
    atomic(T), !,
    (   T == OldM -> C = NewM ; C = T ).
reblob_('$rtl_trie'(Id), Trie, _, _, ById) :-
    integer(Id), !,
    get_assoc(Id, ById, Trie).
reblob_('$rtl_clause'(M0:Name/Arity, Index), Ref, OldM, NewM, _) :-
    atom(M0), integer(Index), !,
    (   M0 == OldM -> M = NewM ; M = M0 ),
    functor(H, Name, Arity),
    (   nth_clause(M:H, Index, Ref)
    ->  true
    ;   state_error("the snapshot refers to clause ~w of ~q, which it does not hold",
                    [Index, M:Name/Arity])
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
              findall(C, ( clause(CM0:H, B), canonical(M, H-B, C), numbervars(C, 0, _) ), Clauses),
              Clauses \== [],                  % a predicate without clauses is no state
              ( CM0 == M -> CM = '$program' ; CM = CM0 ) ),
            Preds),
    captured_globals(Globals0),
    findall(K-V, ( member(K-V0, Globals0), \+ unwritable_blob(V0), canonical(M, V0, V) ), Globals),
    captured_flags(Flags).

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
