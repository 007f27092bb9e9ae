:- module(rtl_subscriptions,
          [ rtl_subscribe/7,            % ?Id, +Consumer, +Pattern, +Conds, ?Template, +Ts, +Te
            rtl_unsubscribe/2,          % +Id, +Te
            rtl_subscription/7,         % ?Id, ?Consumer, ?Pattern, ?Conds, ?Template, ?Ts, ?Te
            rtl_subscribed/1,           % +Event
            subscribe/5,                % +Pattern, +Conds, ?Template, +Consumer, +Id   (Retalis 2015)
            delete_subscription/2,      % +Consumer, +Id                             (Retalis 2015)
            sub/5,                      % +Id, +Consumer, +Query, ?Template, +Ts     (thesis 3.4)
            unsub/2,                    % +Id, +Te                                   (thesis 3.4)
            subscribe_between/5,        % +Consumer, +Query, ?Template, +Ts, +Te     (thesis 3.4)
            rtl_consumer_dir/1,         % +Directory
            rtl_subscriptions_rebuild_index/1,  % +Program
            rtl_close_consumer_files/0
          ]).

/** <module> Subscriptions: deliver matching events to consumers (thesis 3.4, A.2.6)

A subscription names a consumer, an event pattern with conditions, a template and a time
interval `[Ts, Te]`. Every processed event, input or derived, that unifies with the
pattern, satisfies the conditions and occurred inside the interval (`Ts =< Start` and
`End =< Te`) is delivered to the consumer as the template instance, in processing order,
as an output line `{"event": TEMPLATE, "start": S, "end": E, "consumer": NAME}`. Deletions
of such events are delivered the same way with `"op": "retract"`. The conditions are
goals run in the program module; a delivery is made for each of their solutions.

Three spellings:

  - Retalis 2015: `subscribe(Pattern, Conds, Template, Consumer, Id)` (Template unbound:
    the event itself) and `delete_subscription(Consumer, Id)`;
  - thesis: `sub(Id, Consumer, Q, Template, Ts)` and `unsub(Id, Te)`, Q written
    `Event-Conds` (or a bare event), times in seconds or `now` (the clock);
  - thesis `subscribe(Topic, Q, Tmpl, Ts, Te)`, whose name clashes with the Retalis form:
    `subscribe_between(Consumer, Q, Template, Ts, Te)`.

Subscriptions belong to the program that is running when they are made (rtl_program/1),
and are found by every constant argument of their pattern (rtl_pattern_key.pl): a
subscription is filed under the key of its pattern's constants, and an event is keyed once
per mask in use for its type; only the subscriptions filed under its keys are unified with
it, in the order they were made. An event of a type no subscription is on costs one failed
lookup.
*/

:- use_module(rtl_guard, [rtl_condition_raised/3]).
:- use_module(rtl_ele).
:- use_module(rtl_time).
:- use_module(rtl_io).
:- use_module(library(occurs)).
:- use_module(rtl_pattern_key, [rtl_pattern_mask/2, rtl_pattern_key/3]).


% subscription(Program, Id, Consumer, Pattern, Conds, Template, Ts, Te)
:- dynamic subscription/8.
% by_key(Key, Program, Name, Arity, Seq, Id, Consumer): the index the output hook reads, Key
% the hash of the pattern's constants (rtl_pattern_key/3), Seq the order of creation.
:- dynamic by_key/7.
% by_mask(Program, Name, Arity, Mask, Count): Count subscriptions on Name/Arity have constants
% at the positions of Mask.
:- dynamic by_mask/5.

:- multifile retalis:rtl_declaration_handler/3.
retalis:rtl_declaration_handler(subscribe, 5, rtl_subscriptions).
retalis:rtl_declaration_handler(delete_subscription, 2, rtl_subscriptions).
retalis:rtl_declaration_handler(sub, 5, rtl_subscriptions).
retalis:rtl_declaration_handler(unsub, 2, rtl_subscriptions).
retalis:rtl_declaration_handler(subscribe_between, 5, rtl_subscriptions).

%!  subscribe(+Pattern, +Conds:list, ?Template, +Consumer, +Id) is det.
%
%   Retalis 2015 form: deliver every event matching Pattern and Conds, from now on, to
%   Consumer as Template (the event itself when Template is unbound). Starting "now"
%   means with no lower time bound when it is made before any event was processed.

subscribe(Pattern, Conds, Template, Consumer, Id) :-
    rtl_subscribe(Id, Consumer, Pattern, Conds, Template, -inf, inf).

%!  delete_subscription(+Consumer, +Id) is det.
%
%   Remove the subscription Id of Consumer; nothing more is delivered for it. Raises an
%   existence error if there is no such subscription.

delete_subscription(Consumer, Id) :-
    current_program(M),
    (   subscription(M, Id, Consumer, _, _, _, _, _)
    ->  remove(M, Id, Consumer)
    ;   existence_error(subscription, Consumer/Id)
    ).

%!  sub(+Id, +Consumer, +Query, ?Template, +Ts) is det.
%
%   Thesis form: subscribe Consumer to the events matching Query (`Event-Conds` or an
%   event) that occur at or after Ts (`now`, a number of seconds, `[Secs, NSecs]` or
%   `datime/7`), until unsub/2.

sub(Id, Consumer, Query, Template, Ts) :-
    query_parts(Query, Pattern, Conds),
    rtl_subscribe(Id, Consumer, Pattern, Conds, Template, Ts, inf).

%!  unsub(+Id, +Te) is det.
%
%   End the subscriptions with this Id: events ending after Te (`now` or a time) are no
%   longer delivered. Events ending before Te that are still processed (late arrivals,
%   derived events) are.

unsub(Id, Te) :-
    rtl_unsubscribe(Id, Te).

%!  subscribe_between(+Consumer, +Query, ?Template, +Ts, +Te) is det.
%
%   The thesis's `subscribe(Topic, Q, Tmpl, Ts, Te)`: deliver the events matching Query
%   that occurred within `[Ts, Te]`. The subscription gets a fresh integer id.

subscribe_between(Consumer, Query, Template, Ts, Te) :-
    query_parts(Query, Pattern, Conds),
    rtl_subscribe(_, Consumer, Pattern, Conds, Template, Ts, Te).

%!  rtl_subscribe(?Id, +Consumer, +Pattern, +Conds:list, ?Template, +Ts, +Te) is det.
%
%   Register a subscription of the running program. Id is a fresh integer when unbound.
%   A Template that is a variable not occurring in Pattern or Conds stands for the event.
%   Consumer is an atom or string; Ts and Te are `now`, `inf` (Te), `-inf` (Ts) or times.
%   Raises a type, domain or permission error (with the subscription in its context) for a
%   bad subscription: nothing is registered then.

rtl_subscribe(Id, Consumer, Pattern, Conds, Template, Ts0, Te0) :-
    current_program(M),
    Culprit = subscription(Id, Consumer, Pattern, Conds, Template),
    check_subscription(Id, Consumer, Pattern, Conds, Culprit),
    time_bound(Ts0, Ts, Culprit),
    time_bound(Te0, Te, Culprit),
    (   var(Id) -> fresh_id(M, Id) ; true ),
    (   subscription(M, Id, Consumer, _, _, _, _, _)
    ->  permission_error(create, subscription, Consumer/Id)
    ;   true
    ),
    (   var(Template), \+ sub_var(Template, Pattern-Conds)
    ->  Template = Pattern                 % no template: the event itself
    ;   true
    ),
    atom_string(ConsumerAtom, Consumer),
    (   aggregate_all(max(S), by_key(_, M, _, _, S, _, _), Last) -> Seq is Last + 1 ; Seq = 1 ),
    assertz(subscription(M, Id, ConsumerAtom, Pattern, Conds, Template, Ts, Te)),
    file(M, Pattern, Seq, Id, ConsumerAtom),
    rtl_add_output_hook(rtl_subscriptions:deliver).

file(M, Pattern, Seq, Id, Consumer) :-
    functor(Pattern, Name, Arity),
    rtl_pattern_mask(Pattern, Mask),
    rtl_pattern_key(Pattern, Mask, Key),
    assertz(by_key(Key, M, Name, Arity, Seq, Id, Consumer)),
    mask_use(M, Name, Arity, Mask, 1).

mask_use(M, Name, Arity, Mask, Delta) :-
    (   retract(by_mask(M, Name, Arity, Mask, Count0)) -> true ; Count0 = 0 ),
    Count is Count0 + Delta,
    (   Count > 0 -> assertz(by_mask(M, Name, Arity, Mask, Count)) ; true ).

%!  rtl_subscriptions_rebuild_index(+Program) is det.
%
%   File Program's subscriptions again under the keys of their patterns, in the order they
%   were made: rtl_state.pl calls it after a restore, so that no key of a snapshot is
%   trusted (keys are term_hash/2 values).

rtl_subscriptions_rebuild_index(M) :-
    findall(Seq-(Id-Consumer), by_key(_, M, _, _, Seq, Id, Consumer), Filed0),
    sort(Filed0, Filed),
    retractall(by_key(_, M, _, _, _, _, _)),
    retractall(by_mask(M, _, _, _, _)),
    forall(( member(Seq-(Id-Consumer), Filed),
             once(subscription(M, Id, Consumer, Pattern, _, _, _, _)) ),
           file(M, Pattern, Seq, Id, Consumer)).

%!  rtl_unsubscribe(+Id, +Te) is det.
%
%   Set the end of every subscription Id of the running program to Te (`now` or a time).
%   Raises an existence error when there is none.

rtl_unsubscribe(Id, Te0) :-
    current_program(M),
    time_bound(Te0, Te, unsub(Id, Te0)),
    (   subscription(M, Id, _, _, _, _, _, _)
    ->  forall(retract(subscription(M, Id, C, P, Conds, T, Ts, _)),
               assertz(subscription(M, Id, C, P, Conds, T, Ts, Te)))
    ;   existence_error(subscription, Id)
    ).

%!  rtl_subscription(?Id, ?Consumer, ?Pattern, ?Conds, ?Template, ?Ts, ?Te) is nondet.
%
%   The subscriptions of the running program.

rtl_subscription(Id, Consumer, Pattern, Conds, Template, Ts, Te) :-
    current_program(M),
    subscription(M, Id, Consumer, Pattern, Conds, Template, Ts, Te).

%!  rtl_subscribed(+Event) is semidet.
%
%   Some subscription of the running program is on events of Event's type.

rtl_subscribed(Event) :-
    rtl_program(M),
    functor(Event, Name, Arity),
    by_mask(M, Name, Arity, _, _),
    !.

% ---- delivery -------------------------------------------------------------------------

%   The output hook: called for every processed event.
deliver(Event, Start, End, Op) :-
    rtl_program(M),
    functor(Event, Name, Arity),
    (   by_mask(M, Name, Arity, _, _)
    ->  findall(Seq-(Id-Consumer),
                ( by_mask(M, Name, Arity, Mask, _),
                  rtl_pattern_key(Event, Mask, Key),
                  index_hit(Key, M, Name, Arity, Seq, Id, Consumer) ),
                Hits0),
        sort(Hits0, Hits),                      % the order of creation, each once
        forall(member(_-(Id-Consumer), Hits),
               deliver(M, Id, Consumer, Event, Start, End, Op))
    ;   true
    ).

index_hit(Key, M, Name, Arity, Seq, Id, Consumer) :-
    (   integer(Key)
    ->  by_key(Key, M, Name, Arity, Seq, Id, Consumer)
    ;   by_key(_, M, Name, Arity, Seq, Id, Consumer)     % an event with variables: every one of its type
    ).

deliver(M, Id, Consumer, Event, Start, End, Op) :-
    (   subscription(M, Id, Consumer, Pattern, Conds, Template, Ts, Te),
        Start >= Ts,
        End =< Te,
        Pattern = Event
    ->  forall(conditions_hold(M, Conds, subscription(Id, Consumer)),
               emit(Template, Start, End, Consumer, Op))
    ;   expired(M, Id, Consumer)
    ->  remove(M, Id, Consumer)
    ;   true
    ).

%   An ended subscription is removed once no event it could still match can arrive: its
%   end lies more than the delay bound before the clock.
expired(M, Id, Consumer) :-
    subscription(M, Id, Consumer, _, _, _, _, Te),
    Te \== inf,
    rtl_flag(max_delay, Delay),
    Delay \== inf,
    rtl_clock(Clock),
    Clock - Delay > Te.

conditions_hold(M, Conds, Which) :-
    catch(all_goals(Conds, M), Error,
          rtl_condition_raised(Error, "condition of ~q raised ~s; event not delivered", [Which])).

all_goals([], _).
all_goals([G|Gs], M) :-
    call(M:G),
    all_goals(Gs, M).

%   A delivery goes to the output (rtl_emit/5), or to the consumer's own file when
%   rtl_consumer_dir/1 was called.
emit(Event, Start, End, Consumer, Op) :-
    (   nb_current(rtl_consumer_dir, Dir), Dir \== []
    ->  consumer_stream(Dir, Consumer, Stream),
        rtl_event_json(Event, Start, End, Consumer, Op, Line),
        write(Stream, Line), nl(Stream)
    ;   rtl_emit(Event, Start, End, Consumer, Op)
    ).

:- dynamic consumer_file/2.     % consumer_file(Consumer, Stream)

consumer_stream(Dir, Consumer, Stream) :-
    (   consumer_file(Consumer, Stream0)
    ->  Stream = Stream0
    ;   rtl_consumer_file_name(Consumer, Base),
        directory_file_path(Dir, Base, Path),
        open(Path, write, Stream, [encoding(utf8)]),
        assertz(consumer_file(Consumer, Stream))
    ).

%!  rtl_consumer_dir(+Directory) is det.
%
%   From now on write the deliveries of each consumer to `Directory/<consumer>.jsonl`
%   (created, or emptied, at its first delivery) instead of the output. A consumer name
%   is made a file name by dropping leading slashes and writing every character other
%   than letters, digits, `_`, `-` and `.` as `_` (ROS topic `/marker/pose` goes to
%   `marker_pose.jsonl`). The directory is created if needed.

rtl_consumer_dir(Dir) :-
    make_directory_path(Dir),
    nb_setval(rtl_consumer_dir, Dir).

%!  rtl_close_consumer_files is det.
%
%   Close the consumer files opened so far.

rtl_close_consumer_files :-
    forall(retract(consumer_file(_, Stream)), close(Stream)).

rtl_consumer_file_name(Consumer, File) :-
    atom_codes(Consumer, Codes0),
    strip_slashes(Codes0, Codes1),
    maplist(file_code, Codes1, Codes),
    (   Codes == [] -> Base = '_' ; atom_codes(Base, Codes) ),
    atom_concat(Base, '.jsonl', File).

strip_slashes([0'/|Cs], Rest) :- !, strip_slashes(Cs, Rest).
strip_slashes(Cs, Cs).

file_code(C0, C) :-
    (   ( code_type(C0, csym) ; memberchk(C0, `-.`) )
    ->  C = C0
    ;   C = 0'_
    ).

% ---- checks ---------------------------------------------------------------------------

current_program(M) :-
    (   rtl_program(M0)
    ->  M = M0
    ;   existence_error(retalis_program, loaded)
    ).

query_parts(Query, Pattern, Conds) :-
    (   var(Query)
    ->  instantiation_error(Query)
    ;   Query = Pattern-Conds, is_list(Conds)
    ->  true
    ;   Pattern = Query, Conds = []
    ).

check_subscription(Id, Consumer, Pattern, Conds, Culprit) :-
    (   var(Consumer)
    ->  throw(error(instantiation_error, context(Culprit, 'the consumer must be given')))
    ;   ( atom(Consumer) ; string(Consumer) )
    ->  true
    ;   throw(error(type_error(consumer_name, Consumer), context(Culprit, 'a consumer is an atom')))
    ),
    (   callable(Pattern)
    ->  true
    ;   throw(error(type_error(event_pattern, Pattern),
                    context(Culprit, 'the pattern must be an event atom')))
    ),
    (   is_list(Conds), maplist(callable, Conds)
    ->  true
    ;   throw(error(type_error(list_of_goals, Conds),
                    context(Culprit, 'the conditions must be a list of goals')))
    ),
    (   var(Id) -> true
    ;   ground(Id) -> true
    ;   throw(error(instantiation_error, context(Culprit, 'a subscription id must be ground')))
    ).

time_bound(T, _, Culprit) :-
    var(T), !,
    throw(error(instantiation_error, context(Culprit, 'a time bound must be given'))).
time_bound(now, T, _) :- !,
    rtl_clock(T).
time_bound(inf, inf, _) :- !.
time_bound(-inf, -inf, _) :- !.
time_bound(T0, T, Culprit) :-
    (   rtl_time_seconds(T0, T)
    ->  true
    ;   throw(error(type_error(time, T0),
                    context(Culprit, 'a time is now, inf, seconds, [Secs, NSecs] or datime/7')))
    ).

fresh_id(M, Id) :-
    (   nb_current(rtl_subscription_counter, N0) -> true ; N0 = 0 ),
    N is N0 + 1,
    nb_setval(rtl_subscription_counter, N),
    (   subscription(M, N, _, _, _, _, _, _) -> fresh_id(M, Id) ; Id = N ).

remove(M, Id, Consumer) :-
    forall(retract(subscription(M, Id, Consumer, Pattern, _, _, _, _)),
           ( functor(Pattern, Name, Arity),
             rtl_pattern_mask(Pattern, Mask),
             mask_use(M, Name, Arity, Mask, -1) )),
    retractall(by_key(_, M, _, _, _, Id, Consumer)).
