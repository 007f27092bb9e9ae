/*  plunit tests of rtl_event_types.pl: at most `max_event_types` event types a run. A known
    type is always taken, a new one under the cap becomes known, one beyond it is refused with
    its reason; the type a text writes plainly is found before the text is read, and it is the
    functor reading the text makes (random terms written by writeq/print, with quoted commas
    and brackets in their arguments, are the oracle).

        swipl -g run_tests -t halt prolog_runtime/tests/test_event_types.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(random)).
:- use_module('../retalis', []).
:- use_module('../rtl_event_types').

fresh :-
    rtl_forget_event_types.

cap(Max) :-
    rtl_forget_event_types,
    rtl_cap_event_types(Max).

reason(Name/Arity, Max, Reason) :-
    format(string(Reason), "a new event type ~q beyond the ~D this run takes (--max-event-types)",
           [Name/Arity, Max]).

random_name(Name) :-
    random_member(Name, [a, door, 'Big', 'with space', 'x,y', 'p(q', [], '{}', rauch_ü, b1_c]).

random_argument(Depth, Arg) :-
    random_between(0, 6, K),
    (   Depth > 2 -> K1 = 0 ; K1 = K ),
    (   K1 =:= 0 -> random_between(-5, 99, Arg)
    ;   K1 =:= 1 -> random_name(Arg)
    ;   K1 =:= 2 -> Arg = "a, b) c"
    ;   K1 =:= 3 -> Arg = 'it''s, (x'
    ;   K1 =:= 4 -> D1 is Depth + 1, random_term(D1, Arg)
    ;   K1 =:= 5 -> D1 is Depth + 1, random_argument(D1, A), Arg = [A, A]
    ;   Arg = 2.5
    ).

random_term(Depth, Term) :-
    random_name(Name),
    random_between(0, 4, Arity),
    length(Args, Arity),
    maplist(random_argument(Depth), Args),
    (   Args == [] -> Term = Name ; compound_name_arguments(Term, Name, Args) ).

:- begin_tests(rtl_event_types, [cleanup(fresh)]).

test(no_cap_takes_everything, [setup(fresh)]) :-
    forall(between(1, 50, I),
           ( atom_concat(t, I, Name), Event =.. [Name, I],
             assertion(\+ rtl_event_type_refused(Event, _)),
             format(string(Text), "~q", [Event]),
             assertion(\+ rtl_event_text_refused(Text, _)) )).

test(the_cap_counts_types_not_events, [setup(cap(2)), cleanup(fresh)]) :-
    assertion(\+ rtl_event_type_refused(a(1), _)),
    assertion(\+ rtl_event_type_refused(a(2), _)),            % the same type
    assertion(\+ rtl_event_type_refused(b, _)),
    assertion(\+ rtl_event_type_refused(a(3), _)),
    rtl_event_type_refused(a(1, 2), R1), reason(a/2, 2, E1), assertion(R1 == E1),
    rtl_event_type_refused(c, R2), reason(c/0, 2, E2), assertion(R2 == E2),
    assertion(\+ rtl_event_type_refused(b, _)),
    assertion(\+ rtl_event_text_refused("a(9)", _)),
    rtl_event_text_refused("c(1)", R3), reason(c/1, 2, E3), assertion(R3 == E3).

test(a_refused_text_makes_no_functor, [setup(cap(1)), cleanup(fresh)]) :-
    assertion(\+ rtl_event_type_refused(known, _)),
    assertion(rtl_event_text_refused("never_seen_type_36(1, 2)", _)),
    assertion(\+ current_functor(never_seen_type_36, 2)).

test(text_with_comments_or_codes_is_left_to_the_reader, [setup(cap(1)), cleanup(fresh)]) :-
    assertion(\+ rtl_event_type_refused(known, _)),
    assertion(\+ rtl_event_text_refused("other(1) % c", _)),
    assertion(\+ rtl_event_text_refused("other(0'a)", _)),
    assertion(\+ rtl_event_text_refused("other(/* x */ 1)", _)),
    assertion(rtl_event_type_refused(other(1), _)).           % refused once read

% The type found in a random text is the functor reading it makes.
test(the_type_of_a_text_is_the_functor_of_its_term, [setup(cap(1)), cleanup(fresh)]) :-
    assertion(\+ rtl_event_type_refused('$known', _)),
    set_random(seed(36)),
    forall(between(1, 400, _),
           ( random_term(0, Term),
             random_member(Format, ["~q", "~q.", "  ~q . ", "~p"]),
             format(string(Text), Format, [Term]),
             term_string(Read, Text),
             functor(Read, Name, Arity),
             (   rtl_event_text_refused(Text, Reason)
             ->  reason(Name/Arity, 1, Expected),
                 assertion(Reason == Expected)
             ;   true                                  % not plain: the reader decides
             ),
             assertion(rtl_event_type_refused(Read, _)) )).

test(plain_texts_are_recognised, [setup(cap(1)), cleanup(fresh)]) :-
    assertion(\+ rtl_event_type_refused('$known', _)),
    forall(member(Text-Type, ["door(open)"-door/1, "'x,y'(1, \"a,b\")"-'x,y'/2, "a([1, 2], f(3, 4), '(')"-a/3,
                              " stop ."-stop/0, "p({x, y})"-p/1]),
           ( rtl_event_text_refused(Text, Reason), reason(Type, 1, Expected), assertion(Reason == Expected) )).

test(inf_lifts_the_cap, [setup(cap(1)), cleanup(fresh)]) :-
    assertion(\+ rtl_event_type_refused(one, _)),
    assertion(rtl_event_type_refused(two, _)),
    rtl_cap_event_types(inf),
    assertion(\+ rtl_event_type_refused(two, _)).

:- end_tests(rtl_event_types).
