:- module(retalisc_bridge,
          [ bridge/6,                   % +Mode, +GoalText, +Aux, -Status, -Out, -ErrTerm
            bridge_apply/6,             % +Module, +Name, +Args, -Status, -Out, -ErrTerm
            bridge_error/4,             % +Error, -Status, -Out, -ErrTerm
            text_of/2,                  % +Value, -Text
            claim_caller/1,             % -Claimed
            set_flags/0,
            rtl_python_call/4           % +Name, +Args, -Status, -Result
          ]).

/** <module> The Prolog half of the Python bridge (retalisc/driver/bridge.py)

Python reaches Prolog through two predicates only, called from C (pyswip's ctypes layer,
PL_call_predicate/4) or through janus:

  - bridge_apply/6, the call of the protocol (docs/architecture.md, "The Python/Prolog
    boundary"): `bridge_apply(Module, Name, Args, Status, Out, ErrTerm)` runs
    `Module:Name(Args..., Result)` once, Args values (strings, numbers, lists), never
    parsed. Status is 1 (success, Out the value of Result), 0 (failure) or 2 (error: Out the
    message printed by the runtime's one printer, rtl_error_text/2, ErrTerm the writeq text
    of the error term). Out is the text of Result: an atom, string or number as its text,
    any other term as its write text.
  - bridge/6, trusted goal text written by the programmer (tests and tools, never built
    from values): parse GoalText in module user and run it in one of five modes (0 true or
    false, 1 the writeq text of a template, 2 every solution's, 3 the text of a named
    variable, 4 consult a file, collecting the errors printed while loading).

When the calling thread owns the state (claim_caller/1), c/rtl_bridge_call.c runs an API
predicate itself, resolved once, with the values as its arguments (no goal built from names,
no catch/3 frame here): it calls bridge_error/4 for an exception and text_of/2 for an answer
that is neither an atom nor a string, so that both roads answer alike.

Neither ever raises: errors come back as Status 2, so Prolog exceptions never reach the C
interface or the debugger. Out and ErrTerm are always bound (janus cannot return unbound
variables).

## Where the requests run

The runtime keeps its state (clock, output buffer, current program) in global variables and
thread-local predicates, which belong to one Prolog thread. So that an Engine works from every
Python thread (ROS and zenoh callbacks come from other threads), every request runs in one
Prolog thread, the *owner*, created at the first request: the caller sends the request to the
owner's queue and waits for the answer on its own, inside one C call with the GIL released.
The handoff costs two wake-ups of the operating system (20 us on an idle machine, 60 to 90 us
on a busy one; benchmarks/call_cost.py). Looking for the other side's message a few hundred
times before sleeping was measured and made it worse on a machine with more threads than
cores. claim_caller/1 makes the calling thread itself the
owner instead (a command-line run: one Python thread), and requests then run in it at once.

A request that ends the owner thread (abort/0) loses its state; a new owner serves the next
requests and the caller is told so.

## Calls from Prolog into Python

rtl_python_call/4 calls python_call/4, which retalisc/driver/bridge.py defines as a foreign
predicate of this module (`Bridge.serve`); it fails when nothing defines it (janus, or a run
of `swipl OUT.pl` without Python).
*/

:- use_module(library(lists)).

:- thread_local collecting/0, collected/1.
:- dynamic owner_thread/1, caller_owned/0.

%!  bridge(+Mode:integer, +GoalText:text, +Aux:text, -Status, -Out, -ErrTerm) is det.
%
%   Run the trusted goal text GoalText in the owner (see the module documentation).

bridge(Mode, GoalText, Aux, Status, Out, ErrTerm) :-
    post(text(Mode, GoalText, Aux), Status, Out, ErrTerm).

%!  bridge_apply(+Module:text, +Name:text, +Args:list, -Status, -Out, -ErrTerm) is det.
%
%   Run Module:Name(Args..., Result) once in the owner: Args are values (strings, numbers,
%   lists), never parsed; Out is the text of Result.

bridge_apply(Module, Name, Args, Status, Out, ErrTerm) :-
    post(apply(Module, Name, Args), Status, Out, ErrTerm).

%   post(+Request, -Status, -Out, -ErrTerm): run Request where the state is.
post(Request, Status, Out, ErrTerm) :-
    owner(Owner),
    thread_self(Me),
    (   Me == Owner
    ->  handle(Request, reply(Status, Out, ErrTerm))
    ;   caller_owned
    ->  Status = 2,
        Out = "this process runs Prolog in one thread only (a command-line run): call from that thread",
        ErrTerm = ""
    ;   flag(retalisc_bridge_request, Id, Id + 1),
        thread_send_message(Owner, request(Me, Id, Request)),
        thread_get_message(answer(Id, Reply)),
        (   Reply = reply(Status, Out, ErrTerm)
        ->  true
        ;   Status = 2,
            Out = "the bridge's Prolog thread ended (its state is lost); a new one runs the next calls",
            ErrTerm = ""
        )
    ).

%   The owner thread runs every request, whichever thread posts it, so global variables and
%   thread-local predicates are the same for all callers. (A Prolog engine cannot serve
%   several OS threads in SWI-Prolog 9.0: it checks the C stack of the thread that created
%   it, and aborts, `stack_avail: Assertion failed: here > info->c_stack_base`, when another
%   thread runs it deep enough.)
owner(Owner) :-
    (   owner_thread(Owner)
    ->  true
    ;   with_mutex(retalisc_bridge, start_owner(Owner))
    ).

start_owner(Owner) :-
    (   owner_thread(Owner)
    ->  true
    ;   thread_create(serve, Owner, [detached(true), at_exit(owner_exit)]),
        assertz(owner_thread(Owner))
    ).

owner_exit :-
    retractall(owner_thread(_)),
    (   nb_current(retalisc_bridge_pending, From-Id)
    ->  catch(thread_send_message(From, answer(Id, ended)), _, true)
    ;   true
    ).

%   The owner's loop: take a request, answer it.
serve :-
    set_flags,
    repeat,
    thread_get_message(request(From, Id, Request)),
    nb_setval(retalisc_bridge_pending, From-Id),
    handle(Request, Reply),
    nb_setval(retalisc_bridge_pending, none),
    thread_send_message(From, answer(Id, Reply)),
    fail.

%!  claim_caller(-Claimed:atom) is det.
%
%   Make the calling thread the owner, so that its requests run in it at once, without the
%   handoff (a command-line run: one Python thread calls). Only before the first request:
%   Claimed is `true` when the calling thread owns the state now, `false` when the owner
%   thread already does.

claim_caller(Claimed) :-
    with_mutex(retalisc_bridge, claim_caller_(Claimed)).

claim_caller_(Claimed) :-
    thread_self(Me),
    (   owner_thread(Owner)
    ->  ( Owner == Me -> Claimed = true ; Claimed = false )
    ;   assertz(owner_thread(Me)),
        assertz(caller_owned),
        Claimed = true
    ).

handle(text(Mode, GoalText, Aux), reply(Status, Out, ErrTerm)) :-
    catch(run(Mode, GoalText, Aux, Status, Out), E,
          caught(E, Status, Out, ErrTerm)),
    !,
    ( var(ErrTerm) -> ErrTerm = "" ; true ).
handle(apply(Module, Name, Args), reply(Status, Out, ErrTerm)) :-
    catch(apply_goal(Module, Name, Args, Status, Out), E,
          caught(E, Status, Out, ErrTerm)),
    !,
    ( var(ErrTerm) -> ErrTerm = "" ; true ).
handle(_, reply(2, "bridge helper failed", "")).

apply_goal(ModuleText, NameText, Args, Status, Out) :-
    atom_string(Module, ModuleText),
    atom_string(Name, NameText),
    append(Args, [Result], AllArgs),
    Goal =.. [Name|AllArgs],
    (   call(Module:Goal)
    ->  Status = 1, text_of(Result, Out)
    ;   Status = 0, Out = ""
    ).

run(0, GT, _, Status, "") :-
    parse(GT, G, _),
    ( user:G -> Status = 1 ; Status = 0 ).
run(1, GT, TT, Status, Out) :-
    parse(GT, G, VG),
    parse(TT, T, VT),
    share_vars(VT, VG),
    ( user:G -> Status = 1, writeq_string(T, Out) ; Status = 0, Out = "" ).
run(2, GT, TT, 1, Out) :-
    parse(GT, G, VG),
    parse(TT, T, VT),
    share_vars(VT, VG),
    findall(T, user:G, Ts),
    maplist(writeq_string, Ts, Out).
run(3, GT, VarName, Status, Out) :-
    parse(GT, G, VG),
    atom_string(Name, VarName),
    (   memberchk(Name=V, VG)
    ->  true
    ;   throw(error(existence_error(variable, Name), context(bridge/6, GT)))
    ),
    ( user:G -> Status = 1, text_of(V, Out) ; Status = 0, Out = "" ).
run(4, Path, _, 1, "") :-
    consult_collecting(Path).

parse(Text, Term, Bindings) :-
    read_term_from_atom(Text, Term, [variable_names(Bindings)]).

share_vars([], _).
share_vars([Name=V|T], VG) :-
    ( memberchk(Name=V0, VG) -> V = V0 ; true ),
    share_vars(T, VG).

writeq_string(T, S) :-
    format(string(S), "~q", [T]).

%!  text_of(+Value, -Text:string) is det.
%
%   The text of an answer: a string itself, an atom or number its text, a code or char
%   list its string, any other term its write text. Raises on a variable.

text_of(V, _) :-
    var(V), !,
    throw(error(instantiation_error, context(bridge/6, _))).
text_of(V, S) :- string(V), !, S = V.
text_of(V, S) :- atomic(V), !, atom_string(V, S).
text_of(V, S) :- catch(text_to_string(V, S), _, fail), !.
text_of(V, S) :- format(string(S), "~w", [V]).

%!  bridge_error(+Error, -Status:integer, -Out:string, -ErrTerm:string) is det.
%
%   Status 2, Out the message of Error, ErrTerm its writeq text (a request that raised).

bridge_error(E, Status, Out, ErrTerm) :-
    caught(E, Status, Out, ErrTerm).

caught(bridge_load_errors(Msg), 2, Msg, "") :- !.
caught(E0, 2, Msg, Term) :-
    own_error(E0, E),
    catch(message_text(E, Msg), _, Msg = ""),
    catch(writeq_string(E, Term), _, Term = "").

%   An unknown procedure called directly by the request is reported with the bridge (this
%   module, or the C call of c/rtl_bridge_call.c) as its caller; drop that so the message and
%   the term read as for the user, alike on both roads.
own_error(error(Formal, Context0), error(Formal, Context)) :- !,
    own_context(Context0, Context).
own_error(E, E).

%   The error's text, by the runtime's one printer (rtl_error_text.pl), which never interprets
%   the term: an error may come from untrusted goal text. The printer is loaded at the first
%   error, so that a process that only loads the bridge loads none of the runtime.
message_text(bridge_load_errors(Msg), Msg) :- !.
message_text(E, Msg) :-
    error_printer,
    rtl_error_text:rtl_error_text(E, Msg).

error_printer :-
    (   current_predicate(rtl_error_text:rtl_error_text/2)
    ->  true
    ;   module_property(retalisc_bridge, file(Bridge)),
        file_directory_name(Bridge, Dir),
        directory_file_path(Dir, 'rtl_error_text.pl', File),
        use_module(File, [])
    ).

own_context(Context, context(_, Message)) :-
    nonvar(Context),
    Context = context(Caller, Message),
    nonvar(Caller),
    ( Caller = retalisc_bridge:_ ; Caller = system:'$c_call_prolog'/_ ), !.
own_context(Context, Context).

lines_text(Lines, Text) :-
    with_output_to(string(S),
                   print_message_lines(current_output, '', Lines)),
    split_string(S, "", "\n", [Text]).

%   Errors printed while loading do not make load_files/2 fail; collect them through
%   message_hook/3 and raise them together afterwards.
consult_collecting(PathText) :-
    atom_string(Path, PathText),
    retractall(collected(_)),
    setup_call_cleanup(assertz(collecting),
                       load_files(user:Path, []),
                       retractall(collecting)),
    findall(M, retract(collected(M)), Msgs),
    (   Msgs == []
    ->  true
    ;   atomic_list_concat(Msgs, '\n', Text),
        throw(bridge_load_errors(Text))
    ).

:- multifile user:message_hook/3.
user:message_hook(Term, error, Lines) :-
    collecting,
    lines_text(Lines, Text0),
    with_location(Term, Text0, Text),
    assertz(collected(Text)).

with_location(error(syntax_error(_), _), Text, Text) :- !.
with_location(_, Text0, Text) :-
    source_location(File, Line), !,
    format(string(Text), "~w:~w: ~w", [File, Line, Text0]).
with_location(_, Text, Text).

%!  set_flags is det.
%
%   The flags of an embedded runtime: no debugger on errors or interrupts, errors printed,
%   unknown procedures raise.

set_flags :-
    forall(flag_value(Flag, Value),
           catch(set_prolog_flag(Flag, Value), _, true)).

flag_value(debug_on_error, false).
flag_value(debug_on_interrupt, false).
flag_value(report_error, true).
flag_value(on_error, print).
flag_value(on_warning, print).
flag_value(tty_control, false).
flag_value(user:unknown, error).

%!  rtl_python_call(+Name:text, +Args:list(text), -Status:atom, -Result:string) is semidet.
%
%   Call the Python function served as Name (`Bridge.serve`) with the strings Args: Status
%   `ok` (Result its value), `error` (Result the message) or `unknown`. Fails when this
%   process has no Python serving functions.

rtl_python_call(Name, Args, Status, Result) :-
    current_predicate(python_call/4),
    python_call(Name, Args, Status, Result).
