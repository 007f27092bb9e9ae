:- module(rtl_api,
          [ rtl_api_use_program/2,      % +Module, -Out
            rtl_api_default_flags/1,    % -Out
            rtl_api_output_to_buffer/1, % -Out
            rtl_api_set_flag/3,         % +Name, +ValueText, -Out
            rtl_api_feed_events/2,      % +Items, -Output
            rtl_api_feed_paced/4,       % +Items, +Dues, +Tick, -Output
            rtl_api_feed_paced_rest/2,  % +Tick, -Output
            rtl_api_ros1_schema/2,      % +SchemaText, -Handle
            rtl_api_feed_lines/5,       % +Text, +FirstLineNo, +AllowControl, +Strict, -Output
            rtl_api_feed_byte_lines/5,  % +Bytes, +FirstLineNo, +AllowControl, +Strict, -Output
            rtl_api_set_action_output/2, % +Path, -Out
            rtl_api_fresh_rule_prefix/2,% +Module, -Prefix
            rtl_api_install_rules/3,    % +Module, +ClausesText, -Ids
            rtl_api_remove_rule/3,      % +Module, +Label, -Out
            rtl_api_subscribe/7,        % +Consumer, +PatternText, +TemplateText, +ConditionsText, +Ts, +Te, -Id
            rtl_api_subscribe_query/4,  % +Consumer, +QueryText, +TemplateText, -Id
            rtl_api_unsubscribe/3,      % +IdText, +Te, -Out
            rtl_api_clear/1,            % -Out
            rtl_api_end_of_input/2,     % +Mode, -Output
            rtl_api_post_query/5,       % +QueryId, +GoalText, +At, +Timeout, -Output
            rtl_api_query/4,            % +GoalText, +At, +Limit, -Output
            rtl_api_memory/2,           % +RequestText, -Output
            rtl_api_tf_lookup/4,        % +Target, +Source, +Time, -Output
            rtl_api_tf_lookup_numbers/4, % +Target, +Source, +Time, -Answer
            rtl_api_stats/1,            % -Text
            rtl_api_summary/1,          % -Text
            rtl_api_detections/1,       % -Text
            rtl_api_store_size/1,       % -Size
            rtl_api_clock/1,            % -Clock
            rtl_api_advance_clock/2,    % +Time, -Output
            rtl_api_save_state/3,       % +Path, +Identity, -Out
            rtl_api_restore_state/3,    % +Path, +Identity, -Out
            rtl_api_state_digest/1,     % -Hash
            rtl_api_flag/2,             % +Name, -ValueText
            rtl_api_end_stopped/1,      % -Yes
            rtl_api_take_halted/1,      % -Reason
            rtl_api_close_action_output/1, % -Out
            rtl_api_run_event_file/4,   % +File, +AllowControl, +Strict, -Outcome
            rtl_api_use_tracing/1,      % -Out
            rtl_api_ground_canonical/2  % +Text, -Canonical
          ]).

/** <module> The entry points of the Python Engine: values as data, never as program text

The Python driver (retalisc/driver/engine.py) calls only these predicates, through the
bridge's fixed-goal call: `rtl_api:Name(Arg1, ..., ArgN, Out)` with every argument a
Prolog string, number or list of them, never goal text built from Python values. Out is
always a string (`""` for predicates that only act). Text that
stands for a term (an event, a goal, a pattern, a label, a flag value) is read here with
rtl_read_text/4 (rtl_text.pl): one term, trailing text refused, variables by name. Events
must be ground; times finite numbers. Goals from outside (subscription conditions) pass
rtl_check_goal/4 (rtl_sandbox.pl); rules pass it in rtl_install_rules/3 and queries in
rtl_query.pl.

## The protocol (docs/architecture.md, "The Python/Prolog boundary")

The bridge calls these through retalisc_bridge:bridge_apply/6 (rtl_bridge.pl): Status 1, 0 or
2 (an error, never raised into the C interface). The output of the feeding predicates is a
string of lines, read once on the Python side (`retalisc.driver.engine.read_answer`):

  - first, when there are outputs, two lines `[...]`: every output of the call, in order,
    as data (rtl_output_data/2 in rtl_io.pl): a JSON array of the outputs (each event's
    writeq text and times, consumer, op; a synchronized query's result object), then a JSON
    array of their terms as data, each decoded once on the Python side;
  - `?LINE<TAB>TEXT`: a warning (LINE empty outside rtl_api_feed_lines/5);
  - `!LINE<TAB>KIND<TAB>REASON`: an input line not processed (rtl_api_feed_lines/5);
  - as the last line only: `!error<TAB>Index<TAB>Message` (feeding stopped at the event Index
    of the batch, counted from 0, whose processing raised: the output produced before it
    comes first), `!undecodable<TAB>Index` (ROS 1 bytes that are not one message of their
    type), `!paced<TAB>N` (rtl_api_feed_paced/4: N items processed, more to come).

A bad item raises error(bad_item(Index, Error), _) before anything of the batch runs. Queries
and memory requests answer `!KIND<TAB>MESSAGE` when refused.
*/

:- use_module(library(apply)).
:- use_module(library(lists)).
:- use_module(rtl_ele).
:- use_module(rtl_raise, [rtl_input/4]).
:- use_module(rtl_rules).
:- use_module(rtl_query).
:- use_module(rtl_tf, [tf_lookup/6]).
:- use_module(rtl_subscriptions).
:- use_module(rtl_sandbox).
:- use_module(rtl_error_text).
:- use_module(rtl_text).
:- use_module(rtl_seen).
:- use_module(rtl_io, [rtl_json_string_escape/2]).
:- use_module(rtl_time, [rtl_input_interval/6]).
:- use_module(rtl_lines, [rtl_digits_problem/3]).
:- use_module(rtl_horizon, [rtl_take_warnings/1, rtl_warnings_pending/0]).
:- use_module(rtl_state).
:- use_module(rtl_ros1).

:- use_module(rtl_feed, [rtl_feed_lines/4, rtl_end_of_input/2, rtl_summary/1, rtl_heartbeat/2,
                          rtl_run_event_file/4]).
:- use_module(rtl_halt, [rtl_take_halted/1]).

%!  rtl_api_default_flags(-Out) is det.
%
%   rtl_default_flags/0: a new Engine does not inherit the flags another one set.

rtl_api_default_flags("") :-
    rtl_default_flags.

%!  rtl_api_use_program(+Module:text, -Out) is det.

rtl_api_use_program(Text, "") :-
    module_atom(Text, M),
    rtl_use_program(M).

%!  rtl_api_output_to_buffer(-Out) is det.
%
%   Output lines are collected for the caller (rtl_output_to/1).

rtl_api_output_to_buffer("") :-
    rtl_output_to(buffer).

module_atom(Text, M) :-
    must_be(text, Text),
    atom_string(M, Text),
    (   current_module(M)
    ->  true
    ;   existence_error(module, M)
    ).

%!  rtl_api_set_flag(+Name:text, +ValueText:text, -Out) is det.
%
%   Set a runtime flag; the value is read as a ground term (`2.5`, `inf`, `true`).

rtl_api_set_flag(NameText, ValueText, "") :-
    must_be(text, NameText),
    atom_string(Name, NameText),
    rtl_read_ground(ValueText, Value),
    rtl_set_flag(Name, Value).

%!  rtl_api_feed_events(+Items:list, -Output:string) is det.
%
%   Items are `[Op, EventText, Start, End]` lists: Op `"add"` or `"retract"`; Start and End
%   times as an event file gives them (a number of seconds or `[Secs, NSecs]`), End `""` when
%   the event has one time (a file's `"t"`). EventText may also be `[Handle, Bytes]`: a ROS 1
%   message's bytes, read by rtl_ros1_event/3 with the schema Handle names; when they are not
%   one message of that type, processing stops before that event with the last line
%   `!undecodable<TAB>Index` (the driver converts the message itself). Times are checked by rtl_input_interval/6, the
%   check of the file reader, so a time is refused here exactly when a file line with it is,
%   for the same reason (`error(invalid_time(Reason), _)`). The whole batch is read first: a
%   bad item raises an error naming it and nothing is processed.

rtl_api_feed_events(Items, Output) :-
    must_be(list, Items),
    foldl(read_item, Items, Events, 0, _),
    batch_output(process_events(Events, 0, Failure), Failure, Output).

%   batch_output(:Goal, ?Last, -Output): run Goal, which processes events, with what program
%   code prints going to the action output, not into the output; Output holds the output
%   as data (rtl_take_output_data/1), the warnings (deletions outside the
%   retraction horizon) and, when Goal bound it, the line Last.

batch_output(Goal, Last, Output) :-
    rtl_output_to(buffer),
    rtl_action_stream(Stream),
    current_output(Old),
    setup_call_cleanup(set_output(Stream), Goal, set_output(Old)),
    rtl_take_output_data(Lines0),
    rtl_take_warnings(Warnings),
    findall(W, ( member(T, Warnings), format(string(W), "?\t~s", [T]) ), Ws),
    append(Lines0, Ws, Lines1),
    (   var(Last)
    ->  Lines = Lines1
    ;   append(Lines1, [Last], Lines)
    ),
    lines_output(Lines, Output).

%!  rtl_api_feed_paced(+Items:list, +Dues:list(number), +Tick:number, -Output:string) is det.
%
%   The items of rtl_api_feed_events/2, each processed when it is due: Dues are the wall-clock
%   times (get_time/1, seconds) at which the items fall due, in order. Tick is the latency
%   budget: each item is processed at most Tick seconds after it falls due. The caller's
%   thread sleeps here until the first item not processed is Tick late, then processes in
%   one group every item due by then (a recording replayed at a rate,
%   retalisc/robot_io/replay.py: the pacing of its Python loop, without a call per group).
%   Waking at the first item's deadline rather than at its due time lets one wake-up serve
%   every item due within Tick of it: the fewest wake-ups that keep every item within the
%   budget (replaying the NAO recording with Tick 10 ms: 51 a second instead of 78).
%   The call returns as soon as a group produced output (or a warning), so that the output
%   leaves as it is produced: then, when items remain, the last line is `!paced<TAB>N`, N the
%   number of items processed, and rtl_api_feed_paced_rest/2 goes on with the others.
%   Errors end the call as in rtl_api_feed_events/2 (`!error` or `!undecodable` with the
%   item's index in Items: the items before it were processed; the others are dropped).

rtl_api_feed_paced(Items, Dues, Tick, Output) :-
    nb_setval(rtl_paced_rest, []),
    must_be(list, Items),
    must_be(list(number), Dues),
    must_be(number, Tick),
    length(Items, N),
    (   length(Dues, N)
    ->  true
    ;   domain_error(one_due_time_per_item, Dues)
    ),
    foldl(read_item, Items, Events, 0, _),
    paced_output(Events, Dues, Tick, 0, Output).

%!  rtl_api_feed_paced_rest(+Tick:number, -Output:string) is det.
%
%   Go on with the items a call of rtl_api_feed_paced/4 returned before (its last line
%   `!paced<TAB>N`), as it does; indexes still count the items of that call. Output is `""`
%   when none remain.

rtl_api_feed_paced_rest(Tick, Output) :-
    must_be(number, Tick),
    (   nb_current(rtl_paced_rest, rest(Events, Dues, I))
    ->  nb_setval(rtl_paced_rest, []),
        paced_output(Events, Dues, Tick, I, Output)
    ;   Output = ""
    ).

paced_output(Events, Dues, Tick, I, Output) :-
    batch_output(( paced(Events, Dues, Tick, I, Stop), paced_last(Stop, Last) ), Last, Output).

% paced_last(+Stop, -Last): the last line of a paced call, if any; the events left are kept
% for rtl_api_feed_paced_rest/2.
paced_last(done, _) :- !.
paced_last(paced(Done, Rest, RestDues), Last) :- !,
    nb_setval(rtl_paced_rest, rest(Rest, RestDues, Done)),
    format(string(Last), "!paced\t~w", [Done]).
paced_last(Failure, Failure).

% paced(+Events, +Dues, +Tick, +Index, -Stop): Stop is `done`, paced(Processed, Rest,
% RestDues) when a group produced output and events remain, or the failure line.
paced([], _, _, _, done) :- !.
paced(Events, [Due|Dues], Tick, I, Stop) :-
    get_time(Now),
    Wait is Due + Tick - Now,
    (   Wait > 0
    ->  sleep(Wait),
        get_time(Then)
    ;   Then = Now
    ),
    due_group(Events, [Due|Dues], Then, Group, Rest, RestDues),
    process_events(Group, I, Failure),
    length(Group, K),
    I1 is I + K,
    (   nonvar(Failure)
    ->  Stop = Failure
    ;   Rest == []
    ->  Stop = done
    ;   ( rtl_output_pending ; rtl_warnings_pending )
    ->  Stop = paced(I1, Rest, RestDues)
    ;   paced(Rest, RestDues, Tick, I1, Stop)
    ).

% The first event and every one after it due by Now.
due_group([E|Es], [_|Ds], Now, [E|Group], Rest, RestDues) :-
    due_more(Es, Ds, Now, Group, Rest, RestDues).

due_more([E|Es], [D|Ds], Now, [E|Group], Rest, RestDues) :-
    D =< Now,
    !,
    due_more(Es, Ds, Now, Group, Rest, RestDues).
due_more(Es, Ds, _, [], Es, Ds).

read_item(Item, event(Op, Event, Start, End), I, I1) :-
    I1 is I + 1,
    catch(item_event(Item, Op, Event, Start, End), Error,
          throw(error(bad_item(I, Error), _))).

item_event([OpText, Text, Start0, End0], Op, Event, Start, End) :- !,
    must_be(text, OpText),
    atom_string(Op, OpText),
    must_be(oneof([add, retract]), Op),
    item_term(Text, Event),
    (   End0 == ""
    ->  rtl_input_interval(Start0, _, _, Start, End, Problem)
    ;   rtl_input_interval(_, Start0, End0, Start, End, Problem)
    ),
    (   var(Problem), rtl_future_problem(End, Future)       % (the clock before the batch)
    ->  throw(error(invalid_time(Future), _))
    ;   var(Problem)
    ->  true
    ;   throw(error(invalid_time(Problem), _))
    ).
item_event(Item, _, _, _, _) :-
    type_error(event_item, Item).

item_term([Handle, Bytes], Event) :-
    integer(Handle),
    string(Bytes),
    !,
    (   rtl_ros1_event(Handle, Bytes, Event0)
    ->  Event = Event0
    ;   true                                % unbound: no text gives that (events are ground)
    ).
item_term(Text, Event) :-
    rtl_flag(max_digits, MaxDigits),            % (as an event line's text: rtl_io.pl)
    (   string(Text), rtl_digits_problem(Text, MaxDigits, Problem)
    ->  throw(error(syntax_error(Problem), _))
    ;   rtl_read_event(Text, Event)
    ).

%!  rtl_api_ros1_schema(+SchemaText, -Handle:string) is det.
%
%   Register a ROS 1 message schema (rtl_ros1.pl) given as text; Handle is its number as
%   text, or `""` when the C helper is not built.

rtl_api_ros1_schema(Text, Handle) :-
    (   rtl_ros1_available
    ->  rtl_read_ground(Text, Schema),
        rtl_ros1_schema(Schema, N),
        number_string(N, Handle)
    ;   Handle = ""
    ).

finite_time(T) :-
    must_be(number, T),
    (   float(T), \+ ( T =:= T, abs(T) =\= inf )
    ->  domain_error(finite_time, T)
    ;   true
    ).

process_events([], _, _).
process_events([event(_, Event, _, _)|_], I, Failure) :-
    var(Event),
    !,
    format(string(Failure), "!undecodable\t~w", [I]).
process_events([event(Op, Event, Start, End)|Events], I, Failure) :-
    catch(( seen(Op, Event, Start, End), rtl_input(Op, Event, Start, End) -> true ; true ), Error, true),
    (   var(Error)
    ->  I1 is I + 1,
        process_events(Events, I1, Failure)
    ;   rtl_error_text(Error, Message),
        format(string(Failure), "!error\t~w\t~w", [I, Message])
    ).

% The events added are remembered, so that a later retraction line can be checked (rtl_seen.pl).
seen(add, Event, Start, End) :-
    rtl_seen_add(Event, Start, End).
seen(retract, Event, Start, End) :-
    ignore(rtl_seen_take(Event, Start, End)).

lines_output(Lines, Output) :-
    (   Lines == []
    ->  Output = ""
    ;   atomic_list_concat(Lines, "\n", Joined),
        string_concat(Joined, "\n", Output)
    ).

%!  rtl_api_feed_lines(+Text:string, +FirstLineNo:integer, +AllowControl:text, +Strict:text, -Output:string) is det.
%
%   rtl_feed_lines/4: a batch of event JSON Lines, control lines obeyed when AllowControl is
%   `true`, stopping at the first line not processed when Strict is `true`.

rtl_api_feed_lines(Text, First, AllowControl0, Strict0, Output) :-
    must_be(text, Text),
    must_be(integer, First),
    api_boolean(AllowControl0, AllowControl),
    api_boolean(Strict0, Strict),
    rtl_feed_lines(Text, First, [allow_control(AllowControl), strict(Strict)], Output).

%!  rtl_api_feed_byte_lines(+Bytes:string, +FirstLineNo:integer, +AllowControl:text, +Strict:text, -Output:string) is det.
%
%   rtl_api_feed_lines/5 for lines given as their bytes (a string of codes 0..255): each is
%   decoded as UTF-8, and rejected when it is not UTF-8 text (rtl_feed_lines/4, `bytes(true)`).

rtl_api_feed_byte_lines(Bytes, First, AllowControl0, Strict0, Output) :-
    must_be(string, Bytes),
    must_be(integer, First),
    api_boolean(AllowControl0, AllowControl),
    api_boolean(Strict0, Strict),
    rtl_feed_lines(Bytes, First, [allow_control(AllowControl), strict(Strict), bytes(true)], Output).

api_boolean(Text, Boolean) :-
    atom_string(Boolean, Text),
    must_be(boolean, Boolean).

%!  rtl_api_set_action_output(+Path:text, -Out) is det.
%
%   rtl_set_action_output/1 with the file Path (a string, never read as a term).

rtl_api_set_action_output(Path, ok) :-
    must_be(text, Path),
    atom_string(File, Path),
    rtl_set_action_output(File).

%!  rtl_api_fresh_rule_prefix(+Module:text, -Prefix:atom) is det.

rtl_api_fresh_rule_prefix(ModuleText, Prefix) :-
    module_atom(ModuleText, M),
    rtl_fresh_rule_prefix(M, Prefix).

%!  rtl_api_install_rules(+Module:text, +ClausesText:string, -Ids:string) is det.
%
%   rtl_install_rules/3 (which refuses unsafe rules); Ids one per line.

rtl_api_install_rules(ModuleText, Clauses, IdsText) :-
    module_atom(ModuleText, M),
    must_be(string, Clauses),
    rtl_install_rules(M, Clauses, Ids),
    atomic_list_concat(Ids, '\n', IdsText).

%!  rtl_api_remove_rule(+Module:text, +Label:text, -Out) is det.

rtl_api_remove_rule(ModuleText, LabelText, "") :-
    module_atom(ModuleText, M),
    must_be(text, LabelText),
    atom_string(Label, LabelText),
    rtl_remove_rule(M, Label).

%!  rtl_api_subscribe(+Consumer, +PatternText, +TemplateText, +ConditionsText, +Ts, +Te, -Id:string) is det.
%
%   Subscribe Consumer (rtl_subscribe/7). The three texts share variables by name;
%   TemplateText `""` means the event itself. The conditions must be safe. Ts and Te are
%   numbers or the strings `"now"`, `"inf"`, `"-inf"`. Id is the subscription id as text.

rtl_api_subscribe(Consumer, PatternText, TemplateText, ConditionsText, Ts0, Te0, IdText) :-
    must_be(text, Consumer),
    rtl_program(M),
    read_shared(PatternText, M, Pattern, [], B1),
    (   TemplateText == ""
    ->  B2 = B1
    ;   read_shared(TemplateText, M, Template, B1, B2)
    ),
    read_shared(ConditionsText, M, Conds, B2, _),
    subscribe(M, Consumer, Pattern, Conds, Template, Ts0, Te0, IdText).

%!  rtl_api_subscribe_query(+Consumer, +QueryText, +TemplateText, -Id:string) is det.
%
%   The form of `retalisc run --subscribe CONSUMER=QUERY[=>TEMPLATE]`: QueryText is an event
%   pattern or `Pattern-Conditions`; from the start of the input on.

rtl_api_subscribe_query(Consumer, QueryText, TemplateText, IdText) :-
    must_be(text, Consumer),
    rtl_program(M),
    read_shared(QueryText, M, Query, [], B1),
    (   TemplateText == ""
    ->  true
    ;   read_shared(TemplateText, M, Template, B1, _)
    ),
    (   nonvar(Query), Query = Pattern-Conds
    ->  true
    ;   Pattern = Query, Conds = []
    ),
    subscribe(M, Consumer, Pattern, Conds, Template, "-inf", "inf", IdText).

subscribe(M, Consumer, Pattern, Conds, Template, Ts0, Te0, IdText) :-
    bound(Ts0, Ts),
    bound(Te0, Te),
    (   is_list(Conds), maplist(callable, Conds)
    ->  maplist(rtl_check_goal(query([]), M), Conds, Guarded)
    ;   Guarded = Conds                         % rtl_subscribe/7 says what is wrong
    ),
    rtl_subscribe(Id, Consumer, Pattern, Guarded, Template, Ts, Te),
    term_string(Id, IdText).

%   Read Text; variables of the same name as in Bindings0 are the same variable.
read_shared(Text, M, Term, Bindings0, Bindings) :-
    rtl_read_text(Text, Term, Bindings1, [module(M)]),
    foldl(share_binding, Bindings1, Bindings0, Bindings).

share_binding(Name=Var, Bindings0, Bindings) :-
    (   memberchk(Name=Var0, Bindings0)
    ->  Var = Var0,
        Bindings = Bindings0
    ;   Bindings = [Name=Var|Bindings0]
    ).

bound(Value, Bound) :-
    (   number(Value)
    ->  Bound = Value
    ;   must_be(text, Value),
        atom_string(Atom, Value),
        must_be(oneof([now, inf, '-inf']), Atom),
        (   Atom == '-inf' -> Bound = -inf ; Bound = Atom )
    ).

%!  rtl_api_unsubscribe(+IdText:text, +Te, -Out) is det.

rtl_api_unsubscribe(IdText, Te0, "") :-
    rtl_read_ground(IdText, Id),
    bound(Te0, Te),
    rtl_unsubscribe(Id, Te).

%!  rtl_api_clear(-Out) is det.
%
%   Forget every event seen so far; output goes to the buffer again.

rtl_api_clear("") :-
    rtl_clear,
    rtl_output_to(buffer).

%!  rtl_api_end_of_input(+Mode:text, -Output:string) is det.

rtl_api_end_of_input(ModeText, Output) :-
    must_be(text, ModeText),
    atom_string(Mode, ModeText),
    must_be(oneof([run, drop]), Mode),
    rtl_end_of_input(Mode, Output).

%!  rtl_api_post_query(+QueryId:text, +GoalText:text, +At:number, +Timeout, -Output:string) is det.
%
%   Post the synchronized query <Goal, At> (rtl_sync_query/5); Timeout a number or
%   `"inf"`. Output is what was output at once, or one line `!KIND<TAB>MESSAGE` when the
%   query was refused.

rtl_api_post_query(QueryIdText, GoalText, At, Timeout0, Output) :-
    must_be(text, QueryIdText),
    atom_string(QueryId, QueryIdText),
    must_be(text, GoalText),
    finite_time(At),
    (   Timeout0 == "inf"
    ->  Timeout = inf
    ;   finite_time(Timeout0),
        (   Timeout0 >= 0 -> Timeout = Timeout0 ; domain_error(non_negative_timeout, Timeout0) )
    ),
    rtl_output_to(buffer),
    rtl_sync_query(GoalText, At, Timeout, QueryId, Error),
    (   var(Error)
    ->  rtl_take_output_data(Lines),
        lines_output(Lines, Output)
    ;   Error =.. [Kind, Message],
        format(string(Output), "!~w\t~w", [Kind, Message])
    ).

%!  rtl_api_query(+GoalText:text, +At, +Limit:text, -Output:string) is det.
%
%   rtl_query_lines/4; At a number or `"inf"`, Limit `"first"` or `"all"`.

rtl_api_query(GoalText, At0, LimitText, Output) :-
    must_be(text, GoalText),
    (   At0 == "inf" -> At = inf ; must_be(number, At0), At = At0 ),
    atom_string(Limit, LimitText),
    rtl_query_lines(GoalText, At, Limit, Output).

%!  rtl_api_tf_lookup(+Target:text, +Source:text, +Time, -Output:string) is det.
%
%   tf_lookup/6 of rtl_tf.pl with its arguments as data (Engine.tf_lookup): Target and Source
%   frame ids (strings), Time `"latest"`, a number of seconds, `[Secs, NSecs]` or
%   `["ns", Nanoseconds]`. No goal text is read, so nothing passes the sandbox: the goal is
%   this fixed, read-only call. Output is `ok<TAB>X<TAB>Y<TAB>Z<TAB>QX<TAB>QY<TAB>QZ<TAB>QW<TAB>Secs<TAB>NSecs`,
%   or `!<TAB>Reason` with Reason the writeq text of tf_lookup/6's reason term.

rtl_api_tf_lookup(Target, Source, Time, Output) :-
    rtl_api_tf_lookup_numbers(Target, Source, Time, Answer),
    (   Answer = tf(X, Y, Z, QX, QY, QZ, QW, S, NS)
    ->  atomic_list_concat([ok, X, Y, Z, QX, QY, QZ, QW, S, NS], '\t', Output)     % format/2 costs 10x this
    ;   Output = Answer
    ).

%!  rtl_api_tf_lookup_numbers(+Target:text, +Source:text, +Time, -Answer) is det.
%
%   rtl_api_tf_lookup/4 answering with numbers, for the bridge's typed call
%   (rtl_bridge_call_numbers in c/rtl_bridge_call.c reads them without text): Answer is
%   `tf(X, Y, Z, QX, QY, QZ, QW, Secs, NSecs)`, or the string `!<TAB>Reason` as
%   rtl_api_tf_lookup/4's.

rtl_api_tf_lookup_numbers(Target, Source, Time0, Answer) :-
    atom_string(TargetAtom, Target),
    atom_string(SourceAtom, Source),
    api_tf_time(Time0, Time),
    tf_lookup(TargetAtom, SourceAtom, Time, Pose, Stamp, Result),
    (   Result == ok
    ->  Pose = [[X, Y, Z], [QX, QY, QZ, QW]],
        Stamp = [S, NS],
        Answer = tf(X, Y, Z, QX, QY, QZ, QW, S, NS)
    ;   format(string(Answer), "!\t~q", [Result])
    ).

api_tf_time("latest", latest) :- !.
api_tf_time(["ns", N], ns(N)) :- !, must_be(integer, N).
api_tf_time([S, NS], [S, NS]) :- !, must_be(integer, S), must_be(integer, NS).
api_tf_time(T, T) :- number(T), !.
api_tf_time(T, _) :- type_error(tf_time, T).

%!  rtl_api_memory(+RequestText:text, -Output:string) is det.
%
%   rtl_memory_request/2; Output `""` or `!KIND<TAB>MESSAGE`.

rtl_api_memory(Text, Output) :-
    must_be(text, Text),
    rtl_memory_request(Text, Error),
    (   var(Error)
    ->  Output = ""
    ;   Error =.. [Kind, Message],
        format(string(Output), "!~w\t~w", [Kind, Message])
    ).

%!  rtl_api_stats(-Text:string) is det.
%
%   The statistics as lines `Name<TAB>Value`.

rtl_api_stats(Text) :-
    findall(Line, ( rtl_stat(Name, Value), format(string(Line), "~w\t~w", [Name, Value]) ), Lines),
    atomic_list_concat(Lines, "\n", Text).

%!  rtl_api_detections(-Text:string) is det.
%
%   rtl_detections/1 as lines `Rule<TAB>Count` (rules with no detection are not listed).

rtl_api_detections(Text) :-
    rtl_detections(Pairs),
    findall(Line, ( member(Rule-N, Pairs), format(string(Line), "~w\t~w", [Rule, N]) ), Lines),
    atomic_list_concat(Lines, "\n", Text).

%!  rtl_api_summary(-Text:string) is det.

rtl_api_summary(Text) :-
    rtl_summary(Text).

%!  rtl_api_store_size(-Size:integer) is det.

rtl_api_store_size(Size) :-
    rtl_store_size(Size).

%!  rtl_api_clock(-Clock:number) is det.

rtl_api_clock(Clock) :-
    rtl_clock(Clock).

%!  rtl_api_advance_clock(+Time:number, -Output:string) is det.
%
%   A heartbeat: move the clock to Time (if later) without an event; the timers it passes
%   fire (rtl_heartbeat/2).

rtl_api_advance_clock(Time, Output) :-
    must_be(number, Time),
    rtl_heartbeat(Time, Output).

%!  rtl_api_save_state(+Path:text, +Identity:text, -Out) is det.
%!  rtl_api_restore_state(+Path:text, +Identity:text, -Out) is det.
%
%   Write the whole state to the file Path, or replace it by the one written there
%   (rtl_state.pl). Identity is a string naming the program and runtime version; a snapshot
%   with another one is refused and nothing changes.

rtl_api_save_state(Path, Identity, "") :-
    must_be(text, Path),
    must_be(string, Identity),
    rtl_state_save(Path, Identity).

rtl_api_restore_state(Path, Identity, "") :-
    must_be(text, Path),
    must_be(string, Identity),
    rtl_state_restore(Path, Identity).

%!  rtl_api_state_digest(-Hash:string) is det.
%
%   A hash of everything a snapshot holds (tests compare states with it).

rtl_api_state_digest(Hash) :-
    rtl_state_digest(H),
    atom_string(H, Hash).

%!  rtl_api_flag(+Name:text, -ValueText:string) is det.
%
%   The value of the runtime flag Name (rtl_flag/2) as text: `inf`, `2.5`, `true`.

rtl_api_flag(NameText, Text) :-
    must_be(text, NameText),
    atom_string(Name, NameText),
    rtl_flag(Name, Value),
    format(string(Text), "~w", [Value]).

%!  rtl_api_end_stopped(-Yes:string) is det.
%
%   `"yes"` when program code called halt in a match the end of the input ran
%   (rtl_api_end_of_input/2), else `""`.

rtl_api_end_stopped(Yes) :-
    (   nb_current(rtl_end_stopped, true)
    ->  Yes = "yes"
    ;   Yes = ""
    ).

%!  rtl_api_take_halted(-Reason:string) is det.
%
%   Why loading the program stopped (program code called halt in a directive:
%   rtl_take_halted/1), once; `""` when it did not.

rtl_api_take_halted(Reason) :-
    (   rtl_take_halted(Reason0)
    ->  text_string(Reason0, Reason)
    ;   Reason = ""
    ).

text_string(Text, String) :-
    (   string(Text) -> String = Text ; format(string(String), "~w", [Text]) ).

%!  rtl_api_close_action_output(-Out) is det.
%
%   Close the file of the action output (rtl_set_action_output/1), if any.

rtl_api_close_action_output("") :-
    rtl_close_action_output.

%!  rtl_api_run_event_file(+File:text, +AllowControl:text, +Strict:text, -Outcome:string) is det.
%
%   rtl_run_event_file/4: the runtime's own loop over an event file (or `-`, standard input),
%   writing the output to standard output. Outcome as that predicate gives it
%   (`done`, `stopped`, `output gone`).

rtl_api_run_event_file(File, AllowControl, Strict, Outcome) :-
    must_be(text, File),
    rtl_run_event_file(File, AllowControl, Strict, Outcome0),
    text_string(Outcome0, Outcome).

%!  rtl_api_use_tracing(-Out) is det.
%
%   Load the tracing of `explain` and `--trace` (rtl_trace.pl), whose entry points the
%   driver then calls as it calls these (docs/architecture.md, "The Python/Prolog boundary").

rtl_api_use_tracing("") :-
    (   current_module(rtl_trace)
    ->  true
    ;   module_property(rtl_api, file(Api)),          % the runtime this one belongs to
        file_directory_name(Api, Dir),
        directory_file_path(Dir, 'rtl_trace.pl', File),
        use_module(File, [])
    ).

%!  rtl_api_ground_canonical(+Text:text, -Canonical:string) is det.
%
%   rtl_ground_canonical/2 (rtl_text.pl): Text read as one ground term, written back with
%   rtl_write_readable/2; `!Reason` when it is not one.

rtl_api_ground_canonical(Text, Canonical) :-
    rtl_ground_canonical(Text, Canonical).

rtl_error_text:runtime_error_text(invalid_time(Reason), Text) :-
    string(Reason),
    Text = Reason.
rtl_error_text:runtime_error_text(bad_item(I, Error), Text) :-
    integer(I),
    rtl_error_text(Error, Inner),
    format(string(Text), "event ~w of the batch: ~s", [I, Inner]).

:- multifile prolog:error_message//1.

prolog:error_message(invalid_time(Reason)) -->
    { rtl_error_text(error(invalid_time(Reason), _), Text) },
    [ '~s'-[Text] ].
prolog:error_message(bad_item(I, Error)) -->
    { rtl_error_text(error(bad_item(I, Error), _), Text) },
    [ '~s'-[Text] ].
