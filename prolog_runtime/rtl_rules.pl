:- module(rtl_rules,
          [ ins_event_rule/1,           % :Rule
            del_event_rule/1,           % :Label
            rtl_install_rules/3,        % +Module, +ClausesText, -Ids
            rtl_remove_rule/2,          % +Module, +Id
            rtl_rule_exists/2,          % +Module, +Id
            rtl_fresh_rule_prefix/2,    % +Module, -Prefix
            rtl_rules_state/3,          % +Module, -Added, -Removed
            rtl_rules_check_state/4,    % +Module, +Added, +Removed, -Stores
            rtl_rules_restore_state/3   % +Module, +Added, +Removed
          ]).

/** <module> Adding and removing event rules while events flow (ETALIS ins_event_rule)

ins_event_rule/1 compiles an event rule with the retalisc compiler and adds the generated
clauses to the running program; del_event_rule/1 removes every clause, trigger and stored
partial match of a rule. When the runtime runs inside a Python process that serves the
compiler (retalisc/driver/bridge.py, an Engine), the rule compiles there, in-process;
otherwise (`swipl PROGRAM.pl`) `retalisc compile-rules` runs as a subprocess. The Python
driver's own Engine.add_rules compiles in-process and calls rtl_install_rules/3 and
rtl_remove_rule/2 directly.

A rule added at runtime starts with empty stores: it sees only the events processed after
it was added, as in ETALIS. A rule's generated predicates are those named `e_<Id>_<N>` and
`e_<Id>_<N>_<suffix>` (N a step number); its triggers are the `ele_trigger/3` and
`ele_untrigger/3` clauses whose body calls one of them. This holds for the rules of the
program file too, so del_event_rule/1 removes those as well.
*/

:- use_module(library(process)).
:- use_module(library(readutil)).
:- use_module(rtl_ele).
:- use_module(rtl_library, [rtl_target_program/2]).
:- use_module(rtl_sandbox, [rtl_check_rule/5, rtl_rule_pred_name/2, rtl_store_pred/2]).
:- use_module(rtl_error_text).
:- use_module(rtl_timers, [rtl_timers_drop/2]).

:- meta_predicate ins_event_rule(:), del_event_rule(:).

:- dynamic added_rule/2.        % added_rule(Module, Id)
:- dynamic added_rule_code/4.   % added_rule_code(Module, Id, Stores, Clauses): as installed
:- dynamic removed_rule/2.      % removed_rule(Module, Id): a rule of the program file, deleted

%!  ins_event_rule(:Rule) is det.
%
%   Add an event rule to the running program. Rule is the rule's text (a string or an
%   atom, in .rtl syntax, the final full stop optional), or the rule as a term
%   (`Head <- Pattern`, `Label : (Head <- Pattern)`) when the event operators are
%   declared where it is written. An unlabelled rule gets a fresh id. Raises a
%   permission error when a rule with the same label exists, and a
%   `retalis_compile_error` with the compiler's message for a bad rule.
%
%   Inside a Python process, the compiler of that process compiles the rule (see
%   compile_in_process/4). Otherwise it is run as `PYTHON -m retalisc compile-rules`,
%   PYTHON being the environment variable `RETALISC_PYTHON`, the `.venv` next to the
%   runtime, the Python of the installation the runtime was installed into
%   (`PREFIX/bin/python3` for `PREFIX/lib/pythonX.Y/site-packages/retalisc/prolog_runtime`),
%   or `python3`, whichever is found first.

ins_event_rule(Caller:Rule) :-
    rtl_target_program(Caller, M),
    rule_text(Rule, Text),
    rtl_fresh_rule_prefix(M, Prefix),
    run_compiler(M, Prefix, Text, Clauses),
    rtl_install_rules(M, Clauses, _).

%!  del_event_rule(:Rule) is det.
%
%   Remove a rule (added at runtime or compiled with the program): its triggers, its
%   generated predicates and its stored partial matches. Rule is its label, or as in
%   ETALIS the labelled rule itself (`Label 'rule:' Head <- Pattern`, `Label : Head <-
%   Pattern`: its label is used). Raises an existence error when there is no such rule, a
%   domain error for an unlabelled rule term (rules are found by label).

del_event_rule(Caller:Rule) :-
    rtl_target_program(Caller, M),
    rule_label(Rule, Label),
    rtl_remove_rule(M, Label).

rule_label(Rule, Label) :-
    (   var(Rule)
    ->  instantiation_error(Rule)
    ;   atom(Rule)
    ->  Label = Rule
    ;   ( Rule = 'rule:'(Label0, _) ; Rule = (Label0 : '<-'(_, _)) ),
        callable(Label0)
    ->  functor(Label0, Label, _)          % r2([property(...)]) 'rule:' ... is rule r2
    ;   Rule = '<-'(_, _)
    ->  throw(error(domain_error(labelled_event_rule, Rule),
                    context(del_event_rule/1, 'rules are deleted by label: label the rule (r1 \'rule:\' Head <- Pattern) and delete r1')))
    ;   throw(error(type_error(event_rule_label, Rule), context(del_event_rule/1, _)))
    ).

%!  rtl_install_rules(+Module, +Text:string, -Ids:list(atom)) is det.
%
%   Add the rules in Text, the output of `retalisc compile-rules`, to Module. Nothing is
%   added when one of their ids is in use, or when one of them is refused by
%   rtl_check_rule/5 (rtl_sandbox.pl): a rule added at run time comes from outside the
%   program file, so every goal it could run must be safe.

rtl_install_rules(M, Text, Ids) :-
    read_rules(M, Text, Rules),
    findall(Id, member(rule(Id, _, _), Rules), Ids),
    forall(member(Id, Ids),
           (   rtl_rule_exists(M, Id)
           ->  throw(error(permission_error(add, event_rule, Id),
                           context(ins_event_rule/1, 'a rule with this id exists; delete it first')))
           ;   true
           )),
    maplist(checked_rule(M), Rules, Checked),
    forall(member(rule(Id, Stores, Clauses), Checked),
           install_rule(M, Id, Stores, Clauses)),
    reschedule_sweep.

% The clauses of a rule as rtl_check_rule/5 guards them.
checked_rule(M, rule(Id, Stores, Clauses), rule(Id, Stores, Guarded)) :-
    rtl_check_rule(M, Id, Stores, Clauses, Guarded).

install_rule(M, Id, Stores, Clauses) :-
    forall(member(store(Name, Arity, Window), Stores),
           (   dynamic(M:Name/Arity),
               assertz(M:ele_partial_store(Name, Arity)),
               (   Window == none -> true ; assertz(M:ele_store(Name, Arity, Window)) )
           )),
    forall(member(record(Name, Arity, KeptA, KeptB), Stores),   % kept for deletions (rtl_horizon)
           (   dynamic([M:KeptA/Arity, M:KeptB/Arity, M:ele_record_store/3]),
               assertz(M:ele_partial_store(KeptA, Arity)),
               assertz(M:ele_partial_store(KeptB, Arity)),
               assertz(M:ele_record_store(Name, Arity, kept(KeptA, KeptB)))
           )),
    forall(member(kept(Live, Arity, KeptA, KeptB, Order), Stores),
           (   dynamic([M:KeptA/Arity, M:KeptB/Arity, M:ele_kept_store/3]),
               assertz(M:ele_partial_store(KeptA, Arity)),
               assertz(M:ele_partial_store(KeptB, Arity)),
               assertz(M:ele_kept_store(Live, kept(KeptA, KeptB), Order))
           )),
    forall(member(Clause, Clauses), assertz(M:Clause)),
    assertz(added_rule(M, Id)),
    assertz(added_rule_code(M, Id, Stores, Clauses)),
    rtl_dispatch_changed.

read_rules(M, Text, Rules) :-
    setup_call_cleanup(open_string(Text, In),
                       read_terms(In, M, Terms),
                       close(In)),
    group_rules(Terms, Rules).

read_terms(In, M, Terms) :-
    read_term(In, Term, [module(M)]),
    (   Term == end_of_file
    ->  Terms = []
    ;   Terms = [Term|Rest],
        read_terms(In, M, Rest)
    ).

group_rules([], []).
group_rules(['$rtl_rule'(Id, Stores)|Terms], [rule(Id, Stores, Clauses)|Rules]) :- !,
    take_clauses(Terms, Clauses, Rest),
    group_rules(Rest, Rules).
group_rules([Term|_], _) :-
    domain_error(compiled_rules, Term).

take_clauses([], [], []).
take_clauses([T|Ts], Clauses, Rest) :-
    (   T = '$rtl_rule'(_, _)
    ->  Clauses = [], Rest = [T|Ts]
    ;   Clauses = [T|Cs],
        take_clauses(Ts, Cs, Rest)
    ).

%!  rtl_remove_rule(+Module, +Id) is det.
%
%   Remove rule Id from Module (see del_event_rule/1).

rtl_remove_rule(M, Id) :-
    (   rtl_rule_exists(M, Id)
    ->  true
    ;   existence_error(event_rule, Id)
    ),
    forall(member(Trigger, [ele_trigger(_, _, _), ele_untrigger(_, _, _)]),
           forall(( predicate_property(M:Trigger, dynamic),
                    clause(M:Trigger, Body, Ref),
                    calls_rule(Body, Id) ),
                  erase(Ref))),
    forall(( M:ele_partial_store(Name, Arity), rtl_rule_pred_name(Id, Name) ),
           ( functor(Head, Name, Arity),
             retractall(M:Head),
             retractall(M:ele_partial_store(Name, Arity)),
             retractall(M:ele_store(Name, Arity, _)),
             (   current_predicate(M:ele_kept_store/3)
             ->  retractall(M:ele_kept_store(Name, _, _))
             ;   true
             ) )),
    (   current_predicate(M:ele_record_store/3)
    ->  forall(( M:ele_record_store(Name, Arity, Kept), rtl_rule_pred_name(Id, Name) ),
               retractall(M:ele_record_store(Name, Arity, Kept)))
    ;   true
    ),
    forall(( current_predicate(M:Name/Arity), rtl_rule_pred_name(Id, Name),
             functor(Head, Name, Arity),
             \+ predicate_property(M:Head, imported_from(_)) ),
           remove_predicate(M, Name, Arity)),
    rtl_dispatch_changed,
    rtl_timers_drop(M, rtl_rule_pred_name(Id)),
    (   retract(added_rule(M, Id))
    ->  retractall(added_rule_code(M, Id, _, _))
    ;   assertz(removed_rule(M, Id))
    ),
    reschedule_sweep.

%!  rtl_rules_state(+Module, -Added, -Removed) is det.
%!  rtl_rules_check_state(+Module, +Added, +Removed, -Stores) is det.
%!  rtl_rules_restore_state(+Module, +Added, +Removed) is det.
%
%   The rules of Module as a snapshot holds them (rtl_state.pl): Added the rules added at run
%   time, `rule(Id, Stores, Clauses)` as compiled, Removed the ids of the rules of the program
%   file deleted since it was loaded. rtl_rules_check_state/4 throws
%   `rtl_rules_state(Message)` (and changes nothing) unless the rules can be made so: every
%   added rule passes rtl_check_rule/4 as a rule added by a control line does, and no rule of
%   the program file the snapshot keeps was deleted in this process (its code is gone); Stores
%   are the Name/Arity of the partial-match stores of the rules there will be.
%   rtl_rules_restore_state/3 makes them so: the rules added now are removed, the deleted
%   ones deleted and the added ones installed, their stores empty.

rtl_rules_state(M, Added, Removed) :-
    findall(rule(Id, Stores, Clauses), added_rule_code(M, Id, Stores, Clauses), Added),
    findall(Id, removed_rule(M, Id), Removed).

rtl_rules_check_state(M, Added, Removed, Stores) :-
    (   is_list(Added), is_list(Removed), maplist(atom, Removed)
    ->  true
    ;   throw(rtl_rules_state("its rules are not a list of compiled rules and a list of rule ids", []))
    ),
    forall(( removed_rule(M, Id), \+ memberchk(Id, Removed) ),
           throw(rtl_rules_state("it has rule ~q of the program, which was deleted in this process: restore it into a new load of the program", [Id]))),
    forall(( member(Id, Removed), \+ removed_rule(M, Id) ),
           (   \+ added_rule(M, Id), rtl_rule_exists(M, Id)
           ->  true
           ;   throw(rtl_rules_state("it deletes rule ~q, which the program does not have", [Id]))
           )),
    forall(member(Rule, Added),
           (   Rule = rule(Id, RuleStores, Clauses), atom(Id), is_list(RuleStores), is_list(Clauses)
           ->  catch(rtl_check_rule(M, Id, RuleStores, Clauses, Guarded), error(Unsafe, _),
                     throw(rtl_rules_state("its rule ~q added at run time is refused: ~q", [Id, Unsafe]))),
               (   Guarded =@= Clauses              % installed in their guarded form
               ->  true
               ;   throw(rtl_rules_state("its rule ~q added at run time is not as the rule check leaves it", [Id]))
               )
           ;   throw(rtl_rules_state("~q is not a compiled rule", [Rule]))
           )),
    findall(Name/Arity,
            (   current_predicate(M:ele_partial_store/2),
                M:ele_partial_store(Name, Arity),
                \+ ( added_rule(M, Id), rtl_rule_pred_name(Id, Name) ),
                \+ ( member(Id, Removed), rtl_rule_pred_name(Id, Name) )
            ;   member(rule(_, RuleStores, _), Added),
                member(Store, RuleStores),
                rtl_store_pred(Store, Name/Arity)
            ),
            Stores0),
    sort(Stores0, Stores).

rtl_rules_restore_state(M, Added, Removed) :-
    forall(added_rule(M, Id), rtl_remove_rule(M, Id)),
    forall(( member(Id, Removed), \+ removed_rule(M, Id) ), rtl_remove_rule(M, Id)),
    forall(member(rule(Id, Stores, Clauses), Added), install_rule(M, Id, Stores, Clauses)),
    reschedule_sweep.

%   The sweep of windowed stores is scheduled from the smallest window: setting the delay
%   bound (to its current value) schedules it again for the rules now present.
reschedule_sweep :-
    rtl_flag(max_delay, Delay),
    rtl_set_flag(max_delay, Delay).

remove_predicate(M, Name, Arity) :-
    functor(Head, Name, Arity),
    (   predicate_property(M:Head, dynamic) -> retractall(M:Head) ; true ),
    catch(abolish(M:Name/Arity), E,
          print_message(warning, format("del_event_rule: ~w/~w kept: ~q", [Name, Arity, E]))).

calls_rule(Body, Id) :-
    sub_term(Goal, Body),
    callable(Goal),
    functor(Goal, Name, _),
    rtl_rule_pred_name(Id, Name),
    !.

%!  rtl_rule_exists(+Module, +Id) is semidet.
%
%   Module has a rule Id: added at runtime, or with generated predicates of its name.

rtl_rule_exists(M, Id) :-
    (   added_rule(M, Id)
    ->  true
    ;   current_predicate(M:Name/_),
        rtl_rule_pred_name(Id, Name)
    ->  true
    ).

%!  rtl_fresh_rule_prefix(+Module, -Prefix) is det.
%
%   A prefix `rt<N>` no rule of Module uses: unlabelled added rules are `rt<N>_<K>`.

rtl_fresh_rule_prefix(M, Prefix) :-
    (   nb_current(rtl_rule_counter, N0) -> true ; N0 = 0 ),
    N is N0 + 1,
    nb_setval(rtl_rule_counter, N),
    atom_concat(rt, N, Candidate),
    atomic_list_concat([e_, Candidate, '_'], Start),
    (   ( added_rule(M, Id), sub_atom(Id, 0, _, _, Candidate)
        ; current_predicate(M:Name/_), sub_atom(Name, 0, _, _, Start)
        )
    ->  rtl_fresh_rule_prefix(M, Prefix)
    ;   Prefix = Candidate
    ).

% ---- the compiler: in-process or a subprocess -------------------------------------------

rule_text(Rule, Text) :-
    (   var(Rule)
    ->  instantiation_error(Rule)
    ;   string(Rule) -> Text0 = Rule
    ;   atom(Rule) -> atom_string(Rule, Text0)
    ;   with_output_to(string(Text0),
                       \+ \+ ( numbervars(Rule, 0, _),
                               write_term(Rule, [quoted(true), ignore_ops(true), numbervars(true)]) ))
    ),
    split_string(Text0, "", " \t\n", [Trimmed]),
    (   sub_string(Trimmed, _, 1, 0, ".")
    ->  Text = Trimmed
    ;   string_concat(Trimmed, ".", Text)
    ).

run_compiler(M, Prefix, Text, Clauses) :-
    (   compile_in_process(M, Prefix, Text, Clauses)
    ->  true
    ;   compile_in_subprocess(M, Prefix, Text, Clauses)
    ).

%   The Python process the runtime is embedded in serves its compiler as `compile_rules`
%   (retalisc_bridge:rtl_python_call/4, prolog_runtime/rtl_bridge.pl, loaded by
%   retalisc/driver/bridge.py; an Engine serves it): the rule compiles there, without
%   starting a process. Fails when nothing serves it.
compile_in_process(M, Prefix, Text, Clauses) :-
    current_predicate(retalisc_bridge:rtl_python_call/4),
    atom_string(M, Module),
    retalisc_bridge:rtl_python_call(compile_rules, [Module, Prefix, Text], Status, Result),
    (   Status == ok
    ->  Clauses = Result
    ;   Status == error
    ->  throw(error(retalis_compile_error(Result), context(ins_event_rule/1, Text)))
    ).

compile_in_subprocess(M, Prefix, Text, Clauses) :-
    compiler_python(Python),
    compiler_directory(Dir),
    setup_call_cleanup(
        process_create(Python, ['-m', retalisc, 'compile-rules', '--module', M,
                                '--rule-prefix', Prefix, '--name', 'ins_event_rule'],
                       [ stdin(pipe(In)), stdout(pipe(Out)), stderr(pipe(Err)),
                         cwd(Dir), process(Pid) ]),
        ( set_stream(In, encoding(utf8)),
          set_stream(Out, encoding(utf8)),
          set_stream(Err, encoding(utf8)),
          format(In, "~s~n", [Text]),
          close(In),
          read_string(Out, _, Clauses),
          read_string(Err, _, Messages),
          process_wait(Pid, Status) ),
        ( close(Out, [force(true)]), close(Err, [force(true)]) )),
    (   Status == exit(0)
    ->  true
    ;   split_string(Messages, "", "\n", [Message]),
        throw(error(retalis_compile_error(Message), context(ins_event_rule/1, Text)))
    ).

rtl_error_text:runtime_error_text(retalis_compile_error(Message), Text) :-
    string(Message),
    format(string(Text), "the event rule does not compile: ~s", [Message]).

:- multifile prolog:error_message//1.
prolog:error_message(retalis_compile_error(Message)) -->
    [ 'the event rule does not compile:~n~s'-[Message] ].

compiler_python(Python) :-
    (   getenv('RETALISC_PYTHON', P), P \== ''
    ->  Python = P
    ;   runtime_root(Root),
        directory_file_path(Root, '.venv/bin/python', P),
        exists_file(P)
    ->  Python = P
    ;   installation_python(P)
    ->  Python = P
    ;   Python = path(python3)
    ).

runtime_root(Root) :-
    module_property(rtl_rules, file(File)),
    file_directory_name(File, Runtime),
    file_directory_name(Runtime, Root).

%   The interpreter of the installation an installed runtime belongs to:
%   PREFIX/lib/pythonX.Y/site-packages/retalisc/prolog_runtime gives PREFIX/bin/python3
%   (a virtualenv, or the system's Python for dist-packages).
installation_python(Python) :-
    runtime_root(Package),
    file_directory_name(Package, SitePackages),
    file_base_name(SitePackages, Base),
    memberchk(Base, ['site-packages', 'dist-packages']),
    file_directory_name(SitePackages, PythonLib),
    file_directory_name(PythonLib, Lib),
    file_directory_name(Lib, Prefix),
    directory_file_path(Prefix, 'bin/python3', Python),
    exists_file(Python).

%   The compiler runs in the root of a source checkout (so that `python -m retalisc` finds
%   the package there without installing it), otherwise in the current directory.
compiler_directory(Dir) :-
    runtime_root(Root),
    (   directory_file_path(Root, 'retalisc/__init__.py', Init),
        exists_file(Init)
    ->  Dir = Root
    ;   working_directory(Dir, Dir)
    ).
