:- module(rtl_query,
          [ rtl_query/5,                % +GoalText, +At, +Limit, -Answers, -Error
            rtl_query_lines/4,          % +GoalText, +At, +Limit, -Output
            rtl_time_goal/2,            % +Goal0, -Goal
            rtl_memory_request/2,       % +Text, -Error
            rtl_sync_query/5            % +GoalText, +At, +Timeout, ?QueryId, -Error
          ]).

/** <module> Queries from other components: SLR queries <Goal, Z> under the sandbox

A query arrives as text (from Python, the command line or a service). It is read as a
term with rtl_read_text/4 (its variable names kept, trailing text refused), its time terms
`E^T` / `E^[T1, T2]` are rewritten as the compiler rewrites them in the program (the
time becomes the last two arguments), and it must pass rtl_check_goal/4 (rtl_sandbox.pl):
what runs is the guarded goal that check gives. No file, shell or database side effects,
no halt, and no catch/3 of the time limit. The program's own predicates are checked like any code; the SLR query
predicates (prev, next, mem, ...) are declared safe there.

An answer is the list of `Name=Value` pairs of the goal's variables (those whose name does
not start with `_`), in the order they appear in the goal.
*/

:- use_module(library(time), [call_with_time_limit/2]).
:- use_module(rtl_sandbox).
:- use_module(rtl_goal_arguments).
:- use_module(rtl_error_text).
:- use_module(rtl_text).
:- use_module(rtl_ele).
:- use_module(rtl_slr).
:- use_module(rtl_io).
:- use_module(rtl_sync).

%!  rtl_query(+GoalText, +At, +Limit, -Answers:list, -Error) is det.
%
%   Run the query GoalText (a string) on the running program as <Goal, At> (At a number
%   of seconds or `inf`). Limit is `first` or `all`. Answers is a list of answers, each a
%   list of `Name=Value`. Error is unbound on success, else `syntax(Message)`,
%   `unsafe(Message)` or `failed(Message)` (the goal raised an error).

rtl_query(Text, At, Limit, Answers, Error) :-
    must_be(oneof([first, all]), Limit),
    rtl_program(M),
    read_goal(Text, M, Goal0, Bindings, Error),
    (   nonvar(Error)
    ->  Answers = []
    ;   rtl_time_goal(Goal0, Goal),
        in_temporary_module(Tmp,
                            add_import_module(Tmp, M, start),
                            checked_run(Limit, Tmp, Goal, At, Bindings, Answers, Error))
    ).

% The goal runs in a temporary module that inherits the program's predicates: what the
% sandbox allows it to assert goes there, and is gone with it.
checked_run(Limit, Tmp, Goal, At, Bindings, Answers, Error) :-
    catch(rtl_check_goal(query([Tmp]), Tmp, Goal, Guarded), Unsafe, true),
    (   nonvar(Unsafe)
    ->  unsafe_message(Unsafe, Tmp, Message),
        Error = unsafe(Message),
        Answers = []
    ;   unknown_memory(Goal, Message)
    ->  Error = failed(Message),
        Answers = []
    ;   run(Limit, Tmp, Guarded, At, Bindings, Answers, Error)
    ).

%   unknown_memory(+Goal, -Message): Goal calls a memory query (mem, prev, next, ...) on a
%   memory id that names no memory instance (never created, or deleted): an error naming
%   it, not a query with no answer.

unknown_memory(Goal, Message) :-
    sub_term(T, Goal), compound(T),
    compound_name_arity(T, Name, Arity),
    memory_query(Name, Arity),
    arg(1, T, Id),
    ground(Id),
    \+ exist_mem(Id),
    !,
    format(string(Message), "no memory instance ~q (never created, or deleted): ~q", [Id, Name/Arity]).

% The sandbox's refusal, without the name of the temporary module.
unsafe_message(Unsafe, Tmp, Message) :-
    rtl_error_text(Unsafe, Message0),
    format(atom(Prefix), "~q:", [Tmp]),
    atomic_list_concat(Parts, Prefix, Message0),
    atomic_list_concat(Parts, Message1),
    atom_string(Message1, Message).

read_goal(Text, M, Goal, Bindings, Error) :-
    catch(rtl_read_text(Text, Goal, Bindings, [module(M)]), SyntaxError, true),
    (   nonvar(SyntaxError)
    ->  syntax_message(SyntaxError, Text, Message),
        Error = syntax(Message)
    ;   var(Goal)
    ->  Error = syntax("the query must be a goal, not a variable")
    ;   callable(Goal)
    ->  true
    ;   format(string(Message), "~q is not a goal", [Goal]),
        Error = syntax(Message)
    ).

syntax_message(error(syntax_error(What), Context), Text, Message) :- !,
    (   Context = string(_, CharNo), integer(CharNo)
    ->  Column is CharNo + 1
    ;   Context = file(_, _, _, CharNo), integer(CharNo)
    ->  Column is CharNo + 1
    ;   string_length(Text, Length),
        Column is Length + 1
    ),
    format(string(Message), "1:~w: syntax error: ~w", [Column, What]).
syntax_message(Error, _, Message) :-
    rtl_error_text(Error, Message).

run(Limit, M, Goal, At, Bindings, Answers, Error) :-
    include(named, Bindings, Shown),
    rtl_flag(query_time_limit, Seconds),
    catch(call_with_time_limit(Seconds, all_or_first(Limit, M, Goal, At, Shown, Answers)),
          Raised,
          ( raised_message(Raised, Seconds, Message), Error = failed(Message), Answers = [] )).

all_or_first(first, M, Goal, At, Shown, Answers) :-
    (   rtl_with_view(At, M:Goal) -> Answers = [Shown] ; Answers = [] ).
all_or_first(all, M, Goal, At, Shown, Answers) :-
    findall(Shown, rtl_with_view(At, M:Goal), Answers).

raised_message(time_limit_exceeded, Seconds, Message) :- !,
    format(string(Message), "no answer within the query time limit (~w s)", [Seconds]).
raised_message(Error, _, Message) :-
    rtl_error_text(Error, Message).

named(Name=_) :-
    \+ sub_atom(Name, 0, _, _, '_').

%!  rtl_query_lines(+GoalText, +At, +Limit, -Output:string) is det.
%
%   rtl_query/5 with the answers as JSON Lines, one object per answer mapping each
%   variable name to its value written with writeq; or one line `!KIND<TAB>MESSAGE` when
%   the query was refused or raised an error.

rtl_query_lines(Text, At, Limit, Output) :-
    rtl_query(Text, At, Limit, Answers, Error),
    (   nonvar(Error)
    ->  Error =.. [Kind, Message],
        format(string(Output), "!~w\t~w~n", [Kind, Message])
    ;   maplist(answer_json, Answers, Lines),
        atomic_list_concat(Lines, Output0),
        atom_string(Output0, Output)
    ).

answer_json(Pairs, Line) :-
    maplist(pair_json, Pairs, Fields),
    atomic_list_concat(Fields, ', ', Body),
    format(string(Line), "{~w}~n", [Body]).

pair_json(Name=Value, Field) :-
    format(string(ValueText), "~q", [Value]),
    rtl_json_string_escape(Name, N),
    rtl_json_string_escape(ValueText, V),
    format(string(Field), "\"~w\": \"~w\"", [N, V]).

%!  rtl_memory_request(+Text:string, -Error) is det.
%
%   Create or delete memory instances on request from outside: Text is one of
%   `c_mem(Id, Query, N, L)`, `c_mem(Id, Query, N, L, Options)`,
%   `memorize(Event, Conds, Template, Id, N)`, `d_mem(IdPattern)`
%   or `delete_memory(IdPattern)`. The conditions of a new instance must pass the
%   sandbox. Error is unbound on success, else `syntax(Message)`, `unsafe(Message)` or
%   `failed(Message)`; nothing is created then.

rtl_memory_request(Text, Error) :-
    rtl_program(M),
    read_goal(Text, M, Request, _, Error),
    (   nonvar(Error)
    ->  true
    ;   memory_request_conditions(Request, Conds)
    ->  (   is_list(Conds) -> CondList = Conds ; CondList = [Conds] ),
        catch(( maplist(safe_condition(M), CondList, Guarded), Result = ok ), Unsafe,
              ( rtl_error_text(Unsafe, Message), Result = unsafe(Message) )),
        (   Result == ok
        ->  rtl_replace_goals(CondList, Guarded, Request, Checked),
            catch(M:Checked, Raised,
                  ( rtl_error_text(Raised, Message), Error = failed(Message) ))
        ;   Error = Result
        )
    ;   format(string(Message), "~q is not c_mem/4, c_mem/5, memorize/5, d_mem/1 or delete_memory/1", [Request]),
        Error = syntax(Message)
    ).

memory_request_conditions(c_mem(_, Query, _, _), Conds) :-
    (   nonvar(Query), Query = _-Conds0 -> Conds = Conds0 ; Conds = [] ).
memory_request_conditions(c_mem(Id, Query, N, L, _), Conds) :-
    memory_request_conditions(c_mem(Id, Query, N, L), Conds).
memory_request_conditions(memorize(_, Conds, _, _, _), Conds).
memory_request_conditions(d_mem(_), []).
memory_request_conditions(delete_memory(_), []).

safe_condition(M, Cond, Guarded) :-
    (   callable(Cond) -> rtl_check_goal(query([]), M, Cond, Guarded) ; type_error(callable, Cond) ).

%!  rtl_sync_query(+GoalText, +At, +Timeout, ?QueryId, -Error) is det.
%
%   Post the synchronized query <Goal, At> (thesis 4.2.5): it runs, like rtl_query/5 with
%   all answers, as soon as it is achievable (Def. 29): every memory in its dynamic goal set
%   (the memories and stream histories the goal can read, from the compiler's goal_set
%   declarations and the memory terms of the goal itself) holds a record after At, or its
%   history up to At is complete. Until then it waits, without delaying anything else. If
%   the clock reaches At + Timeout first (Timeout `inf`: never), its result is `timeout`.
%   The result is one output line, written when it is known:
%   `{"query": Id, "at": Z, "status": S, "answers": [...], "message": M}` with S one of
%   `answered`, `failed`, `timeout`, `dropped` (the input ended first, rtl_sync_finish(drop)).
%   QueryId is given or numbered. Error as for rtl_query/5 (the goal is read and checked by
%   the sandbox at once).

rtl_sync_query(Text, At, Timeout, QueryId, Error) :-
    rtl_program(M),
    read_goal(Text, M, Goal0, _, Error),
    (   nonvar(Error)
    ->  true
    ;   \+ number(At)
    ->  Error = syntax("a synchronized query needs a time (at)")
    ;   rtl_time_goal(Goal0, Goal),
        in_temporary_module(Tmp, add_import_module(Tmp, M, start),
                            ( catch(rtl_sandbox:rtl_check_goal(query([Tmp]), Tmp, Goal, _), Unsafe, true),
                              ( nonvar(Unsafe) -> unsafe_message(Unsafe, Tmp, Message) ; true ) )),
        (   nonvar(Unsafe)
        ->  Error = unsafe(Message)
        ;   unknown_memory(Goal, Message)
        ->  Error = failed(Message)
        ;   (   var(QueryId) -> flag(rtl_sync_query, Q0, Q0 + 1), QueryId is Q0 + 1 ; true ),
            (   Timeout == inf -> Until = inf ; Until is At + Timeout ),
            (   goal_reads_memory(Goal)
            ->  attempt(QueryId, Text, At, Until)
            ;   sync_answer(QueryId, Text, At, Until, ready)       % reads no history: nothing to wait for
            )
        )
    ).

% Evaluate the query, noting the histories it read; the answer is final when they are all
% complete (Def. 29), else wait for them and try again.
attempt(QueryId, Text, At, Until) :-
    rtl_with_needs(rtl_query(Text, At, all, Answers, Error), Needs),
    exclude(rtl_up_to_date, Needs, Open),
    (   Open == []
    ->  emit_answers(QueryId, At, Answers, Error)
    ;   rtl_postpone(Open, Until, rtl_query:sync_answer(QueryId, Text, At, Until))
    ).

% The compiler's dynamic goal sets (Def. 28) tell which goals read no history at all.
goal_reads_memory(Goal) :-
    sub_term(T, Goal), callable(T), goal_reads(T, _), !.

goal_reads(T, Pattern) :-
    functor(T, Name, Arity),
    (   rtl_goal_set(Name/Arity, Ids, Types)
    ->  (   member(Pattern, Ids)
        ;   member(Type, Types), Pattern = '$stream'(Type)
        )
    ;   memory_query(Name, Arity)
    ->  arg(1, T, Pattern)
    ;   stream_query(Name, Arity)
    ->  arg(1, T, Event0),
        (   nonvar(Event0), Event0 = Event^_ -> true ; Event = Event0 ),
        callable(Event),
        functor(Event, EN, EA),
        Pattern = '$stream'(EN/EA)
    ).

memory_query(mem, 2).
memory_query(prev, 3).
memory_query(next, 4).
memory_query(prev, 5).
memory_query(next, 6).
memory_query(next_inf, 5).
memory_query(access_mem, 3).

stream_query(prev, 2).
stream_query(next, 3).
stream_query(next, 2).

sync_answer(QueryId, Text, At, Until, ready) :-
    (   rtl_input_ended
    ->  rtl_query(Text, At, all, Answers, Error),           % every history is complete now
        emit_answers(QueryId, At, Answers, Error)
    ;   attempt(QueryId, Text, At, Until)
    ).
sync_answer(QueryId, _, At, _, timeout) :-
    emit_result(QueryId, At, timeout, [], "not achievable by the deadline").
sync_answer(QueryId, _, At, _, dropped) :-
    emit_result(QueryId, At, dropped, [], "the input ended before it was achievable").

emit_answers(QueryId, At, Answers, Error) :-
    (   var(Error)
    ->  emit_result(QueryId, At, answered, Answers, "")
    ;   Error =.. [_, Message],
        emit_result(QueryId, At, failed, [], Message)
    ).

emit_result(QueryId, At, Status, Answers, Message) :-
    maplist(answer_object, Answers, Objects),
    atomic_list_concat(Objects, ', ', Body),
    format(string(IdText), "~w", [QueryId]),
    rtl_json_string_escape(IdText, Id),
    rtl_json_string_escape(Message, M),
    format(string(Line), "{\"query\": \"~w\", \"at\": ~w, \"status\": \"~w\", \"answers\": [~w], \"message\": \"~w\"}",
           [Id, At, Status, Body, M]),
    rtl_emit_line(Line).

answer_object(Pairs, Object) :-
    maplist(pair_json, Pairs, Fields),
    atomic_list_concat(Fields, ', ', Body),
    format(string(Object), "{~w}", [Body]).

%!  rtl_time_goal(+Goal0, -Goal) is det.
%
%   Rewrite the time terms of a goal as the compiler rewrites those of the program
%   (retalisc/passes/slr_time_terms.py): `E^[T1, T2]` as E with T1 and T2 added as its last
%   two arguments, `E^T` as E with T, T added; through the goal arguments of the control
%   constructs and meta-predicates of rtl_goal_arguments/3, the table both read. The
%   arguments of prev, next and mem stay as they are: there `^` is data.

rtl_time_goal(G, G) :-
    var(G), !.
rtl_time_goal(E^Time, Goal) :-
    callable(E), !,
    (   is_list(Time), Time = [T1, T2]
    ->  true
    ;   T1 = Time, T2 = Time
    ),
    E =.. List0,
    append(List0, [T1, T2], List),
    Goal =.. List.
rtl_time_goal(G0, G) :-
    compound(G0),
    compound_name_arity(G0, Name, Arity),
    rtl_goal_arguments(Name, Arity, Positions), !,
    compound_name_arguments(G0, Name, Args0),
    timed_arguments(Args0, 1, Positions, Args),
    compound_name_arguments(G, Name, Args).
rtl_time_goal(G, G).

timed_arguments([], _, _, []).
timed_arguments([A0|As0], I, Positions, [A|As]) :-
    (   memberchk(I, Positions) -> rtl_time_goal(A0, A) ; A = A0 ),
    I1 is I + 1,
    timed_arguments(As0, I1, Positions, As).

