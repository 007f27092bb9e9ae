/*  plunit tests of rtl_tf.pl (the tf library); tests/test_tf.py runs them and compares the
    library with tf2's BufferCore on random scenarios. Load a compiled Retalis program (any:
    it only receives the events) whose path is in the environment variable TF_TEST_PROGRAM:

        TF_TEST_PROGRAM=/tmp/host.pl swipl -g run_tests -t halt prolog_runtime/tests/test_tf.pl

    TF_TEST_ROAD (c or prolog) chooses the store the tests run on (tf_set_road/1), else the
    runtime's default (the C store when it is built).
*/
:- use_module(library(plunit)).

:- set_prolog_flag(retalis_embedded, true).
:- getenv('TF_TEST_PROGRAM', File) -> consult(File)
   ;  throw(error(existence_error(environment_variable, 'TF_TEST_PROGRAM'), _)).

:- getenv('TF_TEST_ROAD', Road) -> atom_string(A, Road), tf_set_road(A) ; true.

s2(S) :- S is sqrt(0.5).

approx(A, B) :- number(A), !, abs(A - B) =< 1.0e-12.
approx(A, B) :- maplist(approx, A, B).

ros1(Parent, Child, [S, NS], [X, Y, Z], [QX, QY, QZ, QW],
     geometry_msgs__0__TransformStamped(std_msgs__0__Header(0, [S, NS], Parent), Child,
         geometry_msgs__0__Transform(geometry_msgs__0__Vector3(X, Y, Z),
                                     geometry_msgs__0__Quaternion(QX, QY, QZ, QW)))).
ros2(Parent, Child, Stamp, V, Q,
     geometry_msgs__0__TransformStamped(std_msgs__0__Header(Stamp, Parent), Child, T)) :-
    ros1(Parent, Child, Stamp, V, Q, geometry_msgs__0__TransformStamped(_, _, T)).

feed(Event, T) :- rtl_input(add, Event, T, T).

% along_x(+Parent, +Child, +Time, +X): a dynamic link, Child X metres along Parent's x axis
along_x(Parent, Child, Time, X) :-
    tf_add(Parent, Child, Time, [X, 0, 0], [0, 0, 0, 1], dynamic).

:- begin_tests(tf_events, [setup(tf_clear), cleanup(tf_clear)]).

test(ros1_and_ros2_messages_and_static_topic) :-
    tf_clear,
    ros1('"/odom"', '"/base_link"', [10, 0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], A1),
    ros1('"/odom"', '"/base_link"', [11, 0], [2.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], A2),
    s2(S),
    ros2('"base_link"', '"camera"', [0, 0], [0.0, 0.0, 1.0], [0.0, 0.0, S, S], C),
    feed(tf2_msgs__0__TFMessage([A1]), 10),
    feed(tf_static(tf2_msgs__0__TFMessage([C])), 10),
    feed(tf__0__tfMessage([A2]), 11),
    tf_lookup('"odom"', '"camera"', [10, 500000000], [[X, Y, Z], Q]),
    approx([X, Y, Z], [1.5, 0.0, 1.0]),
    approx(Q, [0.0, 0.0, S, S]),
    tf_lookup('"/odom"', '"/camera"', latest, _, Stamp, ok),
    Stamp == [11, 0],
    tf_frames(Frames),
    Frames == ['"odom"', '"base_link"', '"camera"'].

test(plain_atoms) :-
    tf_clear,
    ros2(odom, base, [5, 0], [0.0, 2.0, 0.0], [0.0, 0.0, 0.0, 1.0], T),
    feed(tf2_msgs__0__TFMessage([T]), 5),
    tf_lookup(base, odom, 5.0, [[_, Y, _], _]),
    approx(Y, -2.0).

:- end_tests(tf_events).

:- begin_tests(tf_semantics, [setup(tf_clear), cleanup(tf_clear)]).

test(static_is_never_interpolated_nor_forgotten) :-
    tf_clear,
    tf_add(a, b, 1, [1, 0, 0], [0, 0, 0, 1], static),
    tf_add(a, b, 2, [3, 0, 0], [0, 0, 0, 1], static),
    tf_lookup(a, b, [1000000, 0], [[X, _, _], _], Stamp, ok),
    X =:= 3, Stamp == [1000000, 0].

test(buffer_forgets_old_records) :-
    tf_clear,
    tf_set_buffer(2.0),
    forall(between(1, 5, T), along_x(a, b, T, T)),
    tf_records(3),
    tf_lookup(a, b, 2, _, _, extrapolation(past, 2000000000, 3000000000, 5000000000)),
    along_x(a, b, 1, 9),          % older than the buffer: ignored
    tf_records(3),
    tf_set_buffer(10).

test(repeated_stamp_keeps_the_first) :-
    tf_clear,
    along_x(a, b, 1, 1),
    along_x(a, b, 1, 2),
    tf_lookup(a, b, 1, [[X, _, _], _]),
    X =:= 1.

test(late_record_is_placed_by_stamp) :-
    tf_clear,
    along_x(a, b, 1, 1),
    along_x(a, b, 3, 3),
    along_x(a, b, 2, 0),
    tf_lookup(a, b, 1.5, [[X, _, _], _]),
    approx(X, 0.5).

test(parent_change_uses_the_older_record) :-
    tf_clear,
    along_x(a, c, 1, 1),
    along_x(b, c, 2, 5),
    tf_add(a, b, 0, [0, 0, 0], [0, 0, 0, 1], static),
    tf_parent(c, 1.5, P1), P1 == a,
    tf_parent(c, 2, P2), P2 == b,
    tf_lookup(a, c, 1.5, [[X, _, _], _]),
    X =:= 1.

test(reasons) :-
    tf_clear,
    along_x(a, b, 1, 1),
    along_x(c, d, 1, 1),
    tf_lookup(a, nowhere, 1, _, _, R1), R1 == unknown_frame(nowhere),
    tf_lookup(a, d, 1, _, _, R2), R2 == not_connected(a, d),
    tf_lookup(a, b, 2, _, _, R3), R3 == extrapolation(future, 2000000000, 1000000000, 1000000000),
    \+ tf_can_transform(a, b, 2),
    \+ tf_lookup(a, b, 2, _),
    tf_can_transform(a, b, 1).

test(bad_transforms_are_ignored) :-
    tf_clear,
    along_x(a, a, 1, 1),
    tf_add(a, b, 1, [1, 0, 0], [0, 0, 0, 2], dynamic),
    along_x(a, b, 1, nan),
    tf_records(0).

:- end_tests(tf_semantics).

:- dynamic seen/1.

:- begin_tests(tf_wait, [setup(tf_clear), cleanup(tf_clear)]).

test(runs_when_the_chain_has_data_past_the_time) :-
    tf_clear, retractall(seen(_)),
    along_x(a, b, 1, 1),
    tf_wait(a, b, 2, 5.0, assertz(seen(2))),
    tf_waiting(1),
    \+ seen(_),
    along_x(a, b, 3, 3),
    seen(2),
    tf_waiting(0),
    tf_wait(a, b, 1.5, 5, assertz(seen(1.5))),
    seen(1.5).

test(times_out_as_any_event_moves_the_clock) :-
    tf_clear, retractall(seen(_)),
    along_x(a, b, 1, 1),
    tf_wait(a, b, 2, 0.5, assertz(seen(2))),
    feed(tf_test_other(1), 2.4),
    tf_waiting(1),
    feed(tf_test_other(2), 2.6),
    tf_waiting(0),
    along_x(a, b, 3, 3),
    \+ seen(_).

:- end_tests(tf_wait).

:- begin_tests(tf_state, [setup(tf_clear), cleanup(tf_clear)]).

test(dump_check_load_round_trip) :-
    tf_clear,
    tf_add(map, odom, 0, [0, 0, 1], [0, 0, 0, 1], static),
    along_x(odom, b, 1, 1),
    along_x(odom, b, 2, 2),
    tf_lookup(map, b, 1.5, Pose, _, ok),
    rtl_tf:tf_state_dump(Terms),
    rtl_tf:tf_state_check(Terms),
    Terms = [frame(map, none), frame(odom, static), frame(b, dynamic)|_],
    tf_clear,
    tf_records(0),
    rtl_tf:tf_state_load(Terms),
    tf_records(3),
    tf_lookup(map, b, 1.5, Pose, _, ok).

test(refuses_what_is_not_a_tree) :-
    \+ rtl_tf:tf_state_check([frame(a, none), r(1, 1, 1, 0, 0, 0, 0, 0, 0, 1)]),
    \+ rtl_tf:tf_state_check([frame(a, none), frame(b, dynamic)]),
    \+ rtl_tf:tf_state_check([frame(a, none), frame(b, static),
                               r(2, 1, 1, 0, 0, 0, 0, 0, 0, 1), r(2, 2, 1, 0, 0, 0, 0, 0, 0, 1)]),
    \+ rtl_tf:tf_state_check([frame(a, none), frame(b, dynamic),
                               r(2, 2, 1, 0, 0, 0, 0, 0, 0, 1), r(2, 1, 1, 0, 0, 0, 0, 0, 0, 1)]),
    \+ rtl_tf:tf_state_check([frame(a, none), frame(a, dynamic)]),
    rtl_tf:tf_state_check([frame(a, none), frame(b, dynamic),
                           r(2, 1, 1, 0, 0, 0, 0, 0, 0, 1), r(2, 2, 1, 0, 0, 0, 0, 0, 0, 1)]).

:- end_tests(tf_state).
