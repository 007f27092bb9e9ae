/*  plunit tests of how the runtime's modules use each other (docs/architecture.md, "Layers"):
    no circle of modules importing each other (use_module/1,2, reexport/1,2), and a module
    names another's predicate, `Module:Goal` or `Module:Name/Arity` in a clause body, only
    when that module exports it (or declares it multifile: a hook) and does not import the
    first one (a call up into an importer: a lower module reaches an upper one through a
    hook the upper one defines, never by name); the C helpers are loaded by rtl_foreign.pl
    alone.

        swipl -g run_tests -t halt prolog_runtime/tests/test_wiring.pl

    wiring_problems/1 is the check itself; the tests also run it on small made-up modules, so
    that it is known to see what it must see.
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(ugraphs)).
:- use_module(library(prolog_xref)).

:- prolog_load_context(directory, Dir),
   file_directory_name(Dir, Runtime),
   asserta(user:file_search_path(wiring_runtime, Runtime)).

%!  runtime_files(+Directory, -Files) is det.
%
%   The module files of Directory (absolute paths).

runtime_files(Directory, Files) :-
    directory_files(Directory, Names),
    findall(File,
            ( member(Name, Names),
              file_name_extension(_, pl, Name),
              directory_file_path(Directory, Name, File) ),
            Files0),
    msort(Files0, Files).

%!  wiring_problems(+Directory, -Problems) is det.
%
%   The modules of Directory loaded and cross-referenced; Problems lists, as text, every
%   circle of modules importing each other, every `Module:Goal` naming a predicate Module
%   neither exports nor declares multifile, and every call up into a module that imports
%   the caller (hooks aside).

wiring_problems(Directory, Problems) :-
    runtime_files(Directory, Files),
    forall(member(File, Files), load_files(File, [if(not_loaded), silent(true)])),
    findall(File-Module, ( member(File, Files), xref_source(File, [silent(true)]),
                           xref_module(File, Module) ),
            Modules),
    findall(M-Q, ( member(File-M, Modules), xref_uses_file(File, _, Used),
                   memberchk(Used-Q, Modules) ),
            Uses),
    findall(reference(M, Q, Ref), ( member(_-P, Modules), qualified_reference(P, Modules, M, Q, Ref) ), Refs0),
    sort(Refs0, Refs),
    findall(Text, ( member(reference(M, Q, Ref), Refs), \+ visible(Q, Ref),
                    format(string(Text), "~w names ~w:~w, which ~w does not export", [M, Q, Ref, Q]) ),
            Hidden),
    findall(M, member(_-M, Modules), Vertices),
    exclude([M-M]>>true, Uses, Edges),
    vertices_edges_to_ugraph(Vertices, Edges, Graph),
    transitive_closure(Graph, Imports),
    findall(Text, ( member(reference(M, Q, Ref), Refs), \+ hook(Q, Ref),
                    neighbours(Q, Imports, Below), memberchk(M, Below),
                    format(string(Text), "~w calls ~w:~w, but ~w imports ~w", [M, Q, Ref, Q, M]) ),
            Upward),
    findall(Text, ( circle(Graph, Circle),
                    atomic_list_concat(Circle, ' -> ', Path),
                    format(string(Text), "circle of modules: ~w", [Path]) ),
            Circles),
    append([Circles, Hidden, Upward], Problems).

%   qualified_reference(+Predicates, +Modules, -Module, -Other, -Indicator): a clause of a
%   predicate of module Predicates, written in module Module (another one for a clause of a
%   multifile hook), names Other:Goal (or Other:Name/Arity) in its body, Other another module
%   of Modules.
qualified_reference(Predicates, Modules, Module, Other, Name/Arity) :-
    current_predicate(Predicates:Name0/Arity0),
    functor(Head, Name0, Arity0),
    \+ predicate_property(Predicates:Head, imported_from(_)),
    \+ predicate_property(Predicates:Head, foreign),
    catch(clause(Predicates:Head, Body0, Clause), _, fail),
    clause_property(Clause, module(Module)),
    (   Module \== Predicates, Body0 = Module:Body -> true ; Body = Body0 ),
    sub_term(Other:Goal, Body),
    atom(Other), Other \== Module,
    memberchk(_-Other, Modules),
    (   Goal = PName/PArity, ( var(PName) ; var(PArity) )
    ->  fail                                    % a pattern (current_predicate(M:N/3)), no name
    ;   Goal = Name/Arity, atom(Name), integer(Arity)
    ->  true
    ;   callable(Goal), functor(Goal, Name, Arity)
    ).

visible(Module, Indicator) :-
    module_property(Module, exports(Exports)),
    memberchk(Indicator, Exports), !.
visible(Module, Indicator) :-
    hook(Module, Indicator).

hook(Module, Name/Arity) :-
    functor(Head, Name, Arity),
    predicate_property(Module:Head, multifile).

%   circle(+Graph, -Circle): a strongly connected set of more than one vertex, as a path
%   from its least member back to it (each circle once).
circle(Graph, Circle) :-
    transitive_closure(Graph, Closure),
    member(Start-Reachable, Closure),
    memberchk(Start, Reachable),
    findall(V, ( member(V, Reachable), V \== Start, neighbours(V, Closure, Back), memberchk(Start, Back) ),
            Members),
    Members \== [],
    msort([Start|Members], [Start|_]),
    path(Graph, Start, Start, [Start|Members], Circle).

path(Graph, From, To, Allowed, [From|Rest]) :-
    neighbours(From, Graph, Next),
    (   memberchk(To, Next)
    ->  Rest = [To]
    ;   member(Step, Next), memberchk(Step, Allowed), Step \== To,
        path(Graph, Step, To, Allowed, Rest), !
    ), !.

:- begin_tests(rtl_wiring).

test(the_runtime) :-
    absolute_file_name(wiring_runtime(.), Runtime, [file_type(directory)]),
    wiring_problems(Runtime, Problems),
    assertion(Problems == []).

test(a_made_up_circle_and_a_private_call, [setup(made_up(Dir)), cleanup(delete_directory_and_contents(Dir))]) :-
    wiring_problems(Dir, Problems),
    assertion(memberchk("circle of modules: wiring_a -> wiring_b -> wiring_a", Problems)),
    assertion(memberchk("wiring_b names wiring_a:secret/0, which wiring_a does not export", Problems)),
    assertion(\+ ( member(P, Problems), sub_string(P, _, _, _, hooked) )),
    assertion(memberchk("wiring_b calls wiring_a:secret/0, but wiring_a imports wiring_b", Problems)),
    assertion(length(Problems, 3)).

test(one_loader_of_the_c_helpers) :-
    absolute_file_name(wiring_runtime(.), Runtime, [file_type(directory)]),
    runtime_files(Runtime, Files),
    findall(Base, ( member(File, Files), file_base_name(File, Base), Base \== 'rtl_foreign.pl',
                    read_file_to_string(File, Text, []),
                    ( sub_string(Text, _, _, _, "load_foreign_library")
                    ; sub_string(Text, _, _, _, "use_foreign_library") ) ),
            Loaders),
    assertion(Loaders == []).

:- end_tests(rtl_wiring).

%   Two modules in a fresh directory that import each other; wiring_b calls wiring_a's
%   private secret/0 (up into its importer) and defines wiring_a's hook (which is allowed).
made_up(Dir) :-
    tmp_file(wiring, Dir),
    make_directory(Dir),
    directory_file_path(Dir, 'wiring_a.pl', A),
    directory_file_path(Dir, 'wiring_b.pl', B),
    write_file(A, [":- module(wiring_a, [a/0]).", ":- use_module(wiring_b).", ":- multifile hooked/0.",
                   "a :- b.", "secret.", "hooked :- fail."]),
    write_file(B, [":- module(wiring_b, [b/0]).", ":- use_module(wiring_a, []).", ":- multifile wiring_a:hooked/0.",
                   "b :- wiring_a:secret.", "wiring_a:hooked :- true."]).

write_file(File, Lines) :-
    setup_call_cleanup(open(File, write, Out),
                       forall(member(Line, Lines), format(Out, "~s~n", [Line])),
                       close(Out)).
