:- module(rtl_aq_api,
          [ aq_api_register/3,          % +Id, +GoalText, -AnswerLines
            aq_api_unregister/2,        % +Id, -Out
            aq_api_answers/2,           % +Id, -AnswerLines
            aq_api_id_text/2,           % +Id, -Text
            aq_api_assert/2,            % +FactTexts, -Out
            aq_api_retract/2,           % +FactTexts, -Out
            aq_api_add_rule/2,          % +RuleText, -Out
            aq_api_remove_rule/2,       % +RuleText, -Out
            aq_api_events/1,            % -EventLines
            aq_api_stats/1,             % -StatLines
            aq_api_unload/2,            % +File, -Out
            aq_api_reset/1,             % -Out
            aq_api_script_batch/4,      % +File, +From, +Max, -Out
            aq_api_save_state/3,        % +Path, +Identity, -Out
            aq_api_restore_state/3,     % +Path, +Identity, -Out
            aq_api_state_digest/1       % -Hash
          ]).

/** <module> The entry points of the Python ActiveQueries class: values as data

retalisc/driver/active_queries.py calls only these, through the bridge's fixed-goal call
(`rtl_aq_api:Name(Args..., Out)`): query ids are integers or strings (a string id is the
atom of that name), goals and facts are texts read here as exactly one term each
(rtl_read_text/4), never pasted into goal text. A registered goal can only be one atom of a
predicate of the program (aq_register/3 refuses anything else), so no other code runs; its
arguments are data. Out is a string: lines of writeq text.
*/

:- use_module(rtl_load, []).              % first: out-of-date .qlf files are not used
:- use_module(library(apply)).
:- use_module(library(lists)).
:- use_module(rtl_aq).
:- use_module(rtl_aq_script, [aq_script_batch/6]).
:- use_module(rtl_text).
:- use_module(rtl_state).

%!  aq_api_register(+Id, +GoalText:text, -Answers:string) is det.

aq_api_register(Id0, GoalText, Out) :-
    query_id(Id0, Id),
    rtl_read_text(GoalText, Goal, _, [module(user)]),
    aq_register(Id, user:Goal, Answers),
    term_lines(Answers, Out).

%!  aq_api_unregister(+Id, -Out) is det.

aq_api_unregister(Id0, "") :-
    query_id(Id0, Id),
    aq_unregister(Id).

%!  aq_api_answers(+Id, -Answers:string) is det.

aq_api_answers(Id0, Out) :-
    query_id(Id0, Id),
    aq_answers(Id, Answers),
    term_lines(Answers, Out).

%!  aq_api_id_text(+Id, -Text:string) is det.
%
%   The writeq text of the query id, as aq_api_events/1 writes it.

aq_api_id_text(Id0, Text) :-
    query_id(Id0, Id),
    format(string(Text), "~q", [Id]).

%!  aq_api_assert(+FactTexts:list, -Out) is det.
%!  aq_api_retract(+FactTexts:list, -Out) is det.
%
%   Assert (retract, in one DRed pass) the facts, each given as a text.

aq_api_assert(Texts, "") :-
    facts(Texts, Facts),
    aq_assert_all(Facts).

aq_api_retract(Texts, "") :-
    facts(Texts, Facts),
    aq_retract_all(Facts).

facts(Texts, Facts) :-
    must_be(list, Texts),
    maplist(fact, Texts, Facts).

fact(Text, Fact) :-
    rtl_read_text(Text, Fact, _, [module(user)]).

%!  aq_api_add_rule(+RuleText:text, -Out) is det.
%!  aq_api_remove_rule(+RuleText:text, -Out) is det.
%
%   Add (remove) the rule `H :- B` given as a text; rtl_aq_rules checks it
%   first (untrusted: program predicates and the definite builtins only).
%   A refused rule raises aq_rule_error(Message).

aq_api_add_rule(Text, "") :-
    rtl_read_text(Text, Rule, _, [module(user)]),
    aq_add_rule(Rule).

aq_api_remove_rule(Text, "") :-
    rtl_read_text(Text, Rule, _, [module(user)]),
    aq_remove_rule(Rule).

%!  aq_api_events(-Lines:string) is det.
%
%   The pending notifications, one line `Id<TAB>Op<TAB>Answer` each (writeq text).

aq_api_events(Out) :-
    aq_events(Events),
    with_output_to(string(Out),
                   forall(member(ev(I, O, A), Events), format("~q\t~w\t~q~n", [I, O, A]))).

%!  aq_api_stats(-Lines:string) is det.

aq_api_stats(Out) :-
    aq_stats(Stats),
    with_output_to(string(Out), forall(member(K=V, Stats), format("~w ~w~n", [K, V]))).

%!  aq_api_reset(-Out) is det.
%
%   Before another program replaces the one loaded: aq_reset_program/0.

aq_api_reset("") :-
    aq_reset_program.

%!  aq_api_unload(+File:text, -Out) is det.
%
%   Unload a program file loaded before (the Python side loads one program at a time).

aq_api_unload(FileText, "") :-
    must_be(text, FileText),
    atom_string(File, FileText),
    unload_file(File).

%!  aq_api_script_batch(+File:text, +From:integer, +Max:integer, -Out:string) is det.
%
%   Run at most Max commands of the update script File from its line From on
%   (aq_script_batch/6). Out is a first line `Next Status Exit Length`
%   (Status `more`, `done` or `error`; Exit the exit status of an error, else
%   0), then Length characters of the error message, then what the commands
%   printed (JSON Lines).

aq_api_script_batch(FileText, From, Max, Out) :-
    must_be(text, FileText),
    atom_string(File, FileText),
    aq_script_batch(File, From, Max, Output, Next, Status),
    (   Status = error(Exit, Message)
    ->  Word = error
    ;   Word = Status, Exit = 0, Message = ""
    ),
    string_length(Message, Length),
    format(string(Out), "~w ~w ~w ~w~n~w~w", [Next, Word, Exit, Length, Message, Output]).

%!  aq_api_save_state(+Path:text, +Identity:string, -Out) is det.
%!  aq_api_restore_state(+Path:text, +Identity:string, -Out) is det.
%!  aq_api_state_digest(-Hash:string) is det.
%
%   Snapshots of the active queries (rtl_state.pl): their tables, consumer
%   and goal records, the stored facts, the rules added at run time, the
%   globals and counters of rtl_aq. A snapshot of another program or runtime
%   version (Identity) is refused and nothing changes.

aq_api_save_state(Path, Identity, "") :-
    must_be(text, Path),
    must_be(string, Identity),
    aq_program(Program),
    rtl_state_save(Path, Identity, Program).

aq_api_restore_state(Path, Identity, "") :-
    must_be(text, Path),
    must_be(string, Identity),
    aq_program(Program),
    rtl_state_restore(Path, Identity, Program).

aq_api_state_digest(Hash) :-
    aq_program(Program),
    rtl_state_digest(Program, H),
    atom_string(H, Hash).

%   The state of an active-query program that lives in `user` (rtl_state.pl
%   saves every dynamic predicate of the rtl_ modules by itself): the rules
%   as transformed (with those added at run time), the kinds of predicates,
%   the stored facts and the goal records waiting for them.
aq_program(user-PIs) :-
    (   current_predicate(user:'$aq_kind'/2)
    ->  findall(PI, aq_state_predicate(PI), PIs0),
        sort(PIs0, PIs)
    ;   throw(error(existence_error(active_query_program, user), _))
    ).

aq_state_predicate(PI) :-
    member(PI, ['$aq_act'/2, '$aq_go'/3, '$aq_final'/6, '$aq_kind'/2]).
aq_state_predicate(Name/Arity) :-
    user:'$aq_fact_pred'(F),
    (   G = F
    ;   user:'$aq_whead'(F, _, G)
    ),
    functor(G, Name, Arity).

query_id(Id0, Id) :-
    (   integer(Id0)
    ->  Id = Id0
    ;   string(Id0)
    ->  atom_string(Id, Id0)
    ;   type_error(query_id, Id0)
    ).

term_lines(Terms, Out) :-
    with_output_to(string(Out), forall(member(T, Terms), format("~q~n", [T]))).
