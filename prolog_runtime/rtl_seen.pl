:- module(rtl_seen,
          [ rtl_seen_add/3,             % +Event, +Start, +End
            rtl_seen_add_atomic/1,      % +Items
            rtl_seen_take/3,            % +Event, +Start, +End
            rtl_seen_horizon/1,         % -Time
            rtl_seen_count/1,           % -Count
            rtl_seen_owner/2,           % ?Module, ?Program
            rtl_seen_fresh_module/1     % -Module
          ]).

/** <module> The input events seen recently, to check retractions against

A retraction (`"op": "retract"`) deletes an input event added before. To tell a retraction
of an event that was never added (a typo, a replayed deletion) from a real one, the runtime
remembers the input events it was given, each occurrence once, in arrival order, and
forgets them as the clock moves on: an event ending more than `max_delay` plus the largest
window of the program's stores before the clock is forgotten (with `max_delay` `inf`
nothing is). A retraction of an event that is not remembered and ends after that horizon
is refused; one of an older event cannot be checked and is processed as before.

The store belongs to the program that was active when its events came (rtl_use_program/1):
each program has its own generations, and switching programs parks the open generation of
the one left and takes up that of the one activated, so an Engine's retraction checks see
its own events only and its snapshot holds only them.

Memory is proportional to the event rate times `max_delay + window` (plus a few thousand
events), as for the partial matches (docs/runtime.md).
*/

:- use_module(library(lists)).
:- use_module(rtl_ele).

:- dynamic generation/3.        % generation(Program, Module, End): its events are Module:seen(Event, Start, End0)
:- dynamic free_generation/2.   % free_generation(Program, Module): not in use
:- dynamic parked/3.            % parked(Program, Module, Size): the open generation of a program not active

%!  rtl_seen_add(+Event, +Start, +End) is det.
%
%   Remember one input event. Events are remembered in generations of about 1,024 input
%   events, each in a module of its own (`rtl_seen_<N>:seen/3` and `seen_atomic/1`); when a
%   generation is closed, the generations whose events all end before the horizon are
%   dropped whole (this runs for every input event: erasing events one by one would cost
%   more than remembering them).

rtl_seen_add(Event, Start, End) :-
    open_generation_name(Name),
    assertz(Name:seen(Event, Start, End)),
    grow_generation(Name, 1, End).

%!  rtl_seen_add_atomic(+Items:list) is det.
%
%   Remember the input events of Items, each `a(Event, T)`: Event at the one time T (the
%   items of rtl_buffered_lines/3, in order), as rtl_seen_add(Event, T, T) for each, in one
%   clause (`seen_atomic(Items)`): a block of lines read at once costs one assertz/1, not
%   one per line.

rtl_seen_add_atomic([]) :- !.
rtl_seen_add_atomic(Items) :-
    open_generation_name(Name),
    assertz(Name:seen_atomic(Items)),
    items_latest(Items, 0, Count, -inf, Latest),
    grow_generation(Name, Count, Latest).

items_latest([], N, N, Latest, Latest).
items_latest([a(_, T)|Items], N0, N, Latest0, Latest) :-
    N1 is N0 + 1,
    (   T > Latest0 -> Latest1 = T ; Latest1 = Latest0 ),
    items_latest(Items, N1, N, Latest1, Latest).

% The open generation Name got Added events, the latest ending at Latest: closed once it
% holds 1,024.
grow_generation(Name, Added, Latest) :-
    generation_size(Size0),
    Size is Size0 + Added,
    (   Size >= 1024
    ->  close_generation(Name, Latest)
    ;   nb_linkval(rtl_seen_size, Size)             % (a number: no copy needed)
    ).

% (A snapshot of an older runtime has no size: its generation counts as empty.)
generation_size(Size) :-
    (   nb_current(rtl_seen_size, Size) -> true ; Size = 0 ).

open_generation_name(Name) :-
    (   nb_current(rtl_seen_generation, Name), Name \== []
    ->  true
    ;   open_generation(Name)
    ).

%!  rtl_seen_take(+Event, +Start, +End) is semidet.
%
%   Forget one remembered occurrence of the input event; fails when there is none.

rtl_seen_take(Event, Start, End) :-
    (   nb_current(rtl_seen_generation, Name), Name \== []
    ;   active_program(P),
        generation(P, Name, _)
    ),
    generation_take(Name, Event, Start, End),
    !.

generation_take(Name, Event, Start, End) :-
    clause(Name:seen(Event, Start0, End0), true, Ref),
    Start0 =:= Start, End0 =:= End,
    !,
    erase(Ref).
generation_take(Name, Event, Start, End) :-
    Start =:= End,
    clause(Name:seen_atomic(Items), true, Ref),
    select(a(Event, T), Items, Rest),
    T =:= End,
    !,
    erase(Ref),
    (   Rest == [] -> true ; assertz(Name:seen_atomic(Rest)) ).

% The modules of dropped generations are used again (modules are never deleted).
open_generation(Name) :-
    active_program(P),
    (   retract(free_generation(P, Name))
    ->  true
    ;   rtl_seen_fresh_module(Name)
    ),
    dynamic([Name:seen/3, Name:seen_atomic/1]),
    nb_setval(rtl_seen_size, 0),
    nb_setval(rtl_seen_generation, Name).

% Every event of the generation ends at the latest at the clock or at End (the latest of
% those just added, not processed yet).
close_generation(Name, End) :-
    rtl_clock(Clock),
    GenerationEnd is max(Clock, End),
    active_program(P),
    assertz(generation(P, Name, GenerationEnd)),
    nb_setval(rtl_seen_generation, []),
    nb_setval(rtl_seen_size, 0),
    rtl_seen_horizon(Horizon),
    forall(( generation(P, Old, OldEnd), OldEnd < Horizon ),
           drop_generation(P, Old)).

drop_generation(P, Name) :-
    retractall(generation(P, Name, _)),
    retractall(Name:seen(_, _, _)),
    retractall(Name:seen_atomic(_)),
    assertz(free_generation(P, Name)).

% The program whose events are remembered (`[]` before any: a runtime used without one).
active_program(P) :-
    (   rtl_program(P0) -> P = P0 ; P = [] ).

%!  rtl_seen_fresh_module(-Module) is det.
%
%   A generation module no program holds (rtl_seen_owner/2): the counter may be behind the
%   modules in use after a snapshot restored its value.

rtl_seen_fresh_module(Name) :-
    repeat,
    flag(rtl_seen_generations, G, G + 1),
    format(atom(Name), 'rtl_seen_~d', [G]),
    \+ rtl_seen_owner(Name, _),
    !.

%!  rtl_seen_owner(?Module, ?Program) is nondet.
%
%   Module is a generation module of Program: a closed or free generation of it, its open
%   generation, or the parked open generation of a program not active.

rtl_seen_owner(Name, P) :-
    (   generation(P, Name, _)
    ;   free_generation(P, Name)
    ;   parked(P, Name, _)
    ;   nb_current(rtl_seen_generation, Name), Name \== [], active_program(P)
    ).

% Switching programs: the open generation of the program left is parked, that of the one
% activated taken up.
:- multifile rtl_ele:program_hook/2.
rtl_ele:program_hook(Old, New) :-
    (   Old == New
    ->  true
    ;   (   nb_current(rtl_seen_generation, Name), Name \== []
        ->  generation_size(Size),
            retractall(parked(Old, _, _)),
            assertz(parked(Old, Name, Size))
        ;   true
        ),
        (   retract(parked(New, NewName, NewSize))
        ->  nb_setval(rtl_seen_generation, NewName),
            nb_setval(rtl_seen_size, NewSize)
        ;   nb_setval(rtl_seen_generation, []),
            nb_setval(rtl_seen_size, 0)
        )
    ).

%!  rtl_seen_count(-Count) is det.
%
%   The number of input events remembered.

rtl_seen_count(Count) :-
    active_program(P),
    findall(Name, ( nb_current(rtl_seen_generation, Name), Name \== [] ; generation(P, Name, _) ), Names),
    aggregate_all(sum(N), ( member(Name, Names),
                            predicate_property(Name:seen(_, _, _), number_of_clauses(N)) ), Singles),
    aggregate_all(sum(N), ( member(Name, Names),
                            Name:seen_atomic(Items),
                            length(Items, N) ), Atomic),
    Count is Singles + Atomic.

%!  rtl_seen_horizon(-Time) is det.
%
%   Events ending before Time are no longer remembered (`-inf` when nothing is forgotten).

rtl_seen_horizon(Horizon) :-
    rtl_flag(max_delay, Delay),
    (   Delay == inf
    ->  Horizon = -inf
    ;   rtl_clock(Clock),
        (   rtl_program(M),
            aggregate_all(max(W), ( M:ele_store(_, _, W), number(W) ), MaxWindow0)
        ->  MaxWindow = MaxWindow0
        ;   MaxWindow = 0
        ),
        (   Clock =:= -inf -> Horizon = -inf ; Horizon is Clock - Delay - MaxWindow )
    ).

:- multifile rtl_ele:clear_hook/0.
rtl_ele:clear_hook :-                            % the active program's store only
    active_program(P),
    forall(generation(P, Name, _), drop_generation(P, Name)),
    (   nb_current(rtl_seen_generation, Name), Name \== []
    ->  retractall(Name:seen(_, _, _)),
        retractall(Name:seen_atomic(_)),
        assertz(free_generation(P, Name))
    ;   true
    ),
    nb_setval(rtl_seen_generation, []),
    nb_setval(rtl_seen_size, 0).
