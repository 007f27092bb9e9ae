/*  Times the original ETALIS engine for benchmarks/cep_vs_etalis.py (run it, never copy it):
    loaded in its own `swipl --traditional` process, next to ETALIS's sources.

    swipl --traditional -q benchmarks/etalis_bench.pl ETALIS_DIR POLICY RULES EVENTS

    EVENTS holds `ev(Event, Start, End)` facts, read into memory first. The driver feeds them
    as `event(Event, [Start, End])` and prints the CPU seconds of feeding and the number of
    detections of rule heads (the fired events not in the input).
*/

:- initialization(main, main).

main :-
    current_prolog_flag(argv, [EtalisDir, Policy, Rules, Events]),
    atomic_list_concat([EtalisDir, '/src/etalis.P'], Source),
    load_files(user:Source, [silent(true)]),
    user:set_etalis_flag(event_consumption_policy, Policy),
    user:compile_event_file(Rules),
    read_file_to_terms(Events, Terms, []),
    garbage_collect,
    statistics(cputime, T0),
    forall(member(ev(E, S, T), Terms), user:event(E, [S, T])),
    statistics(cputime, T1),
    aggregate_all(count, ( user:fired_event(Head, _), derived(Head) ), Detections),
    Seconds is T1 - T0,
    format("~w ~w~n", [Seconds, Detections]).

derived(Head) :-
    functor(Head, Name, _),
    \+ memberchk(Name, [a, b, c]).
