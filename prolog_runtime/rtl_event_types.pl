:- module(rtl_event_types,
          [ rtl_event_text_refused/2,    % +Text, -Reason
            rtl_event_type_refused/2,    % +Event, -Reason
            rtl_cap_event_types/1,       % +Max
            rtl_forget_event_types/0
          ]).

/** <module> At most `max_event_types` event types per run (docs/runtime.md, "Untrusted input")

Each distinct functor SWI-Prolog reads stays in its functor table for good, with the atom of
its name (about 140 bytes; 200,000 event types `t1(1)`, `t2(1)`, ... grow a run by 28 MB, the
same as making their functors in a bare `swipl`: the runtime keeps nothing per type beyond
them). The flag `max_event_types` (default `inf`; `--max-event-types N`) caps the event types
(Name/Arity of an input event) a run takes: an event line of a new type once N are known is
rejected with its reason and counted as rejected.

The functor of an event is made when its text is read, so the type of the text is found
before it is read where the text says it plainly (`name(Arg, ...)`, `'name'(...)` or an atom,
without comments or `0'c` codes): such a refused line makes no functor. The type of any other
text is known, and refused, once it is read. While the cap is set, lines are read in Prolog
(the C reader makes the event's term before the type could be checked).
*/

:- dynamic known_type/2.          % known_type(Name, Arity): an event type this run takes

%!  capped_hook(+Capped:boolean) is nondet.
%
%   Multifile: the cap was set (`true`) or taken off (`false`); rtl_io.pl holds its C reader
%   back while the cap is set.

:- multifile capped_hook/1.

%!  rtl_cap_event_types(+Max) is det.
%
%   Called when the flag `max_event_types` is set to Max (an integer > 0 or `inf`).

rtl_cap_event_types(Max) :-
    (   Max == inf -> Capped = false ; Capped = true ),
    forall(capped_hook(Capped), true),
    nb_setval(rtl_max_event_types, Max).

%!  rtl_forget_event_types is det.
%
%   The run starts anew (a new Engine): no type known, no cap.

rtl_forget_event_types :-
    retractall(known_type(_, _)),
    flag(rtl_event_types, _, 0),
    rtl_cap_event_types(inf).

max_types(Max) :-
    (   nb_current(rtl_max_event_types, Max0), Max0 \== []
    ->  Max = Max0
    ;   Max = inf
    ).

%!  rtl_event_text_refused(+Text, -Reason) is semidet.
%
%   The event text Text is of a new type that the cap refuses, as far as its text says
%   (before it is read).

rtl_event_text_refused(Text, Reason) :-
    capped(Max),
    text_type(Text, Name, Arity),
    new_type(Name, Arity, Known),
    Known >= Max,
    refusal(Name, Arity, Max, Reason).

%!  rtl_event_type_refused(+Event, -Reason) is semidet.
%
%   Event (read) is of a new type that the cap refuses; a new type under the cap is taken
%   (known from now on).

rtl_event_type_refused(Event, Reason) :-
    capped(Max),
    functor(Event, Name, Arity),
    new_type(Name, Arity, Known),
    (   Known >= Max
    ->  refusal(Name, Arity, Max, Reason)
    ;   assertz(known_type(Name, Arity)),
        flag(rtl_event_types, _, Known + 1),
        fail
    ).

capped(Max) :-
    max_types(Max),
    Max \== inf.

% Name/Arity is not a type of this run, which knows Known types.
new_type(Name, Arity, Known) :-
    \+ known_type(Name, Arity),
    flag(rtl_event_types, Known, Known).

refusal(Name, Arity, Max, Reason) :-
    format(string(Reason), "a new event type ~q beyond the ~D this run takes (--max-event-types)",
           [Name/Arity, Max]).

%   text_type(+Text, -Name, -Arity) is semidet: the functor of the term Text holds, when the
%   text writes it plainly.

text_type(Text, Name, Arity) :-
    \+ sub_string(Text, _, _, _, "%"),
    \+ sub_string(Text, _, _, _, "/*"),
    \+ sub_string(Text, _, _, _, "0'"),
    string_codes(Text, Codes0),
    layout(Codes0, Codes1),
    name_token(Codes1, NameCodes, Codes2),
    (   Codes2 = [0'(|Codes3]
    ->  arguments(Codes3, 0, 1, Arity, Codes4)
    ;   Arity = 0, Codes4 = Codes2
    ),
    layout(Codes4, Codes5),
    ( Codes5 = [0'.|Codes6] -> layout(Codes6, []) ; Codes5 == [] ),
    atom_codes(Name, NameCodes).

layout([C|Cs], Rest) :- code_type(C, space), !, layout(Cs, Rest).
layout(Cs, Cs).

name_token([C|Cs], [C|Name], Rest) :-
    code_type(C, lower), !,
    alnums(Cs, Name, Rest).
name_token([0''|Cs], Name, Rest) :-                     % 'name' without escapes
    plain_quoted(Cs, Name, Rest).

alnums([C|Cs], [C|Name], Rest) :- code_type(C, csym), !, alnums(Cs, Name, Rest).
alnums(Cs, [], Cs).

plain_quoted([0''|Rest], [], Rest) :- !, Rest \= [0''|_].
plain_quoted([C|Cs], [C|Name], Rest) :- C \== 0'\\, C \== 0'\n, plain_quoted(Cs, Name, Rest).

%   arguments(+Codes, +Depth, +Arity0, -Arity, -Rest): the arguments of a compound term up
%   to its closing bracket (commas at depth 0 separate them; quoted text is skipped).

arguments([C|Cs], Depth, A0, A, Rest) :-
    (   C == 0'), Depth =:= 0
    ->  A = A0, Rest = Cs
    ;   memberchk(C, `([{`)
    ->  D is Depth + 1, arguments(Cs, D, A0, A, Rest)
    ;   memberchk(C, `)]}`)
    ->  D is Depth - 1, arguments(Cs, D, A0, A, Rest)
    ;   C == 0',, Depth =:= 0
    ->  A1 is A0 + 1, arguments(Cs, Depth, A1, A, Rest)
    ;   memberchk(C, `'"\``)
    ->  skip_quoted(Cs, C, Cs1), arguments(Cs1, Depth, A0, A, Rest)
    ;   arguments(Cs, Depth, A0, A, Rest)
    ).

skip_quoted([C|Cs], Quote, Rest) :-
    (   C == 0'\\
    ->  Cs = [_|Cs1], skip_quoted(Cs1, Quote, Rest)
    ;   C == Quote
    ->  ( Cs = [Quote|Cs1] -> skip_quoted(Cs1, Quote, Rest) ; Rest = Cs )
    ;   skip_quoted(Cs, Quote, Rest)
    ).
