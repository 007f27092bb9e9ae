:- module(rtl_raise,
          [ new_event/1,                % +Event
            new_event/2,                % +Event, +Time
            new_event/3,                % +Event, +Secs, +NSecs
            rtl_input/4,                % +Op, +Event, +Start, +End
            rtl_input_block/1,          % :Goal
            rtl_block_input/3,          % +Event, +Start, +End
            rtl_raise_internal/3,       % +Event, +Start, +End
            rtl_flush_raised/0,
            rtl_guarded/1,              % :Goal
            rtl_drop_raised/0
          ]).

/** <module> Raising events from Prolog code (thesis Listing A.1)

new_event/1,2,3 raise a new *input* event from an action (`Head do Goal <- Pattern`), a
where condition, a static rule or a directive. The event is not processed on the spot:
it is queued and processed after the event being processed has been handled completely
(with everything it derived), in the order the events were raised. Events raised while
queued events are processed go to the end of the queue.

rtl_input/4 is the entry for events from outside (the JSON Lines readers, the Python
driver): it processes one event and then the queue. An event raised while no event is
being processed (at the top level, or by the Python driver) is processed at once; one
raised while a program is being loaded waits for the first input event (or
rtl_flush_raised/0).
*/

:- use_module(rtl_ele).
:- use_module(rtl_time).
:- use_module(rtl_halt).

:- meta_predicate rtl_guarded(0), rtl_input_block(0).

% The events raised and not processed yet, oldest first: a queue kept in the global
% variable rtl_raised (per thread, like the rest of the runtime's state), changed in place
% and never undone on backtracking: q(Front, Back), Front the first cell (or []), Back the
% last one (or []), each cell c(raised(Event, Start, End), Next) with Next [] at the end. An
% event is copied once, into its cell (nb_setarg/3); taking one unlinks its cell. (A
% dynamic predicate costs an assert and a retract per event: 1,900 raised events a second
% in the NAO application.)

%!  new_event(+Event) is det.
%!  new_event(+Event, +Time) is det.
%!  new_event(+Event, +Secs, +NSecs) is det.
%
%   Raise Event as an input event. Its time is the clock (the largest end time processed
%   so far; 0 before the first event) for new_event/1; Time for new_event/2, either one
%   time (an atomic event) or an interval `[T1, T2]`, each time a number of seconds, a
%   ROS stamp `[Secs, NSecs]` or `datime/7`; the ROS stamp `Secs + NSecs/10^9` for
%   new_event/3. Event must be ground.

new_event(Event) :-
    (   prolog_load_context(source, _)          % a directive: the program's clock has not started
    ->  T = 0
    ;   nb_current(rtl_clock, Clock), Clock =\= -inf
    ->  T = Clock
    ;   T = 0
    ),
    raise(Event, T, T).

new_event(Event, Time) :-
    (   time_interval(Time, Start, End)
    ->  raise(Event, Start, End)
    ;   type_error(event_time, Time)
    ).

new_event(Event, Secs, NSecs) :-
    (   integer(Secs), integer(NSecs)
    ->  rtl_time_seconds([Secs, NSecs], T),
        raise(Event, T, T)
    ;   type_error(ros_stamp, [Secs, NSecs])
    ).

% A list of two times is an interval; [Secs, NSecs] stamps are written new_event/3 or as
% one element of an interval: new_event(E, [[S1, N1], [S2, N2]]).
time_interval([T1, T2], Start, End) :- !,
    rtl_time_seconds(T1, Start),
    rtl_time_seconds(T2, End),
    Start =< End.
time_interval(T, Start, Start) :-
    rtl_time_seconds(T, Start).

raise(Event, Start, End) :-
    (   ground(Event), callable(Event)
    ->  true
    ;   var(Event)
    ->  instantiation_error(Event)
    ;   callable(Event)
    ->  throw(error(instantiation_error, context(new_event/1, 'an event must be ground')))
    ;   type_error(event, Event)
    ),
    (   nb_current(rtl_raise_busy, true)
    ->  enqueue(raised(Event, Start, End))
    ;   prolog_load_context(module, _)
    ->  enqueue(raised(Event, Start, End))
    ;   rtl_input(add, Event, Start, End)
    ).

%!  rtl_raise_internal(+Event, +Start, +End) is det.
%
%   Raise an internal event of the runtime (a memory event): queued like new_event/2, then
%   processed by rtl_internal_event/3 (event rules and subscriptions; it is not counted,
%   not written to the output and does not move the clock).

rtl_raise_internal(Event, Start, End) :-
    (   nb_current(rtl_raise_busy, true)
    ->  enqueue(raised('$internal'(Event), Start, End))
    ;   prolog_load_context(module, _)
    ->  enqueue(raised('$internal'(Event), Start, End))
    ;   b_setval(rtl_raise_busy, true),         % undone by an exception (see guarded/1)
        rtl_internal_event(Event, Start, End),
        drain,
        b_setval(rtl_raise_busy, false)
    ).

%!  rtl_input(+Op, +Event, +Start, +End) is det.
%
%   Process one input event (Op `add`) or deletion (Op `retract`), then every event raised
%   meanwhile. Events raised before (at load time) are processed first. Errors raised by
%   the program's rules propagate (the JSON Lines readers report them per event): see
%   guarded/1 for the step limit and halt.

rtl_input(Op, Event, Start, End) :-
    (   nb_current(rtl_raise_busy, true)
    ->  process(Op, Event, Start, End)           % nested call from a rule: no draining here
    ;   guarded(drained(Op, Event, Start, End))
    ).

%!  rtl_input_block(:Goal) is det.
%!  rtl_block_input(+Event, +Start, +End) is det.
%
%   A block of input events: Goal processes them one at a time with rtl_block_input/3,
%   which is rtl_input(add, Event, Start, End) without what a block sets once (the line
%   loop's run of plain event lines, retalis.pl). Goal runs as the events being processed
%   (`rtl_raise_busy`, set with b_setval/2 before the block, so that an error in one event
%   caught by the loop leaves it set for the next); each event keeps its own step limit,
%   its events raised meanwhile and its halt check. Only the line loop, outside any event,
%   opens a block.

rtl_input_block(Goal) :-
    b_setval(rtl_raise_busy, true),
    call(Goal),
    b_setval(rtl_raise_busy, false).

rtl_block_input(Event, Start, End) :-
    limited(drained(add, Event, Start, End)),
    rtl_halt_check.

% The event after the queued ones, then those it raised (a predicate: call/1 of a
% conjunction would compile it for every event).
drained(add, Event, Start, End) :-
    drain,
    rtl_event(Event, Start, End),
    drain.
drained(retract, Event, Start, End) :-
    drain,
    rtl_retract_event(Event, Start, End),
    drain.

%   guarded(:Goal) is det.
%
%   Run Goal, the processing of one input event, as the one being processed (events raised
%   meanwhile are queued) and within the step limit (the flag `max_steps`: inferences per
%   input event, everything it derives and raises included). A derivation that does not
%   end (a cyclic rule, a runaway recursion in a condition) raises
%   `error(rtl_step_limit(Max), _)`. A halt called by program code meanwhile is raised as
%   `rtl_halted(Reason)` (rtl_halt.pl). This runs for every input event, so it has no
%   catch/3 of its own: `rtl_raise_busy` is set with b_setval/2, which an exception or a
%   failure undoes. (The caller that reports an error drops the events still queued with
%   rtl_drop_raised/0.)

guarded(Goal) :-
    b_setval(rtl_raise_busy, true),
    limited(Goal),
    b_setval(rtl_raise_busy, false),
    rtl_halt_check.

%!  rtl_drop_raised is det.
%
%   Forget the events raised and not processed yet (after an event failed).

rtl_drop_raised :-
    nb_setval(rtl_raised, q([], [])).

limited(Goal) :-
    rtl_max_steps(Max),
    (   Max == inf
    ->  call(Goal)
    ;   call_with_inference_limit(Goal, Max, Result),
        (   Result == inference_limit_exceeded
        ->  throw(error(rtl_step_limit(Max), _))
        ;   true
        )
    ).

%!  rtl_guarded(:Goal) is det.
%
%   Run Goal (program code run outside an input event: the postponed matches at the end
%   of the input) as an event is run: the events it raises are queued and processed after
%   it, what it prints goes where the entry point sends it, and a halt in it is raised as
%   `rtl_halted(Reason)`. There is no step limit. After an error the caller drops the
%   events still queued (rtl_drop_raised/0).

rtl_guarded(Goal) :-
    (   nb_current(rtl_raise_busy, true)
    ->  call(Goal)
    ;   b_setval(rtl_raise_busy, true),         % undone by an exception (see guarded/1)
        call(Goal),
        drain,
        b_setval(rtl_raise_busy, false),
        rtl_halt_check
    ).

%!  rtl_flush_raised is det.
%
%   Process the events raised and not yet processed (those raised while the program was
%   being loaded).

rtl_flush_raised :-
    (   nb_current(rtl_raise_busy, true)
    ->  true
    ;   guarded(drain)
    ).

process(add, Event, Start, End) :-
    rtl_event(Event, Start, End).
process(retract, Event, Start, End) :-
    rtl_retract_event(Event, Start, End).

drain :-
    (   nb_current(rtl_raised, Q),                  % (the test of dequeue/1, inline: the queue
        arg(1, Q, c(_, _)),                         % is looked at twice for every input event)
        dequeue(raised(Raised, Start, End))
    ->  (   Raised = '$internal'(Event)
        ->  rtl_internal_event(Event, Start, End)
        ;   rtl_event(Raised, Start, End)
        ),
        drain
    ;   true
    ).

% enqueue(+Item): Item (ground) at the end of the queue, copied into a new last cell.
enqueue(Item) :-
    queue(Q),
    arg(2, Q, Back),
    (   Back == []
    ->  nb_setarg(1, Q, c(Item, [])),
        arg(1, Q, Cell)
    ;   nb_setarg(2, Back, c(Item, [])),
        arg(2, Back, Cell)
    ),
    nb_linkarg(2, Q, Cell).

% dequeue(-Item): the first item, taken off the queue; fails when it is empty.
dequeue(Item) :-
    nb_current(rtl_raised, Q),
    arg(1, Q, c(Item, Next)),
    nb_linkarg(1, Q, Next),
    (   Next == []
    ->  nb_linkarg(2, Q, [])
    ;   true
    ).

queue(Q) :-
    (   nb_current(rtl_raised, Q)
    ->  true
    ;   nb_setval(rtl_raised, q([], [])),
        nb_getval(rtl_raised, Q)
    ).
