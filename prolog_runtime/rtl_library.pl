:- module(rtl_library,
          [ min/3,                      % +X, +Y, -Min
            max/3,                      % +X, +Y, -Max
            datime_minus_datime/3,      % +Time1, +Time2, -Seconds
            ins_static_rule/1,          % :Clause
            del_static_rule/1,          % :Clause
            rtl_target_program/2        % +CallerModule, -ProgramModule
          ]).

/** <module> ETALIS library predicates callable from Retalis programs

The builtins ETALIS offered to the Prolog code of event programs (where conditions,
actions, static rules): min/3, max/3, datime_minus_datime/3 and the insertion and deletion
of static rules. A program module imports them through the runtime; a program that
defines a predicate of the same name and arity keeps its own (SWI-Prolog warns that the
local definition overrides the import).
*/

:- use_module(rtl_ele).
:- use_module(rtl_time).

:- meta_predicate ins_static_rule(:), del_static_rule(:).

%!  min(+X:number, +Y:number, -Min:number) is det.
%!  max(+X:number, +Y:number, -Max:number) is det.
%
%   The smaller (larger) of two numbers; X when they are equal. X and Y may be
%   arithmetic expressions.

min(X, Y, Min) :-
    (   X =< Y -> Min is X ; Min is Y ).

max(X, Y, Max) :-
    (   X >= Y -> Max is X ; Max is Y ).

%!  datime_minus_datime(+Time1, +Time2, -Seconds:integer) is det.
%
%   ETALIS's datime_minus_datime/3: the absolute difference between two time stamps in
%   whole seconds, the order of the arguments does not matter and the sub-second part
%   (the datime counter, ROS nanoseconds, fractions of a second) is ignored. Times are
%   `datime(Y, M, D, H, Min, S, Counter)`, `datime/6`, ETALIS's compact `datime(Stamp,
%   Counter)` and `datime(Stamp)`, ROS `[Secs, NSecs]`, or numbers of seconds.
%   Raises a type error for anything else.

datime_minus_datime(T1, T2, Seconds) :-
    whole_seconds(T1, S1),
    whole_seconds(T2, S2),
    Seconds is abs(S1 - S2).

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
