:- module(rtl_library,
          [ min/3,                      % +X, +Y, -Min
            max/3,                      % +X, +Y, -Max
            is_datime/1,                % @Term
            less_datime/2,              % +Time1, +Time2
            equal_datime/2,             % +Time1, +Time2
            between_datime/3,           % +Time, +Low, +High
            datime_plus_sec/3,          % +Datime, +Seconds, -Datime
            datime_minus_sec/3,         % +Datime, +Seconds, -Datime
            datime_minus_datime/3,      % +Time1, +Time2, -Seconds
            ins_static_rule/1,          % :Clause
            del_static_rule/1,          % :Clause
            rtl_target_program/2        % +CallerModule, -ProgramModule
          ]).

/** <module> ETALIS library predicates callable from Retalis programs

The builtins ETALIS offered to the Prolog code of event programs (where conditions,
`prolog(Goal)` steps, actions, static rules), under ETALIS's names: min/3 and max/3 over
numbers and datimes, the datime tests and arithmetic of ETALIS's date_time.P
(is_datime/1, less_datime/2, equal_datime/2, between_datime/3, datime_plus_sec/3,
datime_minus_sec/3, datime_minus_datime/3) and the insertion and deletion of static rules.
A datime is ETALIS's `datime(Y, M, D, H, Min, S)` or `datime(Y, M, D, H, Min, S, Counter)`
(the counter orders events within one second). A program module imports them through the runtime; a program that
defines a predicate of the same name and arity keeps its own (SWI-Prolog warns that the
local definition overrides the import).
*/

:- use_module(rtl_ele).
:- use_module(rtl_time).

:- meta_predicate ins_static_rule(:), del_static_rule(:).

%!  min(+X, +Y, -Min) is det.
%!  max(+X, +Y, -Max) is det.
%
%   The smaller (larger) of two numbers, or of two datimes by less_datime/2; X when
%   neither is smaller. Numbers may be arithmetic expressions.

min(X, Y, Min) :-
    (   datime_pair(X, Y)
    ->  (   less_datime(Y, X) -> Min = Y ; Min = X )
    ;   X =< Y
    ->  Min is X
    ;   Min is Y
    ).

max(X, Y, Max) :-
    (   datime_pair(X, Y)
    ->  (   less_datime(X, Y) -> Max = Y ; Max = X )
    ;   X >= Y
    ->  Max is X
    ;   Max is Y
    ).

datime_pair(X, Y) :-
    is_datime(X),
    is_datime(Y).

%!  is_datime(@Term) is semidet.
%
%   Term is `datime/6` or `datime/7`.

is_datime(T) :-
    compound(T),
    (   compound_name_arity(T, datime, 6)
    ->  true
    ;   compound_name_arity(T, datime, 7)
    ).

%!  less_datime(+Time1, +Time2) is semidet.
%
%   Time1 comes before Time2: two datimes compared field by field (year first, the counter
%   last when both have one), or two numbers. Raises a type error when the two are not
%   both datimes or both numbers.

less_datime(T1, T2) :-
    time_fields(T1, T2, F1, F2),
    fields_less(F1, F2).

%!  equal_datime(+Time1, +Time2) is semidet.
%
%   The two datimes name the same second (their counters are not compared), or the two
%   numbers are equal.

equal_datime(T1, T2) :-
    time_fields(T1, T2, F1, F2),
    second_fields(F1, S1),
    second_fields(F2, S2),
    maplist(=:=, S1, S2).

%!  between_datime(+Time, +Low, +High) is semidet.
%
%   As in ETALIS: a datime strictly between two datimes, a number between two numbers
%   or equal to one of them.

between_datime(T, Low, High) :-
    (   number(T), number(Low), number(High)
    ->  Low =< T, T =< High
    ;   less_datime(Low, T),
        less_datime(T, High)
    ).

time_fields(T1, T2, [T1], [T2]) :-
    number(T1), number(T2), !.
time_fields(T1, T2, F1, F2) :-
    datime_fields(T1, F1),
    datime_fields(T2, F2).

datime_fields(T, Fields) :-
    is_datime(T),
    T =.. [datime|Fields],
    maplist(number, Fields), !.
datime_fields(T, _) :-
    type_error(datime, T).

second_fields([Y, M, D, H, Min, S|_], [Y, M, D, H, Min, S]) :- !.
second_fields(Fields, Fields).

fields_less([A|As], [B|Bs]) :-
    (   A < B
    ->  true
    ;   A =:= B,
        fields_less(As, Bs)
    ).

%!  datime_plus_sec(+Datime, +Seconds, -Datime2) is det.
%!  datime_minus_sec(+Datime, +Seconds, -Datime2) is det.
%
%   The datime Seconds later (earlier), by the calendar (UTC: every day has 24 hours),
%   in the form of Datime (a counter is kept). The seconds field stays an integer when
%   Datime's and Seconds are integers. ETALIS's own version is wrong at the end of a month
%   (`datime(2010,1,30,23,0,0)` plus 3600 gives the 0th of February): this one is not.

datime_plus_sec(Datime, Seconds, Later) :-
    must_be(number, Seconds),
    datime_fields(Datime, [Y, M, D, H, Min, S|Counter]),
    date_time_stamp(date(Y, M, D, H, Min, S, 0, -, -), Stamp),
    Moved is Stamp + Seconds,
    stamp_date_time(Moved, date(Y2, M2, D2, H2, Min2, S2f, _, _, _), 'UTC'),
    (   integer(S), integer(Seconds)
    ->  S2 is round(S2f)
    ;   S2 = S2f
    ),
    Later =.. [datime, Y2, M2, D2, H2, Min2, S2|Counter].

datime_minus_sec(Datime, Seconds, Earlier) :-
    must_be(number, Seconds),
    Back is -Seconds,
    datime_plus_sec(Datime, Back, Earlier).

%!  datime_minus_datime(+Time1, +Time2, -Seconds:integer) is det.
%
%   ETALIS's datime_minus_datime/3: Time1 minus Time2 in whole seconds, negative when
%   Time1 is the earlier; the sub-second part (the datime counter, ROS nanoseconds,
%   fractions of a second) is ignored. Times are `datime(Y, M, D, H, Min, S, Counter)`,
%   `datime/6`, ETALIS's compact `datime(Stamp, Counter)` and `datime(Stamp)`, ROS
%   `[Secs, NSecs]`, or numbers of seconds. Raises a type error for anything else.

datime_minus_datime(T1, T2, Seconds) :-
    whole_seconds(T1, S1),
    whole_seconds(T2, S2),
    Seconds is S1 - S2.

whole_seconds(datime(Stamp, _Counter), S) :- number(Stamp), !, S is floor(Stamp).
whole_seconds(datime(Stamp), S) :- number(Stamp), !, S is floor(Stamp).
whole_seconds(datime(Y, M, D, H, Min, Sec, _Counter), S) :- !,
    whole_seconds(datime(Y, M, D, H, Min, Sec), S).
whole_seconds([Secs, _NSecs], S) :- integer(Secs), !, S = Secs.
whole_seconds(T, S) :-
    (   rtl_time_seconds(T, Seconds)
    ->  S is floor(Seconds)
    ;   type_error(time_stamp, T)
    ).

%!  ins_static_rule(:Clause) is det.
%
%   Add Clause (`Head :- Body` or a fact) at the end of the program's clauses for its
%   predicate. The predicate must be dynamic: new, or declared `:- dynamic` in the
%   program; adding to a predicate defined by the program's static clauses raises a
%   permission error saying so.

ins_static_rule(Caller:Clause) :-
    rtl_target_program(Caller, M),
    clause_head(Clause, Head),
    (   predicate_property(M:Head, defined),
        \+ predicate_property(M:Head, dynamic)
    ->  functor(Head, Name, Arity),
        throw(error(permission_error(modify, static_procedure, Name/Arity),
                    context(ins_static_rule/1,
                            'defined by the program\'s static clauses; declare it :- dynamic in the program')))
    ;   assertz(M:Clause)
    ).

%!  del_static_rule(:Clause) is semidet.
%
%   Remove the first clause of the program that unifies with Clause (`Head :- Body` or a
%   fact). Fails if there is none.

del_static_rule(Caller:Clause) :-
    rtl_target_program(Caller, M),
    clause_head(Clause, Head),
    (   predicate_property(M:Head, dynamic)
    ->  retract(M:Clause)
    ;   predicate_property(M:Head, defined)
    ->  functor(Head, Name, Arity),
        throw(error(permission_error(modify, static_procedure, Name/Arity),
                    context(del_static_rule/1,
                            'defined by the program\'s static clauses; declare it :- dynamic in the program')))
    ;   fail
    ).

clause_head(Clause, Head) :-
    (   var(Clause)
    ->  instantiation_error(Clause)
    ;   Clause = (Head :- _)
    ->  must_be(callable, Head)
    ;   must_be(callable, Clause),
        Head = Clause
    ).

%!  rtl_target_program(+CallerModule, -ProgramModule) is det.
%
%   The program a library call acts on: the caller when it is a compiled program, the
%   running program (rtl_program/1) otherwise (calls from the top level or Python).

rtl_target_program(Caller, M) :-
    (   atom(Caller), current_predicate(Caller:ele_declaration/1)
    ->  M = Caller
    ;   rtl_program(M0)
    ->  M = M0
    ;   existence_error(retalis_program, loaded)
    ).
