/*  Drives the original ETALIS engine for tests/test_etalis_differential.py (run it, never
    copy it): loaded in its own `swipl --traditional` process, next to ETALIS's sources.

    swipl --traditional -q tests/etalis_driver.pl ETALIS_DIR POLICY RULES STREAMS

    RULES is an ETALIS event-rule file; STREAMS holds `stream(N, [ev(Event, Time), ...])`
    facts. For each stream, in order, the driver empties ETALIS's stores of partial matches
    and its record of fired events, feeds the events as atomic events, and writes every
    detection of a rule head named `r<digits>` as one line: N, the head (writeq), start and
    end, separated by tabs.
*/

:- initialization(main, main).

main :-
    current_prolog_flag(argv, [EtalisDir, Policy, Rules, Streams]),
    atomic_list_concat([EtalisDir, '/src/etalis.P'], Source),
    load_files(user:Source, [silent(true)]),
    user:set_etalis_flag(event_consumption_policy, Policy),
    user:compile_event_file(Rules),
    read_file_to_terms(Streams, Terms, []),
    forall(member(stream(N, Events), Terms), run_stream(N, Events)).

run_stream(N, Events) :-
    forget_state,
    forall(member(ev(Event, T), Events), user:event(Event, [T, T])),
    forall(( user:fired_event(Head, [S, E]), head_of_rule(Head) ),
           format("~w\t~q\t~w\t~w~n", [N, Head, S, E])).

% What ETALIS keeps between events: the goals waiting for a partner and the fired events
% (its compiled rules stay).
forget_state :-
    retractall(user:etr_db(_, _, _, _, _)),
    retractall(user:etr_db(_, _, _, _, _, _)),
    retractall(user:etr_db(_)),
    retractall(user:fired_event(_, _)).

head_of_rule(Head) :-
    functor(Head, Name, _),
    atom_concat(r, Digits, Name),
    atom_number(Digits, _).
