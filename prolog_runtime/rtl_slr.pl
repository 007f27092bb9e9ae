:- module(rtl_slr,
          [ c_mem/4,                    % +Id, +Query, +N, +L                     (thesis Def. 21)
            c_mem/5,                    % +Id, +Query, +N, +L, +Options
            d_mem/1,                    % ?IdPattern
            exist_mem/1,                % ?Id
            memorize/5,                 % +Event, +Conds, ?Template, +Id, +N      (Retalis 2015)
            delete_memory/1,            % ?IdPattern                             (Retalis 2015)
            stream_history/1,           % +Name/Arity
            stream_history/3,           % +Name/Arity, +N, +L
            mem/2,                      % ?Id, ?Event                            (Def. 22)
            rtl_slr_rebuild_index/1,    % +Program
            prev/2,                     % ?Event, +Zs                            (Def. 19)
            prev/3,                     % ?Id, ?Event, +Zs                       (Def. 23)
            next/2,                     % ?Event, +[Zs, Ze]                      (thesis rule 4.7)
            next/3,                     % ?Event, +Zs, +Ze                       (Def. 20)
            next/4,                     % ?Id, ?Event, +Zs, +Ze                  (Def. 24)
            access_mem/3,               % ?Id, ?Event, ?[T1, T2]                 (Retalis 2015)
            prev/5,                     % ?Id, ?Event, ?T1, ?T2, +Z              (Retalis 2015)
            next/6,                     % ?Id, ?Event, ?T1, ?T2, +Zs, +Ze        (Retalis 2015)
            next_inf/5,                 % ?Id, ?Event, ?T1, ?T2, +Zs             (Retalis 2015)
            rtl_memory/5,               % ?Id, ?Query, ?Template, ?N, ?L
            rtl_memory_size/2,          % ?Id, -Records
            rtl_memory_records/2,       % +Id, -Records
            rtl_memory_last_end/2,      % +Id, -End
            rtl_memory_type/2,          % ?Id, -Name/Arity
            rtl_with_view/2,            % +Z, :Goal
            rtl_with_needs/2,           % :Goal, -Needs
            rtl_slr_clock_moved/1,      % +Clock
            rtl_slr_type_hook/1,        % @Hook
            rtl_slr_watch_predicate/1,  % @Name
            rtl_slr_clear/0
          ]).

/** <module> SLR: memory instances and queries over event histories (thesis 4.2, 5.2.1-5.2.2)

A *memory instance* keeps a selected history of the event flow: the events (input or
derived) that unify with its pattern and satisfy its conditions, recorded in its template
form, at most the N most recent in the order of records and only those whose end time is
not beyond L seconds behind the component's clock (the largest end time processed; event
time; rtl_time:rtl_beyond_bound/3). The *order of records* is by end time, then start time,
then the standard order of the templates (record_after/6): ties are broken by the events,
not by their arrival, so without deletions what an instance holds does not depend on the
arrival order (Def. 21).

Cost model (thesis 5.2.1, 5.2.2):

  - Records of instance H are numbered in the order of records, First..Last, and stored as
    `record(Key, Start, End, Template)` with `Key = H * 2^40 + Number`: the first-argument
    index finds a record by (instance, number) in constant time.
  - An event that arrives in end-time order is appended (number Last+1): constant time.
    A late event is inserted at its place by binary search, moving the records on the
    shorter side of it by one number: the cost grows with how late it is, not with the
    size of the memory.
  - Forgetting takes the record numbered First: constant time. Forgetting by time happens
    when the clock moves (rtl_slr_clock_moved/1), not when the instance is next used.
  - prev/next find their starting point by binary search on the numbers (logarithmic)
    and then walk towards older/newer records until one unifies with the pattern.
  - Instances are found per event through one dynamic predicate per event type
    (Name/Arity) whose first argument is the hash of the pattern's constant arguments
    (its mask: the positions of its atomic arguments, rtl_pattern_key.pl); the event is
    hashed under each mask in use for the type, so an event of a type no instance records costs one failed
    lookup, and an instance with a constant the event does not have is not even tried.

Memory events (thesis 4.2.4) are raised, and fed to the event rules and subscriptions,
when something can receive them (an event rule or a subscription on them):
`memory_created(Pattern, Conds, Template, Id, N)`, `memory_deleted(Id)`,
`memory_updated(Id, End)` for every record added, and, for instances created with the
option `record_events(true)`, `memory_record_added(Id, Record)` and
`memory_record_forgotten(Id, Record)` with the record's own interval: one for every record
that enters and one for every record that leaves (by the count limit, by the time limit as
the clock moves, or by a deletion); a late record that a full instance does not keep raises
none.

Queries see the records a memory holds. mem/2 also respects the *stream view* of the
query being answered (rtl_with_view/2, Def. 16-18): only records whose end time is at
most Z. prev and next are bounded by their own time arguments instead (text under
Def. 18). A time argument that is not bound raises an instantiation error.
*/

:- use_module(rtl_guard, [rtl_condition_raised/3]).
:- use_module(rtl_ele).
:- use_module(rtl_time).
:- use_module(rtl_raise).
:- use_module(rtl_time_index).
:- use_module(rtl_pattern_key, [rtl_pattern_mask/2, rtl_pattern_key/3]).
:- use_module(rtl_subscriptions, [rtl_subscribed/1]).

:- meta_predicate rtl_with_view(+, 0), rtl_with_needs(0, -).

% instance(H, Program, Id, Pattern, Conds, Template, N, L, Options)
:- dynamic instance/9.
% id_handle(Program, Id, H)
:- dynamic id_handle/3.
% watch_predicate(Name, Arity, Predicate): the per-type instance index
:- dynamic watch_predicate/3.
% record(Key, Start, End, Template)
:- dynamic record/4.
% stream_memory(Program, Name, Arity, H): the history behind prev/2 and next/3
:- dynamic stream_memory/4.
% need(Id, Time): while rtl_with_needs/2 runs, the histories its goal's answers depend on
:- dynamic need/2.
% bounds_name(H, Name): the global variable holding the bounds of instance H
:- dynamic bounds_name/2.

:- multifile retalis:rtl_declaration_handler/3.
retalis:rtl_declaration_handler(c_mem, 4, rtl_slr).
retalis:rtl_declaration_handler(c_mem, 5, rtl_slr).
retalis:rtl_declaration_handler(d_mem, 1, rtl_slr).
retalis:rtl_declaration_handler(memorize, 5, rtl_slr).
retalis:rtl_declaration_handler(delete_memory, 1, rtl_slr).
retalis:rtl_declaration_handler(stream_history, 1, rtl_slr).
retalis:rtl_declaration_handler(stream_history, 3, rtl_slr).

%!  rtl_slr:memory_update_hook(+Program, +Id, +Start, +End) is det.
%
%   Multifile: called after a record with interval [Start, End] was added to memory Id
%   (synchronization monitors use it).

:- multifile memory_update_hook/4.
:- dynamic memory_update_hook/4.

%!  rtl_slr:instance_created_hook(+Program, +Id) is det.
%
%   Multifile: called after memory instance Id was created.

:- multifile instance_created_hook/2.
:- dynamic instance_created_hook/2.

key_base(1099511627776).                 % 2^40 numbers per instance (key/3 inlines it)
number_origin(549755813888).             % 2^39: room to number late records downwards

% ---- creating and deleting instances ----------------------------------------------------

%!  c_mem(+Id, +Query, +N, +L) is det.
%!  c_mem(+Id, +Query, +N, +L, +Options) is det.
%
%   Create memory instance Id (a ground term) recording the events that match Query,
%   written `Event-Conds` (Conds a list of goals run in the program's module) or `Event`:
%   at most N records (`inf`: no limit), each with its end time within the last L seconds
%   of the clock (`inf`: no limit). Records are the events themselves. Options:
%   `record_events(Bool)` raises memory_record_added/2 and memory_record_forgotten/2.
%   Raises a permission error if an instance Id exists already.

c_mem(Id, Query, N, L) :-
    c_mem(Id, Query, N, L, []).

c_mem(Id, Query, N, L, Options) :-
    query_parts(Query, Pattern, Conds, c_mem/4),
    create_instance(Id, Pattern, Conds, Pattern, N, L, Options, c_mem/4).

%!  memorize(+Event, +Conds:list, ?Template, +Id, +N) is det.
%
%   Retalis 2015 form: keep the last N events matching Event and Conds as Template (the
%   event itself when Template is unbound), with no time limit.

memorize(Event, Conds, Template, Id, N) :-
    (   var(Template) -> Template = Event ; true ),
    create_instance(Id, Event, Conds, Template, N, inf, [], memorize/5).

%!  stream_history(+Name/Arity) is det.
%!  stream_history(+Name/Arity, +N, +L) is det.
%
%   Keep the history of events of type Name/Arity that the stream forms prev/2, next/2
%   and next/3 query: the last N within L seconds (stream_history/1: all of them). The
%   compiler declares one for every event type such a query names in the program; a
%   declaration of the program itself sets the limits.

stream_history(Type) :-
    stream_history(Type, inf, inf).

stream_history(Type, N, L) :-
    (   Type = Name/Arity, atom(Name), integer(Arity), Arity >= 0
    ->  true
    ;   throw(error(type_error(event_type, Type), context(stream_history/3, 'write Name/Arity')))
    ),
    current_program(M),
    (   stream_memory(M, Name, Arity, H)
    ->  instance(H, M, Id, _, _, _, _, _, _),
        remove_instance(M, H, Id)
    ;   true
    ),
    functor(Pattern, Name, Arity),
    Id = '$stream'(Name/Arity),
    create_instance(Id, Pattern, [], Pattern, N, L, [], stream_history/3),
    id_handle(M, Id, NewH),
    assertz(stream_memory(M, Name, Arity, NewH)).

create_instance(Id, Pattern, Conds, Template, N, L, Options, Culprit) :-
    current_program(M),
    check_instance(Id, Pattern, Conds, N, L, Options, Culprit),
    (   id_handle(M, Id, _)
    ->  throw(error(permission_error(create, memory_instance, Id),
                    context(Culprit, 'a memory instance with this id exists (d_mem/1 deletes it)')))
    ;   true
    ),
    flag(rtl_slr_handle, H0, H0 + 1),
    H is H0 + 1,
    assertz(instance(H, M, Id, Pattern, Conds, Template, N, L, Options)),
    assertz(id_handle(M, Id, H)),
    reset_bounds(H),
    watch(M, Pattern, H),
    forall(instance_created_hook(M, Id), true),
    memory_event(M, memory_created(Pattern, Conds, Template, Id, N)).

check_instance(Id, Pattern, Conds, N, L, Options, Culprit) :-
    (   ground(Id) -> true
    ;   throw(error(instantiation_error, context(Culprit, 'a memory id must be ground')))
    ),
    (   callable(Pattern) -> true
    ;   throw(error(type_error(event_pattern, Pattern),
                    context(Culprit, 'the pattern must be an event atom')))
    ),
    (   is_list(Conds), maplist(callable, Conds) -> true
    ;   throw(error(type_error(list_of_goals, Conds),
                    context(Culprit, 'the conditions must be a list of goals')))
    ),
    (   N == inf -> true
    ;   integer(N), N >= 1 -> true
    ;   throw(error(domain_error(memory_size, N), context(Culprit, 'a size is a positive integer or inf')))
    ),
    (   L == inf -> true
    ;   number(L), L >= 0 -> true
    ;   throw(error(domain_error(time_limit, L),
                    context(Culprit, 'a time limit is a number of seconds >= 0 or inf')))
    ),
    (   is_list(Options), forall(member(O, Options), memory_option(O)) -> true
    ;   throw(error(domain_error(memory_options, Options),
                    context(Culprit, 'the options are a list of record_events(true) or record_events(false)')))
    ).

memory_option(O) :-
    nonvar(O),
    O = record_events(B),
    ( B == true ; B == false ), !.

%!  d_mem(?IdPattern) is det.
%!  delete_memory(?IdPattern) is det.
%
%   Delete every memory instance whose id unifies with IdPattern, with its records.

d_mem(IdPattern) :-
    current_program(M),
    findall(H-Id, ( id_handle(M, Id0, H), \+ Id0 = '$stream'(_), Id0 = IdPattern, Id = Id0 ),
            Found),
    forall(member(H-Id, Found), remove_instance(M, H, Id)).

delete_memory(IdPattern) :-
    d_mem(IdPattern).

remove_instance(M, H, Id) :-
    bounds(H, First, Last),
    forall(between(First, Last, Number), ( key(H, Number, Key), retractall(record(Key, _, _, _)) )),
    retract(instance(H, M, Id, Pattern, _, _, _, _, _)),
    retractall(id_handle(M, Id, H)),
    retractall(stream_memory(M, _, _, H)),
    unwatch(M, Pattern, H),
    unschedule_expiry(H, M),
    bounds_key(H, BKey),
    nb_delete(BKey),
    retractall(bounds_name(H, _)),
    memory_event(M, memory_deleted(Id)).

%!  exist_mem(?Id) is nondet.
%
%   Id is (unifies with) the id of a memory instance of the running program.

exist_mem(Id) :-
    current_program(M),
    id_handle(M, Id, _),
    \+ Id = '$stream'(_).

%!  rtl_memory(?Id, ?Query, ?Template, ?N, ?L) is nondet.
%
%   The memory instances of the running program: Query is `Pattern-Conds`.

rtl_memory(Id, Pattern-Conds, Template, N, L) :-
    current_program(M),
    instance(_, M, Id, Pattern, Conds, Template, N, L, _).

%!  rtl_memory_size(?Id, -Records:integer) is nondet.

rtl_memory_size(Id, Size) :-
    current_program(M),
    id_handle(M, Id, H),
    bounds(H, First, Last),
    Size is Last - First + 1.

%!  rtl_memory_type(?Id, -Type) is nondet.
%
%   Type is `Name/Arity` of the events memory Id records.

rtl_memory_type(Id, Name/Arity) :-
    current_program(M),
    instance(_, M, Id, Pattern, _, _, _, _, _),
    functor(Pattern, Name, Arity).

%!  rtl_memory_last_end(+Id, -End:number) is semidet.
%
%   End is the end time of the latest record of memory Id; fails when it has none.

rtl_memory_last_end(Id, End) :-
    current_program(M),
    id_handle(M, Id, H),
    bounds(H, First, Last),
    Last >= First,
    key(H, Last, Key),
    record(Key, _, End, _).

%!  rtl_memory_records(+Id, -Records:list) is det.
%
%   The records of memory Id, oldest first, as `Template^[Start, End]`.

rtl_memory_records(Id, Records) :-
    current_program(M),
    (   id_handle(M, Id, H)
    ->  bounds(H, First, Last),
        findall(T^[S, E], ( between(First, Last, Number), key(H, Number, Key),
                            record(Key, S, E, T) ), Records)
    ;   existence_error(memory_instance, Id)
    ).

%   The clock moved past the next expiry of a memory record (rtl_ele.pl).
:- multifile rtl_ele:expiry_hook/1.
rtl_ele:expiry_hook(Clock) :-
    rtl_slr_clock_moved(Clock).

%   rtl_clear/0 forgets the records of every instance (the instances stay).
:- multifile rtl_ele:clear_hook/0.
rtl_ele:clear_hook :-
    current_program(M),
    forall(id_handle(M, _, H),
           ( bounds(H, First, Last),
             forall(between(First, Last, Number), ( key(H, Number, Key), retractall(record(Key, _, _, _)) )),
             reset_bounds(H) )),
    forall(retract(expiry(H, M, Due)), time_index_remove(slr_expiry, M, Due, H)),
    NoExpiry is inf,
    nb_setval(rtl_slr_next_expiry, NoExpiry).

%!  rtl_slr_clear is det.
%
%   Delete every memory instance of the running program (stream histories included).

rtl_slr_clear :-
    current_program(M),
    forall(id_handle(M, Id, H), remove_instance(M, H, Id)).

% ---- the per-type index ------------------------------------------------------------------

% The events of a watched type reach observe/6 through a per-type output hook of rtl_ele,
% so that an event of a type no instance records costs one failed index lookup.
watch(M, Pattern, H) :-
    watch_head(Pattern, M, H, Head),
    assertz(Head),
    functor(Head, P, _),
    rtl_pattern_mask(Pattern, Mask),
    mask_use(P, M, Mask, 1),
    rtl_add_type_output_hook(Pattern, rtl_slr:observe(P)).

unwatch(M, Pattern, H) :-
    watch_head(Pattern, M, H, Head),
    retractall(Head),
    functor(Head, P, _),
    rtl_pattern_mask(Pattern, Mask),
    mask_use(P, M, Mask, -1),
    (   current_predicate(P/3), \+ call(P, _, _, _)
    ->  rtl_remove_type_output_hook(Pattern, rtl_slr:observe(P))
    ;   true
    ).

%!  rtl_slr_rebuild_index(+Program) is det.
%
%   Make the index of Program's instances again from their patterns: rtl_state.pl calls it
%   after a restore, so that no key of a snapshot is trusted (keys are term_hash/2 values).

rtl_slr_rebuild_index(M) :-
    forall(watch_predicate(_, _, P), ( Head =.. [P, _, M, _], retractall(Head) )),
    forall(instance(H, M, _, Pattern, _, _, _, _, _),
           ( watch_head(Pattern, M, H, Head),
             assertz(Head),
             functor(Head, P, _),
             rtl_pattern_mask(Pattern, Mask),
             mask_use(P, M, Mask, 1) )).

% mask_use(+P, +Program, +Mask, +Delta): the type's clause `P('$mask'(Mask), Program, Count)`
% counts the instances whose patterns have constants at the positions of Mask.
mask_use(P, M, Mask, Delta) :-
    MaskHead =.. [P, '$mask'(Mask), M, Count0],
    (   retract(MaskHead) -> true ; Count0 = 0 ),
    Count is Count0 + Delta,
    (   Count > 0
    ->  NewHead =.. [P, '$mask'(Mask), M, Count],
        assertz(NewHead)
    ;   true
    ).

%!  rtl_slr_type_hook(@Hook) is semidet.
%
%   Hook has the shape of the per-type output hooks this module registers with rtl_ele
%   (`rtl_slr:observe(P)`, P the index predicate of a watched type): rtl_state.pl checks the
%   hooks a snapshot holds with it.

rtl_slr_type_hook(Hook) :-
    nonvar(Hook),
    Hook = Module:observe(P),
    Module == rtl_slr,
    rtl_slr_watch_predicate(P).

%!  rtl_slr_watch_predicate(@Name) is semidet.
%
%   Name is the name of the index predicate (arity 3, in this module) of a watched event
%   type: `'$slr_watch Name/Arity'` (watch_head/4).

rtl_slr_watch_predicate(Name) :-
    atom(Name),
    sub_atom(Name, 0, _, _, '$slr_watch ').

% watch_head(+Pattern, +Program, +H, -Head): Head is `P(Key, Program, H)`, Key the hash of the pattern's constants
% for the type's index predicate P (created on first use).
watch_head(Pattern, M, H, Head) :-
    functor(Pattern, Name, Arity),
    (   watch_predicate(Name, Arity, P)
    ->  true
    ;   format(atom(P), '$slr_watch ~w/~w', [Name, Arity]),
        dynamic(rtl_slr:P/3),
        assertz(watch_predicate(Name, Arity, P))
    ),
    rtl_pattern_mask(Pattern, Mask),
    rtl_pattern_key(Pattern, Mask, Key),
    Head =.. [P, Key, M, H].

% ---- recording ---------------------------------------------------------------------------

%   The type output hook: every processed event (input, derived or internal) of a type
%   some instance records; P is the type's index predicate.
observe(P, Event, Start, End, Op) :-
    rtl_program(M),
    findall(Mask, call(P, '$mask'(Mask), M, _), Masks),
    findall(H, ( member(Mask, Masks), rtl_pattern_key(Event, Mask, Key), index_hit(P, Key, M, H) ), Hs0),
    sort(Hs0, Hs),                              % creation order, each instance once
    observe_in(Hs, Op, Event, Start, End).

index_hit(P, Key, M, H) :-
    (   integer(Key)
    ->  call(P, Key, M, H)
    ;   call(P, Key0, M, H), integer(Key0)       % an event with variables: every instance
    ).

observe_in([], _, _, _, _).
observe_in([H|Hs], Op, Event, Start, End) :-
    (   instance(H, M, Id, Pattern, Conds, Template, N, L, Options),
        Pattern = Event,
        conditions_hold(Conds, M, Id)
    ->  (   Op == add
        ->  add_record(H, M, Id, N, L, Options, Start, End, Template)
        ;   remove_record(H, M, Id, Options, Start, End, Template)
        )
    ;   true
    ),
    observe_in(Hs, Op, Event, Start, End).

conditions_hold([], _, _) :- !.
conditions_hold(Conds, M, Id) :-
    catch(once(all_goals(Conds, M)), Error,
          rtl_condition_raised(Error, "condition of memory ~q raised ~s; event not recorded", [Id])).

all_goals([], _).
all_goals([G|Gs], M) :-
    call(M:G),
    all_goals(Gs, M).

add_record(H, M, Id, N, L, Options, Start, End, Template) :-
    rtl_clock(Clock),
    bounds_term(H, B),
    B = bounds(First, Last, LastEnd),
    (   rtl_beyond_bound(End, Clock, L)
    ->  true                                     % outside the time limit already
    ;   N \== inf,
        End =< LastEnd,
        Last - First + 1 >= N,
        key(H, First, FirstKey),
        record(FirstKey, S1, E1, T1),
        \+ record_after(End, Start, Template, E1, S1, T1)
    ->  true                                     % full, and older than every record it keeps
    ;   (   Last < First
        ->  Number = First,
            nb_setarg(2, B, First),
            nb_setarg(3, B, End)
        ;   ( End > LastEnd ; End =:= LastEnd, \+ before_last(H, Last, End, Start, Template) )
        ->  Number is Last + 1,
            nb_setarg(2, B, Number),
            nb_setarg(3, B, End)
        ;   last_not_after_record(H, First, Last, End, Start, Template, Before),
            Point is Before + 1,                            % a late record goes after every
            make_room(H, B, First, Last, Point, Number)     % record not after it (never last)
        ),
        key(H, Number, Key),
        assertz(record(Key, Start, End, Template)),
        (   N == inf
        ->  true
        ;   forget_over_count(H, B, N, M, Id, Options)
        ),
        recorded(M, Id, Options, Start, End, Template),
        schedule_expiry(H, M, L)
    ).

%   The order of records: by end time, then start time, then the standard order of the
%   templates, so that what a memory holds (its N latest) and which record prev and next
%   meet first among equal end times depend on the events, not on their arrival order.
%   Records equal in all three are indistinguishable.
record_after(E, S, T, E1, S1, T1) :-
    (   E =\= E1 -> E > E1
    ;   S =\= S1 -> S > S1
    ;   T @> T1
    ).

% The new record [Start, End] of Template goes before record Last, which ends at End too.
before_last(H, Last, End, Start, Template) :-
    key(H, Last, Key),
    record(Key, S1, E1, T1),
    record_after(E1, S1, T1, End, Start, Template).

% The last number whose record is not after [Start, End] of Template (First - 1 if none).
last_not_after_record(H, Low, High, End, Start, Template, Number) :-
    (   Low > High
    ->  Number = High
    ;   Mid is (Low + High) >> 1,
        key(H, Mid, Key),
        record(Key, S, E, T),
        (   record_after(E, S, T, End, Start, Template)
        ->  High1 is Mid - 1,
            last_not_after_record(H, Low, High1, End, Start, Template, Number)
        ;   Low1 is Mid + 1,
            last_not_after_record(H, Low1, High, End, Start, Template, Number)
        )
    ).

recorded(M, Id, Options, Start, End, Template) :-
    memory_event(M, memory_updated(Id, End), End, End),
    (   memberchk(record_events(true), Options)
    ->  memory_event(M, memory_record_added(Id, Template), Start, End)
    ;   true
    ),
    forall(memory_update_hook(M, Id, Start, End), true).

% Free a number for a record that goes before Point: move the shorter side by one.
make_room(H, B, First, Last, Point, Number) :-
    (   Point - First < Last - Point + 1
    ->  First1 is First - 1,
        Before is Point - 1,
        forall(between(First, Before, N0), renumber(H, N0, -1)),
        nb_setarg(1, B, First1),
        Number = Before
    ;   forall(between(Point, Last, I), ( N0 is Last - (I - Point), renumber(H, N0, 1) )),
        Last1 is Last + 1,
        nb_setarg(2, B, Last1),
        Number = Point
    ).

renumber(H, N0, Delta) :-
    key(H, N0, Key0),
    retract(record(Key0, S, E, T)),
    Key is Key0 + Delta,
    assertz(record(Key, S, E, T)).

forget_over_count(H, B, N, M, Id, Options) :-
    arg(1, B, First),
    arg(2, B, Last),
    (   Last - First + 1 > N
    ->  forget_first(H, B, First, M, Id, Options),
        forget_over_count(H, B, N, M, Id, Options)
    ;   true
    ).

forget_expired(H, B, L, M, Id, Options) :-
    rtl_clock(Clock),
    arg(1, B, First),
    arg(2, B, Last),
    (   First =< Last,
        key(H, First, Key),
        record(Key, _, End, _),
        rtl_beyond_bound(End, Clock, L)
    ->  forget_first(H, B, First, M, Id, Options),
        forget_expired(H, B, L, M, Id, Options)
    ;   true
    ).

forget_first(H, B, First, M, Id, Options) :-
    key(H, First, Key),
    retract(record(Key, S, E, T)),
    First1 is First + 1,
    nb_setarg(1, B, First1),
    (   memberchk(record_events(true), Options)
    ->  memory_event(M, memory_record_forgotten(Id, T), S, E)
    ;   true
    ).

% A deleted event takes its record with it (the first one recorded for it).
remove_record(H, M, Id, Options, Start, End, Template) :-
    bounds_term(H, B),
    arg(1, B, First),
    arg(2, B, Last),
    first_not_before(H, First, Last, End, From),
    (   record_of(From, Last, H, Start, End, Template, Number)
    ->  key(H, Number, Key),
        retract(record(Key, S, E, T)),
        close_gap(H, B, First, Last, Number),
        instance(H, _, _, _, _, _, _, L, _),
        schedule_expiry(H, M, L),
        (   memberchk(record_events(true), Options)
        ->  memory_event(M, memory_record_forgotten(Id, T), S, E)
        ;   true
        )
    ;   true
    ).

% The number of the record [Start, End] of Template among those ending at End.
record_of(Number, Last, H, Start, End, Template, Found) :-
    Number =< Last,
    key(H, Number, Key),
    record(Key, S, E, T),
    E =:= End,
    (   S =:= Start, T =@= Template
    ->  Found = Number
    ;   Next is Number + 1,
        record_of(Next, Last, H, Start, End, Template, Found)
    ).

close_gap(H, B, First, Last, Gap) :-
    (   Gap - First < Last - Gap
    ->  Before is Gap - 1,
        forall(between(First, Before, I), ( N0 is Before - (I - First), renumber(H, N0, 1) )),
        First1 is First + 1,
        nb_setarg(1, B, First1)
    ;   After is Gap + 1,
        forall(between(After, Last, N0), renumber(H, N0, -1)),
        Last1 is Last - 1,
        nb_setarg(2, B, Last1),
        (   Gap =:= Last, Last1 >= First          % the last record went: note the new last's end
        ->  key(H, Last1, Key),
            record(Key, _, LastEnd, _),
            nb_setarg(3, B, LastEnd)
        ;   true
        )
    ).

% ---- forgetting by time -------------------------------------------------------------------
%
% A record of an instance with time limit L is forgotten when the clock moves beyond L
% seconds after its end (rtl_beyond_bound/3), at that clock move, with its
% memory_record_forgotten event: rtl_ele calls rtl_slr_clock_moved/1 (its expiry_hook/1) before the event that
% moved the clock is processed (and on a heartbeat), so every query, rule and timer from
% then on sees the memory without it, and a consumer of the memory events hears of it when
% it happens (the last clock move of the input included), not at the next record.
%
% Each time-limited instance with records has one entry in the time index `slr_expiry`
% (rtl_time_index.pl) under its program, at the due time `End + L` of its oldest record
% (expiry/3 says which), so a clock move costs what it forgets, not the number of
% instances. The global rtl_slr_next_expiry is a time before which nothing is due: a clock
% move that does not pass it costs one comparison in rtl_ele.

% expiry(H, Program, Due): the entry of instance H in the time index slr_expiry
:- dynamic expiry/3.

%!  rtl_slr_clock_moved(+Clock) is det.
%
%   The clock moved to Clock, past rtl_slr_next_expiry: forget the records of the
%   time-limited instances that lie beyond their limits.

rtl_slr_clock_moved(Clock) :-
    rtl_program(M),
    time_index_take(slr_expiry, M, <, Clock, Due),
    forall(member(H, Due),
           (   retract(expiry(H, M, _)),
               instance(H, M, Id, _, _, _, _, L, Options)
           ->  bounds_term(H, B),
               forget_expired(H, B, L, M, Id, Options),
               schedule_expiry(H, M, L)
           ;   true
           )),
    (   time_index_count(slr_expiry, M, 0)
    ->  NoExpiry is inf,
        nb_setval(rtl_slr_next_expiry, NoExpiry)
    ;   nb_setval(rtl_slr_next_expiry, Clock)    % every entry left is due at Clock or later
    ).

% schedule_expiry(+H, +Program, +L): the records of instance H changed; its entry in the
% index is due when its oldest record is.
schedule_expiry(_, _, inf) :- !.
schedule_expiry(H, M, L) :-
    bounds(H, First, Last),
    (   First =< Last
    ->  key(H, First, Key),
        record(Key, _, End, _),
        Due is End + L                          % rtl_beyond_bound/3's sum
    ;   Due = none
    ),
    (   expiry(H, M, Old), Old == Due
    ->  true
    ;   unschedule_expiry(H, M),
        (   Due == none
        ->  true
        ;   assertz(expiry(H, M, Due)),
            time_index_add(slr_expiry, M, Due, H),
            (   nb_current(rtl_slr_next_expiry, Next), number(Next), Next =< Due
            ->  true
            ;   nb_setval(rtl_slr_next_expiry, Due)
            )
        )
    ).

unschedule_expiry(H, M) :-
    (   retract(expiry(H, M, Old))
    ->  time_index_remove(slr_expiry, M, Old, H)
    ;   true
    ).

% ---- memory events -----------------------------------------------------------------------

memory_event(M, Event) :-
    rtl_clock(Clock),
    (   Clock =:= -inf -> T = 0 ; T = Clock ),
    memory_event(M, Event, T, T).

memory_event(M, Event, Start, End) :-
    (   listened(M, Event)
    ->  rtl_raise_internal(Event, Start, End)
    ;   true
    ).

listened(M, Event) :-
    (   \+ \+ clause(M:ele_trigger(Event, _, _), _)
    ->  true
    ;   rtl_subscribed(Event)
    ).

% ---- queries -----------------------------------------------------------------------------

%!  mem(?Id, ?Event) is nondet.
%
%   Event unifies with a record of a memory instance whose id unifies with Id, oldest
%   first, within the stream view of the query (end time at most its Z). Event may be
%   written `E^T` (T the end time) or `E^[T1, T2]` to reach the record's time.

mem(Id, Event) :-
    current_program(M),
    view(View),
    id_handle(M, Id, H),
    \+ Id = '$stream'(_),
    bounds(H, First, Last),
    needs(H, View),
    between(First, Last, Number),
    key(H, Number, Key),
    record(Key, S, E, T),
    E =< View,
    match(Event, S, E, T).

%!  access_mem(?Id, ?Event, ?Interval) is nondet.
%
%   Retalis 2015 spelling of mem/2: Interval is `[T1, T2]`.

access_mem(Id, Event, [T1, T2]) :-
    mem(Id, Event^[T1, T2]).

%!  prev(?Id, ?Event, +Zs) is nondet.
%
%   Event unifies with the latest record (by end time) of memory Id that unifies with it
%   and ends at or before Zs (Def. 23). Semidet for a given instance; an unbound Id
%   enumerates the instances.

prev(Id, Event, Zs) :-
    time_argument(Zs, Z, prev/3),
    current_program(M),
    id_handle(M, Id, H),
    \+ Id = '$stream'(_),
    latest(H, Event, Z).

%!  next(?Id, ?Event, +Zs, +Ze) is nondet.
%
%   Event unifies with the earliest record of memory Id that unifies with it and ends
%   within [Zs, Ze] (Def. 24; Ze may be `inf`).

next(Id, Event, Zs, Ze) :-
    time_argument(Zs, Z1, next/4),
    time_argument(Ze, Z2, next/4),
    current_program(M),
    id_handle(M, Id, H),
    \+ Id = '$stream'(_),
    earliest(H, Event, Z1, Z2).

%!  prev(?Event, +Zs) is semidet.
%!  next(?Event, +Zs, +Ze) is semidet.
%!  next(?Event, +Interval) is semidet.
%
%   The same over the stream of events of Event's type (Def. 19-20), kept by
%   stream_history/3. Interval is `[Zs, Ze]`.

prev(Event, Zs) :-
    time_argument(Zs, Z, prev/2),
    stream_handle(Event, H, prev/2),
    latest(H, Event, Z).

next(Event, Zs, Ze) :-
    time_argument(Zs, Z1, next/3),
    time_argument(Ze, Z2, next/3),
    stream_handle(Event, H, next/3),
    earliest(H, Event, Z1, Z2).

next(Event, Interval) :-
    (   nonvar(Interval), Interval = [Zs, Ze]
    ->  next(Event, Zs, Ze)
    ;   throw(error(type_error(interval, Interval), context(next/2, 'write next(Event, [Zs, Ze])')))
    ).

%!  prev(?Id, ?Event, ?T1, ?T2, +Z) is nondet.
%!  next(?Id, ?Event, ?T1, ?T2, +Zs, +Ze) is nondet.
%!  next_inf(?Id, ?Event, ?T1, ?T2, +Zs) is nondet.
%
%   Retalis 2015 spellings: the record's start and end times are T1 and T2.

prev(Id, Event, T1, T2, Z) :-
    prev(Id, Event^[T1, T2], Z).

next(Id, Event, T1, T2, Zs, Ze) :-
    next(Id, Event^[T1, T2], Zs, Ze).

next_inf(Id, Event, T1, T2, Zs) :-
    next(Id, Event^[T1, T2], Zs, inf).

latest(H, Event, Z) :-
    needs(H, Z),
    bounds(H, First, Last),
    last_not_after(H, First, Last, Z, From),
    scan_down(From, First, H, Event).

earliest(H, Event, Zs, Ze) :-
    bounds(H, First, Last),
    first_not_before(H, First, Last, Zs, From),
    (   scan_up(From, Last, H, Event, Ze)
    ->  true                     % found: with per-type in-order arrival, nothing earlier can come
    ;   needs(H, Ze),            % not found: final once the history up to Ze is complete
        fail
    ).

%!  rtl_with_needs(:Goal, -Needs:list) is semidet.
%
%   Run Goal once, noting which histories its evaluation depended on: Needs is a list of
%   `MemoryId-Time`, each meaning "the answer is final once this memory's history up to Time
%   is complete" (prev and mem read up to their time; a next that found nothing needs its
%   whole interval; a next that found a record needs nothing more). Synchronized queries
%   (thesis Def. 29) use it.

rtl_with_needs(Goal, Needs) :-
    retractall(need(_, _)),
    setup_call_cleanup(nb_setval(rtl_slr_log, true), once(Goal), nb_setval(rtl_slr_log, false)),
    findall(Id-T, retract(need(Id, T)), Needs0),
    sort(Needs0, Needs).

needs(H, T) :-
    (   nb_current(rtl_slr_log, true)
    ->  instance(H, _, Id, _, _, _, _, _, _),
        assertz(need(Id, T))
    ;   true
    ).

scan_down(Number, First, H, Event) :-
    Number >= First,
    key(H, Number, Key),
    record(Key, S, E, T),
    (   match(Event, S, E, T)
    ->  true
    ;   Next is Number - 1,
        scan_down(Next, First, H, Event)
    ).

scan_up(Number, Last, H, Event, Ze) :-
    Number =< Last,
    key(H, Number, Key),
    record(Key, S, E, T),
    E =< Ze,
    (   match(Event, S, E, T)
    ->  true
    ;   Next is Number + 1,
        scan_up(Next, Last, H, Event, Ze)
    ).

% The last number whose record ends at or before Z (First - 1 if none).
last_not_after(H, Low, High, Z, Number) :-
    (   Low > High
    ->  Number = High
    ;   Mid is (Low + High) >> 1,
        key(H, Mid, Key),
        record(Key, _, E, _),
        (   E =< Z
        ->  Low1 is Mid + 1,
            last_not_after(H, Low1, High, Z, Number)
        ;   High1 is Mid - 1,
            last_not_after(H, Low, High1, Z, Number)
        )
    ).

% The first number whose record ends at or after Z (Last + 1 if none).
first_not_before(H, Low, High, Z, Number) :-
    (   Low > High
    ->  Number = Low
    ;   Mid is (Low + High) >> 1,
        key(H, Mid, Key),
        record(Key, _, E, _),
        (   E < Z
        ->  Low1 is Mid + 1,
            first_not_before(H, Low1, High, Z, Number)
        ;   High1 is Mid - 1,
            first_not_before(H, Low, High1, Z, Number)
        )
    ).

% An event pattern against a record: `E^[T1, T2]` (start and end), `E^T` (T is the end
% time, as `E^T` in event patterns binds the end of an event's interval) or E.
match(Event, S, E, T) :-
    (   nonvar(Event), Event = Pattern^Time
    ->  Pattern = T,
        (   nonvar(Time), Time = [T1, T2]
        ->  T1 = S, T2 = E
        ;   Time = E
        )
    ;   Event = T
    ).

stream_handle(Event, H, Culprit) :-
    (   nonvar(Event), Event = E0^_ -> true ; E0 = Event ),
    (   callable(E0)
    ->  true
    ;   throw(error(instantiation_error, context(Culprit, 'the event type must be given')))
    ),
    functor(E0, Name, Arity),
    current_program(M),
    (   stream_memory(M, Name, Arity, H)
    ->  true
    ;   throw(error(existence_error(stream_history, Name/Arity),
                    context(Culprit, 'no history is kept for this event type: declare stream_history(Name/Arity, N, L)')))
    ).

time_argument(T, Seconds, Culprit) :-
    (   var(T)
    ->  throw(error(instantiation_error, context(Culprit, 'the time arguments of prev and next must be bound')))
    ;   T == inf
    ->  Seconds = inf
    ;   rtl_time_seconds(T, Seconds)
    ->  true
    ;   compound(T), \+ is_list(T), catch(Seconds is T, _, fail)
    ->  true                                 % an expression such as T + 1 (thesis rule 4.8)
    ;   throw(error(type_error(time, T),
                    context(Culprit, 'a time is seconds, an arithmetic expression, [Secs, NSecs], datime/7 or inf')))
    ).

%!  rtl_with_view(+Z, :Goal) is nondet.
%
%   Run Goal as the SLR query <Goal, Z>: mem/2 sees the records whose end time is at
%   most Z (`inf`: all).

rtl_with_view(Z, Goal) :-
    (   nb_current(rtl_slr_view, Old) -> true ; Old = inf ),
    setup_call_cleanup(nb_setval(rtl_slr_view, Z), Goal, nb_setval(rtl_slr_view, Old)).

view(View) :-
    (   nb_current(rtl_slr_view, View0), View0 \== [] -> View = View0 ; View = inf ).

% ---- numbers, keys and bounds ------------------------------------------------------------

key(H, Number, Key) :-
    Key is H * 1099511627776 + Number.          % key_base/1

% The name of the global variable of instance H's bounds, made once per instance.
bounds_key(H, Key) :-
    (   bounds_name(H, Key0)
    ->  Key = Key0
    ;   atom_concat('$rtl_slr_bounds_', H, Key),
        assertz(bounds_name(H, Key))
    ).

% The bounds of instance H: a global term bounds(First, Last, LastEnd), its records being
% numbered First..Last (none when Last < First); LastEnd is the end time of record Last
% (kept by add_record/9 and close_gap/5, so that an in-order append reads no record).
bounds_term(H, B) :-
    bounds_key(H, Key),
    nb_getval(Key, B).

bounds(H, First, Last) :-
    bounds_term(H, B),
    arg(1, B, First),
    arg(2, B, Last).

reset_bounds(H) :-
    number_origin(Origin),
    Last is Origin - 1,
    bounds_key(H, Key),
    nb_setval(Key, bounds(Origin, Last, 0)).

% ---- checks ------------------------------------------------------------------------------

% The program a memory belongs to: the one being loaded (for its directives), else the
% running one.
current_program(M) :-
    (   prolog_load_context(module, M0),
        current_predicate(M0:ele_trigger/3)
    ->  M = M0
    ;   rtl_program(M0)
    ->  M = M0
    ;   existence_error(retalis_program, loaded)
    ).

query_parts(Query, Pattern, Conds, Culprit) :-
    (   var(Query)
    ->  throw(error(instantiation_error, context(Culprit, 'the query must be given')))
    ;   Query = Pattern-Conds
    ->  true
    ;   Pattern = Query, Conds = []
    ).
