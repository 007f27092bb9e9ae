/*  Retalis active queries: answer tables.

    Part of the Retalis runtime.
*/

:- module(rtl_aq_table,
          [ aqt_new/1,          % -Table
            aqt_add/4,          % +Table, +Answer, +Rank, -New
            aqt_insert/3,       % +Table, +Answer, +Value
            aqt_lookup/3,       % +Table, +Answer, -Value
            aqt_delete/3,       % +Table, +Answer, -Value
            aqt_gen/3,          % +Table, ?Answer, -Value
            aqt_entries/2,      % +Table, -Pairs
            aqt_count/2,        % +Table, -Count
            aqt_ground/1,       % +Table
            aqt_destroy/1,      % +Table
            aqt_is_table/1,     % @Term
            aqt_in_c/0
          ]).

/** <module> The answer tables of active queries

An answer table maps answers, identified up to variable renaming (variants), to an integer:
the answer's rank in rtl_aq.pl. A table is a blob of type `aq_answers` made by
`foreign/rtl_aq_table.so` (`c/rtl_aq_table.c`) when the set-up built it: a hash table of the
answers' external records, where one call does what a lookup and an insertion or update in
a trie do (`aqt_add/4`). Without the library a table is a SWI-Prolog trie, with the same
results. Terms with attributed variables and cyclic terms are refused with a type error
either way. rtl_state.pl writes tables of both kinds into snapshots.
*/

:- dynamic c_tables/0.

load_c_tables :-
    source_location(File, _),
    file_directory_name(File, Dir),
    atomic_list_concat([Dir, '/foreign/rtl_aq_table'], Lib),
    retractall(c_tables),
    (   getenv('RETALIS_AQ_TRIES', true)        % the Prolog road, for comparison
    ->  true
    ;   absolute_file_name(Lib, _, [file_type(executable), access(read), file_errors(fail)]),
        catch(load_foreign_library(Lib), _, fail),
        current_predicate(aqt_add/4)
    ->  assertz(c_tables)
    ;   true
    ).

:- load_c_tables.

%!  aqt_in_c is semidet.
%
%   The tables are those of the C library.

aqt_in_c :- c_tables.

%!  aqt_new(-Table) is det.
%!  aqt_add(+Table, +Answer, +Rank, -New) is det.
%
%   New is `true` when Answer had no variant in Table and is now stored with Rank;
%   else `false`, and the value V of the stored variant is now -V when it was positive.
%
%!  aqt_insert(+Table, +Answer, +Value) is semidet.
%
%   Store Answer with Value; fail when a variant of Answer is there.
%
%!  aqt_lookup(+Table, +Answer, -Value) is semidet.
%!  aqt_delete(+Table, +Answer, -Value) is semidet.
%!  aqt_entries(+Table, -Pairs) is det.
%
%   Pairs is a list of Answer-Value, one for every answer, in no particular order.
%
%!  aqt_count(+Table, -Count) is det.
%!  aqt_ground(+Table) is semidet.
%
%   Every answer in Table is ground.
%
%!  aqt_destroy(+Table) is det.
%
%   Free the answers; Table must not be used again.

:- if(\+ current_predicate(aqt_add/4)).

aqt_new(T) :- trie_new(T).

aqt_add(T, A, R, New) :-
    (   trie_lookup(T, A, V)
    ->  New = false,
        (   V > 0 -> NV is -V, trie_update(T, A, NV) ; true )
    ;   trie_insert(T, A, R),
        New = true
    ).

aqt_insert(T, A, V) :-                  % trie_insert/3 raises an error for a key
    \+ trie_lookup(T, A, _),             % stored with another value
    trie_insert(T, A, V).

aqt_lookup(T, A, V) :- trie_lookup(T, A, V).

aqt_delete(T, A, V) :- trie_delete(T, A, V).

aqt_entries(T, Pairs) :- findall(A-V, trie_gen(T, A, V), Pairs).

aqt_count(T, C) :-
    (   trie_property(T, value_count(C)) -> true ; C = 0 ).

aqt_ground(_) :- fail.

aqt_destroy(T) :- trie_destroy(T).

:- endif.

%!  aqt_gen(+Table, ?Answer, -Value) is nondet.
%
%   Answer unifies with a stored answer whose value is Value.

aqt_gen(T, A, V) :-
    (   \+ c_tables
    ->  trie_gen(T, A, V)
    ;   ground(A), aqt_ground(T)            % only A itself can unify with A
    ->  aqt_lookup(T, A, V)
    ;   aqt_entries(T, Pairs),
        member(A-V, Pairs)
    ).

%!  aqt_is_table(@Term) is semidet.

aqt_is_table(T) :-
    blob(T, Type),
    (   Type == aq_answers -> true ; Type == trie ).
