/*  The tf library on a scenario of benchmarks/tf_lookup.py (the input format of
    benchmarks/tf2_peer.cpp, same output), in rules' terms: tf_add/6 per transform and
    tf_lookup/6 per lookup, CPU time from statistics/2, memory tf_bytes/1 (the C store's
    allocations, or the size of the Prolog store's clauses), on the road given (c or prolog,
    default c):

        swipl benchmarks/tf_bench.pl [c|prolog] < SCENARIO.txt
*/
:- use_module('../prolog_runtime/retalis').

:- initialization(main, main).

main :-
    current_prolog_flag(argv, Argv),
    (   Argv = [Road0|_] -> atom_string(Road, Road0) ; Road = c ),
    tf_set_road(Road),
    read_string(user_input, _, Text),
    split_string(Text, "\n", "", Lines),
    foldl(parse, Lines, Ops, []), !,
    partition([O]>>(O = add(_, _, _, _, _, _)), Ops, Adds, Lookups),
    store_bytes(B0),
    statistics(cputime, T0),
    forall(member(add(P, C, S, V, Q, K), Adds), tf_add(P, C, ns(S), V, Q, K)),
    statistics(cputime, T1),
    store_bytes(B1),
    tf_records(Kept),
    runs(Lookups, Runs),
    foldl(time_run, Runs, Answers, []),
    forall(member(A, Answers), writeln(A)),
    length(Adds, NAdds),
    Ingest is T1 - T0,
    format("cpu ingest ~w ~w~n", [Ingest, NAdds]),
    forall(group_total(G, Seconds, Count), format("cpu ~w ~w ~w~n", [G, Seconds, Count])),
    Bytes is B1 - B0,
    format("heap ~w~nkept ~w~n", [Bytes, Kept]).

:- dynamic group_total/3.

parse(Line, Ops0, Ops) :-
    split_string(Line, " ", "", Fields),
    (   Fields = ["a", P, C, S, K | Numbers]
    ->  maplist(number_string, [X, Y, Z, QX, QY, QZ, QW], Numbers),
        number_string(Stamp, S),
        (   K == "1" -> Kind = static ; Kind = dynamic ),
        maplist(atom_string, [PA, CA], [P, C]),
        Ops0 = [add(PA, CA, Stamp, [X, Y, Z], [QX, QY, QZ, QW], Kind)|Ops]
    ;   Fields = ["l", G, T, S, N]
    ->  number_string(Stamp, N),
        maplist(atom_string, [GA, TA, SA], [G, T, S]),
        Ops0 = [lookup(GA, TA, SA, Stamp)|Ops]
    ;   Ops0 = Ops
    ).

runs([], []).
runs([lookup(G, T, S, N)|Ls], [G-[T-S-N|Run]|Runs]) :-
    same_group(Ls, G, Run, Rest),
    runs(Rest, Runs).

same_group([lookup(G, T, S, N)|Ls], G, [T-S-N|Run], Rest) :- !,
    same_group(Ls, G, Run, Rest).
same_group(Ls, _, [], Ls).

% A run of lookups is timed as a whole, as a rule makes them (each answer made and left);
% the answers are collected in a second, untimed, pass.
time_run(G-Run, Answers0, Answers) :-
    statistics(cputime, T0),
    forall(member(T-S-N, Run), tf_lookup(T, S, ns(N), _, _, _)),
    statistics(cputime, T1),
    findall(Pose-Stamp-Result, ( member(T-S-N, Run), tf_lookup(T, S, ns(N), Pose, Stamp, Result) ), Found),
    length(Run, Count),
    Seconds is T1 - T0,
    (   retract(group_total(G, S0, C0)) -> true ; S0 = 0, C0 = 0 ),
    S1 is S0 + Seconds, C1 is C0 + Count,
    assertz(group_total(G, S1, C1)),
    foldl(answer_line, Found, Answers0, Answers).

answer_line(Pose-Stamp-Result, [Line|Lines], Lines) :-
    (   Result == ok
    ->  Pose = [[X, Y, Z], [QX, QY, QZ, QW]],
        Stamp = [S, NS],
        Ns is S * 1000000000 + NS,
        format(string(Line), "~17g ~17g ~17g ~17g ~17g ~17g ~17g ~d", [X, Y, Z, QX, QY, QZ, QW, Ns])
    ;   Line = "error"
    ).

store_bytes(Bytes) :-
    tf_bytes(Bytes).
