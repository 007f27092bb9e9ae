:- module(rtl_aq_rules,
          [ aq_rule_check/2,        % +Rule, -Literals
            aq_rule_clauses/4       % +Rule, +Literals, +Id, -Clauses
          ]).

/** <module> Active queries: rules added at run time (checked, then binarized)

A rule `H :- B` added to a running active-query program (an update script's `+(H :- B).`, the
thesis's runtime reconfiguration) comes from outside the program file and is untrusted.  It
is checked here before anything of it is installed:

  - its body is a conjunction of literals of the program's predicates (those the generated
    program lists in '$aq_kind'/2, or the head's own predicate) and of the definite builtins
    (comparison, term order, `is`, `=`, `\=`, `==`, `\==`, `true`), or `\+` of a builtin.  Nothing else can
    run: no meta-call, no side effect, no library predicate.  This is stricter than
    rtl_sandbox.pl (which lets safe library predicates through), because a rule body of an
    active query is a definite program;
  - its head is a predicate of the program (one with stored facts only becomes a mixed one:
    rtl_aq's aq_add_rule/1) or a new predicate, not a builtin, a system predicate or a name
    starting with `$`.

aq_rule_clauses/4 then produces the same clauses the compiler generates for a program rule
(retalisc/backends/prolog/aq_backend.py): the activation '$aq_act'(H, T), one
'$aq_go'(State, Literal, R) per wait point, and '$aq_final'/6.  The states are named
`sr<Id>_<J>`, distinct from the program's `s<K>_<J>`.
*/

:- use_module(library(lists)).
:- use_module(library(apply)).

builtin(_ < _).
builtin(_ > _).
builtin(_ =< _).
builtin(_ >= _).
builtin(_ =:= _).
builtin(_ =\= _).
builtin(_ is _).
builtin(_ = _).
builtin(_ \= _).
builtin(_ == _).
builtin(_ \== _).
builtin(_ @< _).
builtin(_ @> _).
builtin(_ @=< _).
builtin(_ @>= _).
builtin(true).

%!  aq_rule_check(+Rule, -Literals) is det.
%
%   Literals is the body of Rule (`H :- B`) as a list of builtin(G), call(G)
%   and fact(G); throws aq_rule_error(Message) for a rule that may not be
%   added.

aq_rule_check(Rule, _) :-
    \+ ( nonvar(Rule), Rule = (_ :- _) ), !,
    throw(aq_rule_error('a rule is written Head :- Body')).
aq_rule_check((H :- B), Lits) :-
    check_head(H),
    conj_list(B, Goals),
    maplist(body_literal(H), Goals, Lits0),
    exclude(==(builtin(true)), Lits0, Lits).

check_head(H) :-
    (   var(H) ; \+ callable(H) ), !,
    throw(aq_rule_error('the head of a rule must be an atom or a compound term')).
check_head(H) :-
    functor(H, N, A),
    (   builtin(H) ; predicate_property(system:H, defined) ; sub_atom(N, 0, 1, _, $) ), !,
    format(atom(M), 'cannot define ~q (a builtin or system predicate)', [N/A]),
    throw(aq_rule_error(M)).
check_head(_).

conj_list(B, _) :-
    var(B), !,
    throw(aq_rule_error('a variable cannot be a goal (meta-call) in a rule')).
conj_list((A, B), Goals) :- !,
    conj_list(A, GA),
    conj_list(B, GB),
    append(GA, GB, Goals).
conj_list(G, [G]).

body_literal(_, G, _) :-
    \+ callable(G), !,
    throw(aq_rule_error('a number cannot be a goal')).
body_literal(_, G, builtin(G)) :-
    builtin(G), !.
body_literal(_, \+ G, builtin(\+ G)) :-
    nonvar(G), builtin(G), !.
body_literal(_, G, _) :-
    (   G = (\+ _) ; G = not(_) ; G = tnot(_) ), !,
    throw(aq_rule_error('a rule added at run time may negate builtins only (negation of program predicates must be stratified with the program: put that rule in the program)')).
body_literal(H, G, Lit) :-
    functor(G, N, A), functor(P, N, A),
    (   user:'$aq_kind'(P, Kind)
    ->  Lit =.. [Kind, G]
    ;   functor(H, N, A)
    ->  Lit = call(G)
    ;   format(atom(M), 'unknown predicate ~q: a rule body may use the program''s predicates and the comparison builtins only', [N/A]),
        throw(aq_rule_error(M))
    ).

%!  aq_rule_clauses(+Rule, +Literals, +Id, -Clauses) is det.
%
%   The generated clauses of Rule (`H :- _`, Literals as aq_rule_check/2
%   gives them), its states named sr<Id>_<J>.

aq_rule_clauses((H :- _), Lits, Id, Clauses) :-
    findall(I, ( nth0(I, Lits, L), \+ L = builtin(_) ), Waits),
    length(Lits, Len),
    Ctx = ctx(H, Lits, Id, T),
    (   Waits = [W1|_]
    ->  builtins(Lits, 0, W1, B0),
        enter(Ctx, W1, E1),
        append(B0, [E1], ActBody)
    ;   builtins(Lits, 0, Len, B0),
        append(B0, [aq_answer(T, H, 0)], ActBody)
    ),
    clause_term('$aq_act'(H, T), ActBody, Act),
    go_clauses(Waits, Ctx, Len, Gos),
    final_clause(Waits, Ctx, Len, Final),
    append([[Act], Gos, [Final]], Clauses).

go_clauses([], _, _, []).
go_clauses([W|Ws], Ctx, Len, [C|Cs]) :-
    Ctx = ctx(H, Lits, _, T),
    nth0(W, Lits, Lit), arg(1, Lit, G),
    state(Ctx, W, S),
    (   Ws = [Next|_]
    ->  W1 is W + 1,
        builtins(Lits, W1, Next, Bs),
        enter(Ctx, Next, E),
        append(Bs, [E], Body),
        R = _
    ;   W1 is W + 1,
        builtins(Lits, W1, Len, Bs),
        append(Bs, [aq_answer(T, H, R)], Body)
    ),
    clause_term('$aq_go'(S, G, R), Body, C),
    go_clauses(Ws, Ctx, Len, Cs).

final_clause([], ctx(H, Lits, _, T), Len, '$aq_final'(H, T, act(T), none, true, Check)) :- !,
    builtins(Lits, 0, Len, Bs),
    conj(Bs, Check).
final_clause(Waits, Ctx, Len, '$aq_final'(H, T, S, Kind, G, Check)) :-
    Ctx = ctx(H, Lits, _, T),
    last(Waits, W),
    nth0(W, Lits, Lit),
    Lit =.. [Kind, G],
    state(Ctx, W, S),
    W1 is W + 1,
    builtins(Lits, W1, Len, Bs),
    conj(Bs, Check).

%   The state waiting at literal W: sr<Id>_<W+1>(T, the variables of the head
%   and of the literals before W).
state(ctx(H, Lits, Id, T), W, S) :-
    length(Before, W),
    append(Before, _, Lits),
    term_variables(H-Before, Env),
    J is W + 1,
    format(atom(F), 'sr~w_~w', [Id, J]),
    S =.. [F, T|Env].

enter(Ctx, W, Goal) :-
    Ctx = ctx(_, Lits, _, _),
    nth0(W, Lits, Lit),
    state(Ctx, W, S),
    (   Lit = call(G) -> Goal = aq_wait_call(G, S)
    ;   Lit = fact(G), Goal = aq_wait_fact(G, S)
    ).

builtins(Lits, From, To, Goals) :-
    findall(I-G, ( between(From, To, I), I < To, nth0(I, Lits, builtin(G)) ), Pairs0),
    pairs_values(Pairs0, Goals0),
    bind_like(Pairs0, Lits, Goals0, Goals).

%   findall/3 copies: the goals must share the rule's variables, so they are
%   taken from Lits again.
bind_like([], _, _, []).
bind_like([I-_|Ps], Lits, [_|Gs0], [G|Gs]) :-
    nth0(I, Lits, builtin(G)),
    bind_like(Ps, Lits, Gs0, Gs).

clause_term(Head, [], Head) :- !.
clause_term(Head, Body, (Head :- B)) :-
    conj(Body, B).

conj([], true).
conj([G], G) :- !.
conj([G|Gs], (G, B)) :-
    conj(Gs, B).
