/*  plunit tests of rtl_subscriptions.pl: subscriptions deliver every processed event (and its
    deletion) that matches their pattern and conditions within their time interval, as their
    template, in processing order; random subscriptions and streams of additions, deletions
    and an unsubscription are checked against a model. Also: the three spellings, bad
    subscriptions refused with nothing registered, and an ended subscription removed once no
    event it could match can arrive.

        swipl -g run_tests -t halt prolog_runtime/tests/test_subscriptions.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(apply)).
:- use_module(library(random)).
:- use_module('../retalis').

% A program with no rules: the input events alone are delivered.
:- dynamic sub_test_program:ele_trigger/3, sub_test_program:ele_untrigger/3,
           sub_test_program:ele_store/3, sub_test_program:ele_partial_store/2.
sub_test_program:ele_printed(_).
sub_test_program:big(X) :- X > 2.
sub_test_program:odd(X) :- X mod 2 =:= 1.
sub_test_program:twice(X, Y) :- member(Y, [X, X]).

fresh :-
    rtl_use_program(sub_test_program),
    rtl_clear,
    forall(rtl_subscription(Id, C, _, _, _, _, _), catch(delete_subscription(C, Id), _, true)),
    rtl_set_flag(max_delay, inf),
    rtl_output_to(buffer),
    rtl_take_output(_).

line(Template, T, Consumer, Op, Line) :-
    (   Op == add -> Tail = "" ; Tail = ", \"op\": \"retract\"" ),
    format(string(Line), "{\"event\": \"~q\", \"start\": ~w, \"end\": ~w, \"consumer\": \"~w\"~s}",
           [Template, T, T, Consumer, Tail]).

% s(Id, Consumer, Pattern, Conds, Template, Ts, Te)
random_subscription(N, s(N, Consumer, e(K), Conds, Template, Ts, Te)) :-
    format(atom(Consumer), "c~w", [N]),
    random_member(K-Conds, [_-[], 3-[], _-[big(K)], _-[odd(K)], _-[twice(K, _)]]),
    random_member(Template, [e(K), got(K, N), _]),
    random_member(Ts, [-inf, 0, 5, 10]),
    random_member(Te, [inf, 8, 15]).

model_lines([], _, []).
model_lines([Op-e(K)-T|Events], Subs, Lines) :-
    findall(Line, ( member(S, Subs), model_delivery(S, Op, e(K), T, Line) ), Here),
    append(Here, Rest, Lines),
    model_lines(Events, Subs, Rest).

model_delivery(s(_, Consumer, Pattern, Conds, Template, Ts, Te), Op, Event, T, Line) :-
    T >= Ts, T =< Te,
    copy_term(Pattern-Conds-Template, Event-Conds1-Template1),
    forall_solutions(Conds1, Template1, Event, Templates),
    member(Tmpl, Templates),
    line(Tmpl, T, Consumer, Op, Line).

forall_solutions(Conds, Template, Event, Templates) :-
    findall(X, ( maplist([G]>>call(sub_test_program:G), Conds), ( var(Template) -> X = Event ; X = Template ) ),
            Templates).

subscribe_model(s(Id, C, P, Conds, Template, Ts, Te)) :-
    copy_term(s(P, Conds, Template), s(P1, Conds1, Template1)),
    rtl_subscribe(Id, C, P1, Conds1, Template1, Ts, Te).

random_events(N, Events) :-
    numlist(1, N, Ns),
    foldl([_, T0-E0, T-E]>>( random_between(0, 2, Dt), T is T0 + Dt, random_between(0, 6, K),
                             append(E0, [add-e(K)-T], E) ),
          Ns, 0-[], _-Adds),
    findall(X, ( member(A, Adds), ( X = A ; A = add-Ev-T, random(R), R < 0.3, X = retract-Ev-T ) ), Events).

process(add-E-T) :- rtl_event(E, T, T).
process(retract-E-T) :- rtl_retract_event(E, T, T).

:- begin_tests(rtl_subscriptions, [setup(fresh), cleanup(fresh)]).

test(random_subscriptions_against_a_model) :-
    set_random(seed(36)),
    forall(between(1, 80, _),
           ( fresh,
             random_between(1, 4, NS), numlist(1, NS, Ids),
             maplist(random_subscription, Ids, Subs),
             maplist(subscribe_model, Subs),
             random_between(1, 15, NE), random_events(NE, Events),
             maplist(process, Events),
             rtl_take_output(Lines),
             model_lines(Events, Subs, Expected),
             assertion(Lines == Expected) )).

test(the_retalis_2015_and_thesis_spellings, [setup(fresh)]) :-
    subscribe(e(X), [big(X)], hit(X), robot, 1),
    sub(2, "arm", e(Y)-[odd(Y)], _, 4),
    subscribe_between(log, e(Z), seen(Z), 0, 3),
    rtl_event(e(3), 3, 3),
    rtl_event(e(5), 5, 5),
    unsub(2, 5),
    delete_subscription(robot, 1),
    rtl_event(e(7), 7, 7),
    rtl_take_output(Lines),
    assertion(Lines == ["{\"event\": \"hit(3)\", \"start\": 3, \"end\": 3, \"consumer\": \"robot\"}",
                        "{\"event\": \"seen(3)\", \"start\": 3, \"end\": 3, \"consumer\": \"log\"}",
                        "{\"event\": \"hit(5)\", \"start\": 5, \"end\": 5, \"consumer\": \"robot\"}",
                        "{\"event\": \"e(5)\", \"start\": 5, \"end\": 5, \"consumer\": \"arm\"}"]).

test(bad_subscriptions_register_nothing, [setup(fresh)]) :-
    forall(member(Goal, [rtl_subscribe(_, c, _, [], _, -inf, inf),            % no pattern
                         rtl_subscribe(_, c, e(_), [], _, soon, inf),          % not a time
                         rtl_subscribe(_, 42, e(_), [], _, -inf, inf)]),            % not a name
           ( catch(Goal, error(_, _), true) -> true ; true )),
    rtl_subscribe(7, c, e(_), [], _, -inf, inf),
    catch(rtl_subscribe(7, c, e(_), [], _, -inf, inf), error(permission_error(create, subscription, _), _), true),
    findall(Id, rtl_subscription(Id, _, _, _, _, _, _), Ids),
    assertion(Ids == [7]),
    catch(delete_subscription(c, 8), error(existence_error(subscription, _), _), true),
    catch(unsub(8, 1), error(existence_error(subscription, _), _), true).

test(an_ended_subscription_is_removed_past_the_delay_bound, [setup(fresh)]) :-
    rtl_set_flag(max_delay, 1),
    rtl_subscribe(1, c, e(_), [], _, -inf, 5),
    rtl_event(e(1), 4, 4),
    rtl_event(e(2), 6, 6),                         % after its end, within the bound: kept
    assertion(rtl_subscription(1, _, _, _, _, _, _)),
    rtl_event(e(3), 7, 7),                         % 7 - 1 > 5: removed
    assertion(\+ rtl_subscription(1, _, _, _, _, _, _)),
    rtl_take_output(Lines),
    assertion(Lines == ["{\"event\": \"e(1)\", \"start\": 4, \"end\": 4, \"consumer\": \"c\"}"]).

test(a_condition_that_raises_delivers_nothing, [setup(fresh)]) :-
    rtl_subscribe(1, c, e(X), [X > a], _, -inf, inf),
    with_output_to(string(_), rtl_event(e(1), 1, 1)),
    rtl_take_output(Lines),
    assertion(Lines == []).

:- end_tests(rtl_subscriptions).
