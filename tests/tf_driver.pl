/*  The tf library on a scenario of JSON operations, for the tests and the benchmark that
    compare it with tf2 (tests/test_tf.py, tests/tf2_oracle.py, benchmarks/tf_lookup.py):

        swipl tests/tf_driver.pl SCENARIO.json

    The scenario is {"ops": [OP, ...]}, each OP a list:
      ["buffer", Seconds]
      ["add", Parent, Child, StampNs, [X, Y, Z], [QX, QY, QZ, QW], Static]
      ["lookup", Target, Source, TimeNs]          (TimeNs 0: the latest)
      ["can", Target, Source, TimeNs]
    The environment variable RTL_TF_ROAD (c or prolog) chooses the store (tf_set_road/1;
    without it, the runtime's default: the C store when it is built).
    One JSON line per lookup on standard output: {"pose": [X, Y, Z, QX, QY, QZ, QW],
    "stamp": Ns}, or {"error": [Kind, ...]} with tf_lookup/6's reason as a list; per can,
    {"can": Bool}.
*/
:- use_module(library(http/json)).
:- use_module('../prolog_runtime/retalis').

:- initialization(main, main).

main :-
    current_prolog_flag(argv, [File]),
    (   getenv('RTL_TF_ROAD', Road0) -> atom_string(Road, Road0), tf_set_road(Road) ; true ),
    setup_call_cleanup(open(File, read, In), json_read_dict(In, Scenario, [value_string_as(atom)]), close(In)),
    forall(member(Op, Scenario.ops), ( op(Op) -> true ; format(user_error, "failed: ~q~n", [Op]), halt(1) )).

op([buffer, Seconds]) :-
    tf_set_buffer(Seconds).
op([add, Parent, Child, Stamp, T, Q, Static]) :-
    (   Static == true -> Kind = static ; Kind = dynamic ),
    tf_add(Parent, Child, ns(Stamp), T, Q, Kind).
op([lookup, Target, Source, Time]) :-
    tf_lookup(Target, Source, ns(Time), Pose, Stamp, Result),
    (   Result == ok
    ->  Pose = [[X, Y, Z], [QX, QY, QZ, QW]],
        Stamp = [S, NS],
        Ns is S * 1000000000 + NS,
        json_write_dict(current_output, _{pose: [X, Y, Z, QX, QY, QZ, QW], stamp: Ns}, [width(0)])
    ;   Result =.. List,
        json_write_dict(current_output, _{error: List}, [width(0)])
    ),
    nl.
op([can, Target, Source, Time]) :-
    (   tf_can_transform(Target, Source, ns(Time)) -> B = true ; B = false ),
    json_write_dict(current_output, _{can: B}, [width(0)]),
    nl.
