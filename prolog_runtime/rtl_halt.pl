:- module(rtl_halt,
          [ rtl_halt_check/0,
            rtl_take_halted/1,          % -Reason
            rtl_exit/1,                 % +Status
            rtl_action_context/2        % +Goal, :Call
          ]).

/** <module> `halt` called by program code

A program may call halt/0,1 from a `do` action, a `where` condition, a static rule or a
directive. Ending the process on the spot would lose the output still buffered (and, in
the Python driver, the Python process with it) and would end with status 0 as if the input
had been processed. Instead an at_halt/1 hook cancels such a halt while an event is being
processed or a program is being loaded, and records where it happened:

  - during an event, halt/0,1 fails; when the event has been processed, rtl_halt_check/0
    raises `rtl_halted(Reason)`, which the line loop reports as
    `EVENTS:LINE: error: the program called halt ... while processing EVENT` before it
    flushes the output and ends the run with status 1;
  - in a directive, loading goes on; the entry points ask rtl_take_halted/1 before the
    first event and end the run with status 1 after saying where.

The runtime's own exits go through rtl_exit/1, which the hook lets pass, as it lets pass
every halt outside those two situations (the end of a Python process, the top level).
*/

:- meta_predicate rtl_action_context(+, 0).

:- initialization(at_halt(rtl_halt:halt_hook)).

%!  rtl_exit(+Status) is det.
%
%   End the process with Status (the runtime's own exit; not cancelled).

rtl_exit(Status) :-
    nb_setval(rtl_exiting, true),
    halt(Status).

%!  rtl_halt_check is det.
%
%   Raise `rtl_halted(Reason)` if program code called halt during the current event.

rtl_halt_check :-
    (   nb_current(rtl_halt_event, Reason), Reason \== []
    ->  nb_setval(rtl_halt_event, []),
        throw(rtl_halted(Reason))
    ;   true
    ).

%!  rtl_take_halted(-Reason:string) is semidet.
%
%   A directive of the program called halt while it was loaded; Reason says where. The
%   record is removed.

rtl_take_halted(Reason) :-
    nb_current(rtl_halt_load, Reason),
    Reason \== [],
    nb_setval(rtl_halt_load, []).

%!  rtl_action_context(+Goal, :Call) is semidet.
%
%   Run Call, the action Goal of a rule, so that a halt in it can be reported as being in
%   that action.

rtl_action_context(Goal, Call) :-
    b_setval(rtl_action_goal, Goal),
    call(Call),
    b_setval(rtl_action_goal, []).

halt_hook :-
    \+ nb_current(rtl_exiting, true),
    (   nb_current(rtl_raise_busy, true)
    ->  (   b_getval_default(rtl_action_goal, Goal0), Goal0 \== []
        ->  strip_module(Goal0, _, Goal),
            format(string(Reason), "the program called halt (in the action ~q)", [Goal])
        ;   Reason = "the program called halt"
        ),
        nb_setval(rtl_halt_event, Reason)
    ;   prolog_load_context(module, Module),
        Module \== user,
        current_predicate(Module:ele_trigger/3)
    ->  (   prolog_load_context(term, Term), nonvar(Term), Term = (:- Directive)
        ->  true
        ;   Directive = halt
        ),
        (   source_location(File, Line)
        ->  format(string(Reason), "~w:~w: error: the program called halt in the directive :- ~q",
                   [File, Line, Directive])
        ;   format(string(Reason), "error: the program called halt in the directive :- ~q", [Directive])
        ),
        nb_setval(rtl_halt_load, Reason)
    ),
    !,
    cancel_halt(rtl_halt).
halt_hook.

b_getval_default(Name, Value) :-
    catch(b_getval(Name, Value), _, fail).

% The hook's cancellation is reported by the runtime, not as "Halt cancelled".
:- multifile user:message_hook/3.
user:message_hook(cancel_halt(rtl_halt), _, _).
