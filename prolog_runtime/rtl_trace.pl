:- module(rtl_trace,
          [ rtl_trace_start/1,          % -Out
            rtl_trace_stop/1,           % -Out
            rtl_trace_feed_line/3,      % +Text, +LineNo, -Output
            rtl_trace_feed_byte_line/3, % +Bytes, +LineNo, -Output
            rtl_trace_explain/4,        % +RulesText, +TargetText, +Limit, -Text
            rtl_trace_why_not/3,        % +RulesText, +PatternText, -Text
            rtl_trace_matches/3,        % +RulesText, +PatternText, -Text
            rtl_trace_rules/2,          % +Specs, -Out
            rtl_trace_report/1,         % -Text
            rtl_trace_late/3,           % +File, +Rules, -Out
            rtl_trace_end/1             % -Out
          ]).

/** <module> Explaining detections: how a derived event came about, and why one did not

Used by `retalisc explain` only; nothing here runs while events are processed unless
rtl_trace_start/0 registered its output hook, so runs without it pay nothing.

While tracing, every processed event is logged with the input line being processed: the
first event of a line is the input event itself, the others were derived from it (or raised
by an action while processing it). The explanations then read the log:

  - rtl_trace_explain/4: for a derived event, the rule that derived it and the events that
    make up the match, each with its input line, recursively for derived ones;
  - rtl_trace_why_not/3: for a pattern no event matched, per rule that could derive it,
    how many matches each part of its pattern has in the log, and the first part that has
    none although its operands have some (which condition, relation or window rejected
    them).

For `retalisc run --trace RULE`, rtl_trace_rules/2 watches the partial-match stores of rules
(prolog_listen/2 on their dynamic predicates) and writes a line to standard error for each
partial match created, consumed (by a consumption policy), expired (its window passed; kept
for late events and deletions), dropped (past the retraction horizon), replaced (by a newer
identical event, `recent` policy) or retracted (by a deletion); rtl_trace_report/1 gives the
counts and the detections per rule. For `--late FILE`, rtl_trace_late/3 writes every input
event that arrives more than the delay bound behind the clock, with its lateness and the
rules whose partners it may have missed. Without these calls no listener or hook exists.

Both evaluations of patterns below evaluate the rules' patterns over the log with the declarative semantics of the
language (docs/language.md, "Patterns"), the operators' temporal relations read from the table
the compiler compiles them from (rtl_relations.pl): rules come from the compiler as terms
`rule(Label, Place, Head, Pattern)`, Pattern built from `ev(Event, Start, End)`,
`seq(P, Q)` (and the other binary operators), `where(P, Goal)`, `check(P, Goal)`,
`win(P, Seconds)`, `neg(N, P1, P2)`, `absent(N, P, Seconds)`, `fnot(P, N, Window)` (Window
the number of seconds of the windows around it, or `none`),
`agg(Function, P, Value)`, `sliding(Function, P, Group, Seconds, Value)`, `timer(P, Delay)`
for the pattern of a timer rule (`alarm(E, Delay) <- P`, whose head is then E) and
`sync(P, Query)` for that of a synchronized rule (its head the synchronized event).
Conditions run in the program module.
*/

:- use_module(library(apply)).
:- use_module(library(lists)).
:- use_module(rtl_ele).
:- use_module(rtl_io, [rtl_json_string_escape/2, rtl_parse_event_line/2]).
:- use_module(rtl_lines, [rtl_utf8_line/2]).
:- use_module(rtl_policy, [rtl_policy_positioned/2]).
:- use_module(rtl_relations).
:- use_module(rtl_sliding, [rtl_sliding_change/5]).
:- use_module(retalis, [rtl_feed_lines/3, rtl_feed_lines/4]).

:- dynamic logged/6.            % logged(Seq, Line, Kind, Event, Start, End); Kind input or derived

%!  rtl_trace_start(-Out) is det.
%!  rtl_trace_stop(-Out) is det.
%
%   Start (with an empty log) and stop logging the processed events (Out is "", for the
%   Python bridge).

rtl_trace_start("") :-
    retractall(logged(_, _, _, _, _, _)),
    nb_setval(rtl_trace_seq, 0),
    nb_setval(rtl_trace_line, 0),
    nb_setval(rtl_trace_line_seen, -1),
    nb_setval(rtl_trace_input, first),
    rtl_add_output_hook(rtl_trace:log_event).

rtl_trace_stop("") :-
    rtl_remove_output_hook(rtl_trace:log_event).

%!  rtl_trace_feed_line(+Text, +Where, -Output) is det.
%
%   rtl_feed_lines/3 for one input line, its events logged under Where: the line number in
%   the event file, or a string naming a recording's message (`/tf#12`, fed as line 0).

rtl_trace_feed_line(Text, Line, Output) :-
    expect_input(Text, Line),
    line_number(Line, Number),
    rtl_feed_lines(Text, Number, Output).

line_number(Line, Number) :-
    (   integer(Line) -> Number = Line ; Number = 0 ).

%   where_text(+Where, -Text): "input line N" or "input message TOPIC#N".

where_text(Line, Text) :-
    (   integer(Line)
    ->  format(string(Text), "input line ~w", [Line])
    ;   format(string(Text), "input message ~w", [Line])
    ).

%!  rtl_trace_feed_byte_line(+Bytes, +LineNo, -Output) is det.
%
%   rtl_trace_feed_line/3 for a line given as its bytes (codes 0..255), decoded as UTF-8
%   and rejected when it is not (rtl_feed_lines/4, `bytes(true)`).

rtl_trace_feed_byte_line(Bytes, Line, Output) :-
    (   catch(rtl_utf8_line(Bytes, Text), _, fail), string(Text)
    ->  expect_input(Text, Line)
    ;   expect_input("", Line)
    ),
    line_number(Line, Number),
    rtl_feed_lines(Bytes, Number, [bytes(true)], Output).

%   expect_input(+Text, +LineNo): the event the line holds is the one logged as its input.
%   Events logged before it (timers and absences the line's time makes due) and after it
%   are derived. A line whose event cannot be read here takes its first event as the input.

expect_input(Text, Line) :-
    nb_setval(rtl_trace_line, Line),
    (   catch(rtl_parse_event_line(Text, event(add, Event, Start, End)), _, fail)
    ->  nb_setval(rtl_trace_input, event(Event, Start, End))
    ;   nb_setval(rtl_trace_input, first)
    ).

log_event(Event, Start, End, add) :- !,
    nb_getval(rtl_trace_seq, Seq0),
    Seq is Seq0 + 1,
    nb_setval(rtl_trace_seq, Seq),
    nb_getval(rtl_trace_line, Line),
    nb_getval(rtl_trace_input, Input),
    (   nb_getval(rtl_trace_line_seen, Line)
    ->  Kind = derived
    ;   Input = event(E, S, En), \+ ( E =@= Event, S =:= Start, En =:= End )
    ->  Kind = derived
    ;   nb_setval(rtl_trace_line_seen, Line),
        Kind = input
    ),
    assertz(logged(Seq, Line, Kind, Event, Start, End)).
log_event(Event, Start, End, retract) :-
    (   logged(Seq, Line, Kind, E, S, En), E =@= Event, S =:= Start, En =:= End
    ->  retract(logged(Seq, Line, Kind, E, S, En))
    ;   true
    ).

% ---- explain ------------------------------------------------------------------------------

%!  rtl_trace_explain(+RulesText, +TargetText, +Limit, -Text) is det.
%
%   Text explains the (at most Limit) logged derived events that unify with the target.

rtl_trace_explain(RulesText, TargetText, Limit, Text) :-
    read_rules(RulesText, Rules, Target, TargetText),
    findall(Seq, ( logged(Seq, _, derived, E, _, _), \+ E \= Target ), Seqs0),
    length(Seqs0, Found),
    (   Found =:= 0
    ->  format(string(Text), "no derived event matches ~w; try --why-not~n", [TargetText])
    ;   take(Limit, Seqs0, Seqs),
        with_output_to(string(Text),
                       forall(member(Seq, Seqs), ( explain_entry(Rules, Seq, 0, []), nl )))
    ).

take(N, List, Taken) :-
    length(List, Len),
    (   Len =< N -> Taken = List ; length(Taken, N), append(Taken, _, List) ).

explain_entry(Rules, Seq, Depth, Seen) :-
    logged(Seq, Line, Kind, Event, Start, End),
    indent(Depth),
    (   Start =:= End
    ->  format("~q at ~w", [Event, Start])
    ;   format("~q over [~w, ~w]", [Event, Start, End])
    ),
    (   Kind == input
    ->  where_text(Line, Where),
        format("  ~s~n", [Where])
    ;   memberchk(Seq, Seen)
    ->  format("  (see above)~n")
    ;   derivation(Rules, Event, Start, End, Seq, Rule, Items)
    ->  Rule = rule(Label, Place, _, _),
        format("  derived by rule ~w (~w)~n", [Label, Place]),
        Depth1 is Depth + 1,
        forall(member(Item, Items), explain_item(Rules, Item, Depth1, [Seq|Seen]))
    ;   where_text(Line, Where),
        format("  raised while processing ~s~n", [Where])
    ).

explain_item(Rules, Seq, Depth, Seen) :-
    integer(Seq), !,
    explain_entry(Rules, Seq, Depth, Seen).
explain_item(_, note(Text), Depth, _) :-
    indent(Depth),
    format("~w~n", [Text]).

indent(Depth) :-
    forall(between(1, Depth, _), write("  ")).

%   derivation(+Rules, +Event, +Start, +End, +Seq, -Rule, -Items)
%
%   A rule and a match of its pattern, made of events logged before Seq, that derives Event
%   over [Start, End].

derivation(Rules, Event, Start, End, Seq, Rule, Items) :-
    rtl_program(M),
    member(Rule0, Rules),
    copy_term(Rule0, Rule),
    Rule = rule(_, _, Head, Pattern),
    Head = Event,
    match(M, Seq, Pattern, S, E, Items0),
    S =:= Start, E =:= End,
    !,
    flatten(Items0, Items).

%!  rtl_trace_matches(+RulesText, +PatternText, -Text) is det.
%
%   Every event unifying with the pattern that a rule's pattern matches in the whole log,
%   as explain evaluates it: one line `Event<TAB>Start<TAB>End<TAB>Rule` each (the event
%   written with writeq), sorted, without duplicates. What explain can account for, to hold
%   against what the program detected (tests/test_explain_agrees.py).

rtl_trace_matches(RulesText, PatternText, Text) :-
    read_rules(RulesText, Rules, Target, PatternText),
    rtl_program(M),
    findall(Line,
            ( member(Rule0, Rules),
              copy_term(Rule0-Target, rule(Label, _, Head, Pattern)-Head),
              match(M, inf, Pattern, S, E, _),
              format(string(Line), "~q\t~w\t~w\t~w", [Head, S, E, Label]) ),
            Lines0),
    sort(Lines0, Lines),
    atomic_list_concat(Lines, "\n", Text).

% ---- evaluating patterns over the log -----------------------------------------------------

%   match(+M, +Before, +Pattern, -Start, -End, -Items) is nondet.

match(_, Before, ev(Event, S, E), S, E, [Seq]) :-
    logged(Seq, _, _, Event, S, E),
    Seq < Before.
match(M, B, Pattern, S, E, [I1, I2]) :-
    binary(Pattern, Op, P, Q),
    Op \== or, !,
    match(M, B, P, S1, E1, I1), match(M, B, Q, S2, E2, I2),
    related(Op, S1-E1, S2-E2, S, E).
match(M, B, or(P, Q), S, E, I) :-
    (   match(M, B, P, S, E, I) ; match(M, B, Q, S, E, I) ).
match(M, B, where(P, Goal), S, E, I) :-
    match(M, B, P, S, E, I),
    catch(M:Goal, _, fail).
match(M, B, check(P, Goal), S, E, I) :-
    match(M, B, P, S, E, I),
    check_goal(Goal, S, E, Goal1),
    catch(M:Goal1, _, fail).
match(M, B, win(P, Q), S, E, I) :-
    match(M, B, P, S, E, I), fits(S, E, Q).
match(M, B, neg(N, P, Q), S, E, [I1, I2]) :-
    match(M, B, P, S1, E1, I1), match(M, B, Q, S2, E2, I2),
    related(cnot, S1-E1, S2-E2, S, E),
    \+ ( match(M, B, N, SN, EN, _), blocks(cnot, S1-E1, S2-E2, SN-EN, none) ).
match(M, B, fnot(P, N, W), S, E, I) :-
    match(M, B, P, S, E, I),
    \+ ( match(M, B, N, SN, EN, _), blocks(fnot, S-E, none, SN-EN, W) ).
match(M, B, agg(_, P, _), S, E, [I, note("(the value aggregates the matches of this pattern so far)")]) :-
    match(M, B, P, S, E, I).
match(M, B, absent(N, P, D), S, E, I) :-
    match(M, B, P, S1, E1, I),
    rtl_absence_result(S1-E1, D, Start, End),
    S is Start, E is End,
    \+ ( match(M, B, N, SN, EN, _), blocks(absence, S1-E1, S-E, SN-EN, none) ).
match(M, B, timer(P, Delay), S, E, [I, note(Note)]) :-
    match(M, B, P, S, E1, I),
    catch(D is Delay, _, fail),
    E is E1 + D,
    format(string(Note), "(raised ~w s after the match ended)", [D]).
match(M, B, sync(P, _Query), S, E, [I, note("(a synchronized rule: derived once its query could be answered)")]) :-
    match(M, B, P, S, E, I).
match(M, B, sliding(F, P, G, D, V), T, T, [Items, note(Note)]) :-
    copy_term(G-P, G1-P1),
    distinct(G1-T, ( match(M, B, P1, _, E0, _), ( T = E0 ; T is E0 + D ) )),
    G = G1,
    findall(E-(X-I), ( match(M, B, P, _, E, I), aggregated(F, X) ), Matches),
    findall(E-X, member(E-(X-_), Matches), Values),
    rtl_sliding_change(F, D, Values, T, V),         % (the value the compiled rule outputs at T)
    findall(I, ( member(E-(_-I), Matches), E > T - D, E =< T ), Items),
    length(Items, Count),
    text(Note, "(the value over the ~d match~a of group ~q in the last ~w s)", [Count, es(Count), G, D]).

%   related(+Op, +Left, +Right, -Start, -End): the relation of the binary operator Op holds
%   between the intervals Left and Right, and its result is over [Start, End]
%   (rtl_relations.pl, the table the compiler compiles the rules from).

related(Op, Left, Right, S, E) :-
    rtl_relation(Op, Left, Right, Goals, Start, End),
    maplist(holds, Goals),
    S is Start, E is End.

%   blocks(+Op, +Left, +Right, +Blocker, +Window): the negated event over Blocker blocks the
%   match of Op (its operands over Left and Right): a blocker inside a window (not `none`)
%   only when it fits it where rtl_blocker_window/5 says.

blocks(Op, Left, Right, Blocker, Window) :-
    rtl_blocker(Op, Left, Right, Blocker, Goals),
    maplist(holds, Goals),
    (   Window \== none, rtl_blocker_window(Op, Left, Blocker, From, To)
    ->  fits(From, To, Window)
    ;   true
    ).

%   fits(+From, +To, +Window): [From, To] fits the window (rtl_window/4).

fits(From, To, Window) :-
    rtl_window(From, To, Window, Goal),
    holds(Goal).

holds(Goal) :-
    call(Goal).

%   aggregated(+Function, -X): the value Function aggregates for a match (its argument, with
%   the match's bindings; 1 for count), as the compiled rule stores it.

aggregated(F, X) :-
    (   compound(F) -> arg(1, F, X) ; X = 1 ).

check_goal(Goal, S, E, Goal1) :-
    mapsubterms(check_time(S, E), Goal, Goal1).

check_time(S, _, t1(T), T = S).
check_time(_, E, t2(T), T = E).

% ---- why not -------------------------------------------------------------------------------

%!  rtl_trace_why_not(+RulesText, +PatternText, -Text) is det.
%
%   For each rule whose head unifies with the pattern: the matches of each part of its
%   pattern in the log (head variables bound by the pattern), outermost part first, and the
%   part where matching stops: the first (innermost) part with no match although its
%   operands have some, or an event that never occurred.

rtl_trace_why_not(RulesText, PatternText, Text) :-
    read_rules(RulesText, Rules, Target, PatternText, Names),
    rtl_program(M),
    aggregate_all(count, ( logged(_, _, derived, E, _, _), \+ E \= Target ), Found),
    with_output_to(string(Text),
                   ( (   Found > 0
                     ->  say("~d derived event~a match~a ~w (see explain)~n",
                             [Found, s(Found), es_verb(Found), PatternText])
                     ;   true
                     ),
                     include(derives(Target), Rules, Candidates),         % no copies: Names stay linked
                     (   Candidates == []
                     ->  format("no rule derives an event of the form ~w~n", [PatternText])
                     ;   forall(member(R, Candidates), why_not_rule(M, Target, R, Rules, Names))
                     ))).

derives(Target, rule(_, _, Head, _)) :-
    \+ Head \= Target.

why_not_rule(M, Target, Rule0, Rules, Names0) :-
    copy_term(Rule0-Rules-Names0, rule(Label, Place, Head, Pattern)-_-Names),
    Head = Target,
    named(Names, Head, HeadText),
    format("rule ~w (~w), for ~s:~n", [Label, Place, HeadText]),
    part(M, Names, Pattern, Node),
    (   stop_node(Node) -> Stopped = true ; Stopped = false ),
    print_node(Node, 1),
    (   Stopped == false
    ->  format("  every part matches: ~s was derived (or print_trigger leaves it out of the output)~n",
               [HeadText])
    ;   true
    ).

%   part(+M, +Names, +Pattern, -Node): node(Id, Text, Count, Children) for Pattern and its parts.

part(M, Names, Pattern, node(_, Text, Count, [])) :-
    Pattern = ev(Event, _, _), !,
    count_matches(M, Pattern, Count),
    named(Names, Event, EventText),
    text(Text, "~s: ~d match~a", [EventText, Count, es(Count)]).
part(M, Names, Pattern, node(_, Text, Count, [NP, NQ])) :-
    binary(Pattern, Op, P, Q), !,
    part(M, Names, P, NP),
    part(M, Names, Q, NQ),
    count_matches(M, Pattern, Count),
    (   Op == or
    ->  text(Text, "or: ~d match~a", [Count, es(Count)])
    ;   aggregate_all(count, ( match(M, inf, P, _, _, _), match(M, inf, Q, _, _, _) ), Joined),
        (   relation_text(Op, Relation) -> true ; Relation = "as its relation requires" ),
        text(Text, "~w: ~d pair~a with equal shared variables, ~d of them ~w",
             [Op, Joined, s(Joined), Count, Relation])
    ).
part(M, Names, where(P, Goal), node(_, Text, Count, [NP])) :- !,
    condition_part(M, Names, where, P, Goal, Text, Count, NP).
part(M, Names, check(P, Goal), node(_, Text, Count, [NP])) :- !,
    condition_part(M, Names, check, P, Goal, Text, Count, NP).
part(M, Names, win(P, Q), node(_, Text, Count, [NP])) :- !,
    part(M, Names, P, NP),
    node_count(NP, CP),
    count_matches(M, win(P, Q), Count),
    text(Text, "window ~w s: ~d of ~d short enough", [Q, Count, CP]).
part(M, Names, neg(N, P, Q), node(_, Text, Count, [NP, NQ])) :- !,
    part(M, Names, P, NP),
    part(M, Names, Q, NQ),
    count_matches(M, seq(P, Q), Pairs),
    count_matches(M, neg(N, P, Q), Count),
    (   N = ev(NE, _, _) -> named(Names, NE, NText) ; NText = "the negated pattern" ),
    text(Text, "not ~s in between: ~d of ~d sequences have none", [NText, Count, Pairs]).
part(M, Names, fnot(P, N, W), node(_, Text, Count, [NP])) :- !,
    part(M, Names, P, NP),
    node_count(NP, CP),
    count_matches(M, fnot(P, N, W), Count),
    text(Text, "fnot: ~d of ~d without a blocking event before", [Count, CP]).
part(M, Names, agg(F, P, V), node(_, Text, Count, [NP])) :- !,
    part(M, Names, P, NP),
    node_count(NP, Count),
    named(Names, F-V, FV),
    text(Text, "aggregate ~s: one value per match", [FV]).
part(M, Names, absent(N, P, D), node(_, Text, Count, [NP])) :- !,
    part(M, Names, P, NP),
    node_count(NP, CP),
    count_matches(M, absent(N, P, D), Count),
    (   N = ev(NE, _, _) -> named(Names, NE, NText) ; NText = "the negated pattern" ),
    text(Text, "not ~s within ~w s after: ~d of ~d have none", [NText, D, Count, CP]).
part(M, Names, timer(P, Delay), node(_, Text, Count, [NP])) :- !,
    part(M, Names, P, NP),
    node_count(NP, Count),
    named(Names, Delay, DelayText),
    text(Text, "timer of ~s s: one per match, raised when the clock reaches it", [DelayText]).
part(M, Names, sync(P, Query), node(_, Text, Count, [NP])) :- !,
    part(M, Names, P, NP),
    node_count(NP, Count),
    named(Names, Query, QueryText),
    text(Text, "synchronized: the query ~s once the memories it reads are complete", [QueryText]).
part(M, Names, sliding(F, P, G, D, V), node(_, Text, Count, [NP])) :- !,
    part(M, Names, P, NP),
    count_matches(M, sliding(F, P, G, D, V), Count),
    named(Names, F-G, FG),
    text(Text, "sliding ~s over ~w s: ~d value~a", [FG, D, Count, s(Count)]).

condition_part(M, Names, Kind, P, Goal, Text, Count, NP) :-
    part(M, Names, P, NP),
    node_count(NP, CP),
    Pattern =.. [Kind, P, Goal],
    count_matches(M, Pattern, Count),
    named(Names, Goal, GoalText),
    text(Text, "~w ~s: ~d of ~d pass~a", [Kind, GoalText, Count, CP, es_verb(Count)]).

node_count(node(_, _, Count, _), Count).

%   stop_node(+Node): the first node, children before parents, with no match whose children
%   all have matches (or a leaf with none), under parts that have no match either, gets its
%   Id bound to `stop`; fails if none.

stop_node(node(Id, _, Count, Children)) :-
    Count =:= 0,                % below a part that matches (an `or`), nothing stops it
    (   member(Child, Children), stop_node(Child)
    ->  true
    ;   forall(member(node(_, _, C, _), Children), C > 0),
        Id = stop
    ).

print_node(node(Id, Text, _, Children), Depth) :-
    indent(Depth),
    (   Id == stop -> format("~s   <- stops here~n", [Text]) ; format("~s~n", [Text]) ),
    D1 is Depth + 1,
    forall(member(Child, Children), print_node(Child, D1)).

text(Text, Format, Args0) :-
    maplist(ending, Args0, Args),
    format(string(Text), Format, Args).

%   named(+Names, +Term, -Text): Term written with the rule's variable names.

named(Names, Term, Text) :-
    \+ \+ ( maplist(bind_name, Names),
            format(string(Text), "~W", [Term, [quoted(true), numbervars(true), portray(true)]]),
            nb_setval(rtl_trace_text, Text) ),
    nb_getval(rtl_trace_text, Text).

bind_name(Name = Var) :-
    (   var(Var) -> Var = '$VAR'(Name) ; true ).

binary(Pattern, Op, P, Q) :-
    compound(Pattern),
    compound_name_arguments(Pattern, Op, [P, Q]),
    (   Op == or
    ->  true
    ;   Op \== cnot,                           % (the pair of `neg/3`)
        once(rtl_relation(Op, _, _, _, _, _))
    ).

relation_text(seq, "in order (the first ends before the second starts)").
relation_text(and, "(any order)").
relation_text(par, "overlapping").
relation_text(equals, "with the same interval").
relation_text(meets, "meeting (the second starts when the first ends)").
relation_text(during, "with the first strictly inside the second").
relation_text(starts, "starting together, the first ending first").
relation_text(finishes, "ending together, the first starting later").

count_matches(M, Pattern, Count) :-
    aggregate_all(count, match(M, inf, Pattern, _, _, _), Count).

%   say(+Format, +Args): format/2, with s(N), es(N) and es_verb(N) in Args written as the
%   plural endings N asks for.

say(Format, Args0) :-
    maplist(ending, Args0, Args),
    format(Format, Args).

ending(s(N), E) :- !, ( N =:= 1 -> E = '' ; E = s ).
ending(es(N), E) :- !, ( N =:= 1 -> E = '' ; E = es ).
ending(es_verb(N), E) :- !, ( N =:= 1 -> E = es ; E = '' ).
ending(A, A).

% ---- reading the rules ----------------------------------------------------------------------

read_rules(RulesText, Rules, Target, TargetText) :-
    read_rules(RulesText, Rules, Target, TargetText, _).

read_rules(RulesText, Rules, Target, TargetText, Names) :-
    rtl_program(M),
    term_string(Rules, RulesText, [module(M), variable_names(Names)]),
    must_be(list, Rules),
    term_string(Target, TargetText, [module(M)]).

% ---- tracing the partial matches of rules ------------------------------------------------------

:- dynamic traced_store/5.      % traced_store(Module, StoreName, Rule, Kind, Description); Kind live or kept
:- dynamic traced_head/2.       % traced_head(Rule, Skeleton)
:- dynamic trace_count/3.       % trace_count(Rule, What, N)

%!  rtl_trace_rules(+Specs, -Out) is det.
%
%   Specs are `[Rule, HeadName, HeadArity, Stores]` lists, Stores `[Name, Arity, Kind,
%   Description]` lists (Kind "live" or "kept"). Starts watching those stores.

rtl_trace_rules(Specs, "") :-
    rtl_program(M),
    retractall(traced_store(_, _, _, _, _)),
    retractall(traced_head(_, _)),
    retractall(trace_count(_, _, _)),
    forall(member([Rule0, HeadName0, HeadArity, Stores], Specs),
           ( atom_string(Rule, Rule0),
             atom_string(HeadName, HeadName0),
             functor(Skeleton, HeadName, HeadArity),
             assertz(traced_head(Rule, Skeleton)),
             forall(member(What, [created, consumed, expired, dropped, replaced, retracted, detections]),
                    assertz(trace_count(Rule, What, 0))),
             forall(member([Name0, Arity, Kind0, Desc], Stores),
                    ( atom_string(Name, Name0), atom_string(Kind, Kind0),
                      assertz(traced_store(M, Name, Rule, Kind, Desc)),
                      functor(Head, Name, Arity),
                      prolog_listen(M:Head, rtl_trace:store_changed(M, Name)) )) )),
    nb_setval(rtl_trace_phase, add),
    rtl_add_output_hook(rtl_trace:trace_phase).

trace_phase(Event, _, _, Op) :-
    nb_setval(rtl_trace_phase, Op),
    (   Op == add
    ->  forall(( traced_head(Rule, Skeleton), \+ Event \= Skeleton ), bump(Rule, detections))
    ;   true
    ).

store_changed(M, Name, Action, Ref) :-
    (   Action == assertz ; Action == asserta ; Action == retract ; Action == erase ),
    traced_store(M, Name, Rule, Kind, Desc),
    catch(clause(_:Head, true, Ref), _, fail),
    !,
    change(Action, Kind, What),
    (   What == ignore
    ->  true
    ;   bump(Rule, What),
        rtl_clock(Clock),
        Head =.. [_|Args],
        (   rtl_policy_positioned(M, Name)          % a policy store: position, start, end
        ->  append(Values, [_, Start, End], Args)
        ;   append(Values, [Start, End], Args)
        ),
        format(user_error, "trace ~w at ~w: ~w ~w ~q over [~w, ~w]~n",
               [Rule, Clock, What, Desc, Values, Start, End])
    ).
store_changed(_, _, _, _).

%   change(+Action, +Kind, -What): what a change of a store means, from where it is made.

change(assertz, live, created) :- !.
change(asserta, live, created) :- !.
change(assertz, kept, ignore) :- !.            % reported as `expired` when it left the live store
change(asserta, kept, ignore) :- !.
change(erase, Kind, What) :- !,
    change(retract, Kind, What).
change(retract, Kind, What) :-
    (   in_ancestor(rtl_ele:rtl_dry_run/3)
    ->  What = ignore
    ;   in_ancestor(rtl_ele:rtl_collect_garbage/1)              % a sweep (clock-driven or of late events)
    ->  ( Kind == live -> What = expired ; What = dropped )
    ;   in_ancestor(rtl_policy:rtl_policy_drop_twins/2)
    ->  What = replaced
    ;   nb_getval(rtl_trace_phase, retract)
    ->  What = retracted
    ;   Kind == kept
    ->  What = dropped
    ;   What = consumed
    ).

in_ancestor(PI) :-
    prolog_current_frame(Frame),
    ancestor(Frame, PI).

ancestor(Frame, PI) :-
    (   prolog_frame_attribute(Frame, predicate_indicator, PI0), PI0 == PI
    ->  true
    ;   prolog_frame_attribute(Frame, parent, Parent),
        ancestor(Parent, PI)
    ).

bump(Rule, What) :-
    retract(trace_count(Rule, What, N0)), !,
    N is N0 + 1,
    assertz(trace_count(Rule, What, N)).
bump(_, _).

%!  rtl_trace_report(-Text) is det.
%
%   One line per traced rule: its detections and what happened to its partial matches.

rtl_trace_report(Text) :-
    findall(Line,
            ( traced_head(Rule, Skeleton),
              functor(Skeleton, Name, Arity),
              findall(N, ( member(W, [detections, created, consumed, expired, dropped, replaced, retracted]),
                           trace_count(Rule, W, N) ), [D, C, U, E, X, R, T]),
              format(string(Line), "trace ~w (~w/~w): ~d detections; partial matches: ~d created, ~d consumed, ~d expired, ~d dropped, ~d replaced, ~d retracted",
                     [Rule, Name, Arity, D, C, U, E, X, R, T]) ),
            Lines),
    atomic_list_concat(Lines, "\n", Text).

% ---- late events ---------------------------------------------------------------------------------

%!  rtl_trace_late(+File, +Rules, -Out) is det.
%
%   Write to File (JSON Lines) every input event that ends more than the delay bound behind
%   the clock: its lateness, and per rule whose pattern has an event of its kind, whether
%   partners it would join may have been forgotten (lateness beyond the delay bound plus the
%   rule's window). Rules are `[Label, Window, Skeletons]` lists (Window -1 for none,
%   Skeletons the text of the event atoms of the rule's pattern).

rtl_trace_late(File, Rules, "") :-
    open(File, write, Stream, [encoding(utf8)]),
    nb_setval(rtl_trace_late_stream, Stream),
    rtl_program(M),
    retractall(late_rule(_, _, _)),
    forall(member([Label0, Window, Skeletons], Rules),
           ( atom_string(Label, Label0),
             forall(member(Text, Skeletons),
                    ( term_string(Skeleton, Text, [module(M)]),
                      assertz(late_rule(Label, Window, Skeleton)) )) )),
    rtl_add_output_hook(rtl_trace:late_event).

:- dynamic late_rule/3.

late_event(Event, Start, End, add) :-
    rtl_clock(Clock),
    rtl_flag(max_delay, Delay),
    Delay \== inf,
    Lateness is Clock - End,
    Lateness > Delay,
    \+ in_ancestor(rtl_ele:rtl_derived/3),
    \+ in_ancestor(rtl_ele:rtl_internal_event/3),
    !,
    findall(Label-Missed,
            ( late_rule(Label, Window, Skeleton), \+ Event \= Skeleton,
              (   Window >= 0, Lateness > Delay + Window -> Missed = true ; Missed = false ) ),
            Pairs0),
    sort(Pairs0, Pairs),
    findall(L, member(L-_, Pairs), Rules0), sort(Rules0, Rules),
    findall(L, member(L-true, Pairs), Missed0), sort(Missed0, Missed),
    format(string(EventText), "~q", [Event]),
    nb_getval(rtl_trace_late_stream, Stream),
    json_list(Rules, RulesJson),
    json_list(Missed, MissedJson),
    rtl_json_string_escape(EventText, Escaped),
    format(Stream, "{\"event\": \"~s\", \"start\": ~w, \"end\": ~w, \"clock\": ~w, \"lateness\": ~w, \"max_delay\": ~w, \"rules\": ~s, \"may_have_missed_partners_in\": ~s}~n",
           [Escaped, Start, End, Clock, Lateness, Delay, RulesJson, MissedJson]),
    flush_output(Stream).
late_event(_, _, _, _).

json_list(Atoms, Json) :-
    findall(Q, ( member(A, Atoms), format(string(Q), "\"~w\"", [A]) ), Qs),
    atomic_list_concat(Qs, ", ", Inner),
    format(string(Json), "[~w]", [Inner]).

%!  rtl_trace_end(-Out) is det.
%
%   Stop tracing rules and late events: remove the listeners and hooks, close the late file.

rtl_trace_end("") :-
    forall(retract(traced_store(M, Name, _, _, _)),
           (   current_predicate(M:Name/Arity)
           ->  functor(Head, Name, Arity),
               catch(prolog_unlisten(M:Head, rtl_trace:store_changed(M, Name)), _, true)
           ;   true
           )),
    rtl_remove_output_hook(rtl_trace:trace_phase),
    rtl_remove_output_hook(rtl_trace:late_event),
    (   nb_current(rtl_trace_late_stream, Stream), Stream \== []
    ->  nb_setval(rtl_trace_late_stream, []),
        close(Stream)
    ;   true
    ).
