/*  plunit tests of rtl_math.pl (vectors, quaternions, poses):

        swipl -g run_tests -t halt prolog_runtime/tests/test_math.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module('../rtl_math').

%   approx(+Expected, +Actual): same shape, numbers equal within 1e-12.
approx(A, B) :-
    number(A), !,
    number(B),
    abs(A - B) =< 1.0e-12.
approx(A, B) :-
    is_list(A), !,
    maplist(approx, A, B).

%   same_rotation(+Q1, +Q2): Q1 and Q2 are equal or opposite quaternions.
same_rotation(Q1, Q2) :-
    (   approx(Q1, Q2)
    ->  true
    ;   maplist([X, Y]>>(Y is -X), Q2, N2),
        approx(Q1, N2)
    ).

s2(S) :- S is sqrt(0.5).

rot_z90([0, 0, S, S]) :- s2(S).            % +90 degrees about z
rot_x90([S, 0, 0, S]) :- s2(S).
rot_y90([0, S, 0, S]) :- s2(S).

identity([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]).

:- begin_tests(rtl_math_identity).

test(multiply_identity) :-
    rot_x90(Q),
    quat_multiply([0, 0, 0, 1], Q, A), assertion(approx(Q, A)),
    quat_multiply(Q, [0, 0, 0, 1], B), assertion(approx(Q, B)).

test(rotate_identity, V == [1.0, -2.0, 3.5]) :-
    quat_rotate([0, 0, 0, 1], [1, -2, 3.5], V).

test(chain_empty, P == I) :-
    identity(I),
    pose_chain([], P).

test(chain_single) :-
    rot_y90(Q),
    pose_chain([[[1, 2, 3], Q]], P),
    assertion(approx([[1, 2, 3], Q], P)).

test(compose_identity) :-
    identity(I),
    rot_z90(Q),
    P = [[1, 2, 3], Q],
    pose_compose(I, P, A), assertion(approx(P, A)),
    pose_compose(P, I, B), assertion(approx(P, B)).

test(normalize, Q == [0.6, 0.0, 0.0, 0.8]) :-
    quat_normalize([3, 0, 0, 4], Q).

test(normalize_tiny, Q == [1.0, 0.0, 0.0, 0.0]) :-
    quat_normalize([1.0e-200, 0, 0, 0], Q).

test(conjugate, Q == [-1.0, -2.0, -3.0, 4.0]) :-
    quat_conjugate([1, 2, 3, 4], Q).

:- end_tests(rtl_math_identity).

:- begin_tests(rtl_math_rotations).

test(z90_maps_x_to_y) :-
    rot_z90(Q),
    quat_rotate(Q, [1, 0, 0], V), assertion(approx([0, 1, 0], V)).

test(x90_maps_y_to_z) :-
    rot_x90(Q),
    quat_rotate(Q, [0, 1, 0], V), assertion(approx([0, 0, 1], V)).

test(y90_maps_z_to_x) :-
    rot_y90(Q),
    quat_rotate(Q, [0, 0, 1], V), assertion(approx([1, 0, 0], V)).

test(two_z90_make_z180) :-
    rot_z90(Q),
    quat_multiply(Q, Q, Q2),
    assertion(same_rotation([0, 0, 1, 0], Q2)),
    quat_rotate(Q2, [1, 2, 3], V), assertion(approx([-1, -2, 3], V)).

%   Hamilton order: x90 * z90 first rotates about z, then about x.
test(product_order) :-
    rot_x90(QX), rot_z90(QZ),
    quat_multiply(QX, QZ, Q),
    quat_rotate(Q, [1, 0, 0], V),           % x -z90-> y -x90-> z
    assertion(approx([0, 0, 1], V)).

test(slerp_halfway_z90) :-
    quat_slerp([0, 0, 0, 1], [0, 0, 1, 1], 0.5, Q),  % unnormalised input
    C is cos(pi/8), S is sin(pi/8),
    assertion(approx([0, 0, S, C], Q)).

test(slerp_endpoints) :-
    rot_x90(Q1), rot_y90(Q2),
    quat_slerp(Q1, Q2, 0, A), assertion(approx(Q1, A)),
    quat_slerp(Q1, Q2, 1, B), assertion(approx(Q2, B)).

%   [0,0,-S,-S] is +90 degrees about z written with negative sign: the short arc from
%   the identity passes +45 degrees about z, not -135 degrees.
test(antipodal_takes_short_arc) :-
    s2(S), NS is -S,
    quat_slerp([0, 0, 0, 1], [0, 0, NS, NS], 0.5, Q),
    C is cos(pi/8), Sn is sin(pi/8),
    assertion(same_rotation([0, 0, Sn, C], Q)),
    quat_rotate(Q, [1, 0, 0], V),
    Cx is cos(pi/4), Sy is sin(pi/4),
    assertion(approx([Cx, Sy, 0], V)).

test(slerp_q_and_minus_q) :-
    rot_y90(Q),
    maplist([X, Y]>>(Y is -X), Q, NQ),
    quat_slerp(Q, NQ, 0.3, R),
    assertion(same_rotation(Q, R)).

test(slerp_nearly_equal_uses_nlerp) :-
    quat_slerp([0, 0, 0, 1], [0, 0, 1.0e-9, 1], 0.5, Q),
    assertion(approx([0, 0, 5.0e-10, 1], Q)).

test(slerp_extrapolates) :-
    C8 is cos(pi/8), S8 is sin(pi/8),
    quat_slerp([0, 0, 0, 1], [0, 0, S8, C8], 2, Q),   % 45 degrees, twice
    rot_z90(Z90),
    assertion(same_rotation(Z90, Q)).

:- end_tests(rtl_math_rotations).

:- begin_tests(rtl_math_poses).

test(compose_translation_rotated) :-
    rot_z90(Q),
    pose_compose([[1, 0, 0], Q], [[1, 0, 0], [0, 0, 0, 1]], P),
    assertion(approx([[1, 1, 0], Q], P)).

test(compose_with_inverse_is_identity) :-
    quat_normalize([0.3, -0.5, 0.2, 0.7], Q),
    P = [[1.5, -2, 0.25], Q],
    identity(I),
    pose_inverse(P, Inv),
    pose_compose(P, Inv, A), assertion(approx(I, A)),
    pose_compose(Inv, P, B), assertion(approx(I, B)).

test(chain_is_left_to_right) :-
    rot_z90(Q),
    P1 = [[1, 0, 0], Q], P2 = [[1, 0, 0], [0, 0, 0, 1]], P3 = [[0, 0, 2], Q],
    pose_chain([P1, P2, P3], P),
    pose_compose(P1, P2, P12), pose_compose(P12, P3, Expected),
    assertion(approx(Expected, P)).

test(time_fraction, F == 0.25) :-
    time_fraction(10, 14, 11, F).

test(time_fraction_equal_times, F == 0.0) :-
    time_fraction(3, 3, 7, F).

test(interpolate_at_t1_and_t2) :-
    rot_z90(Q),
    P1 = [[0, 0, 0], [0, 0, 0, 1]], P2 = [[2, 4, 6], Q],
    pose_interpolate(1, P1, 3, P2, 1, A), assertion(A == P1),
    pose_interpolate(1, P1, 3, P2, 3.0, B), assertion(B == P2).

test(interpolate_equal_times) :-
    rot_z90(Q),
    P1 = [[0, 0, 0], [0, 0, 0, 1]], P2 = [[2, 4, 6], Q],
    pose_interpolate(5, P1, 5, P2, 5, A), assertion(A == P1),
    pose_interpolate(5, P1, 5, P2, 9, B), assertion(B == P1).

test(interpolate_takes_every_time_form_of_prev_and_next) :-
    P1 = [[0, 0, 0], [0, 0, 0, 1]], P2 = [[2, 0, 0], [0, 0, 0, 1]],
    pose_interpolate(1, P1, 3, P2, 2, Expected),
    forall(member(T1-T-T2, [ [1, 0]-[2, 0]-[3, 0], (0.5 + 0.5)-(1 + 1)-(9 / 3),
                             datime(1970, 1, 1, 0, 0, 1, 0)-datime(1970, 1, 1, 0, 0, 2)-3.0 ]),
           ( pose_interpolate(T1, P1, T2, P2, T, P), assertion(P == Expected) )),
    catch(pose_interpolate(1, P1, 3, P2, foo + 1, _), error(type_error(time, _), _), Refused = true),
    assertion(Refused == true).

test(interpolate_midway) :-
    rot_z90(Q),
    pose_interpolate(1, [[0, 0, 0], [0, 0, 0, 1]], 3, [[2, 4, 6], Q], 2, P),
    C is cos(pi/8), S is sin(pi/8),
    assertion(approx([[1, 2, 3], [0, 0, S, C]], P)).

test(interpolate_extrapolates) :-
    C8 is cos(pi/8), S8 is sin(pi/8),
    pose_interpolate(0, [[0, 0, 0], [0, 0, 0, 1]], 1, [[1, 2, 3], [0, 0, S8, C8]], 2, P),
    P = [V, Q],
    assertion(approx([2, 4, 6], V)),
    rot_z90(Z90),
    assertion(same_rotation(Z90, Q)).

test(vec_lerp_any_length, V == [1.5, 2.5, 3.5, 4.5, 5.5]) :-
    vec_lerp([1, 2, 3, 4, 5], [2, 3, 4, 5, 6], 0.5, V).

test(vec_lerp_empty, V == []) :-
    vec_lerp([], [], 0.5, V).

test(vec_lerp_exact_endpoints) :-
    vec_lerp([0.1, 0.2], [0.3, 0.7], 0, A), assertion(A == [0.1, 0.2]),
    vec_lerp([0.1, 0.2], [0.3, 0.7], 1, B), assertion(B == [0.3, 0.7]).

:- end_tests(rtl_math_poses).

:- begin_tests(rtl_math_errors).

test(lerp_lengths, error(domain_error(length(2), [1, 2, 3]))) :-
    vec_lerp([1, 2], [1, 2, 3], 0.5, _).

test(lerp_element, error(type_error(number, a))) :-
    vec_lerp([1, a], [1, 2], 0.5, _).

test(lerp_fraction, error(type_error(number, half))) :-
    vec_lerp([1], [2], half, _).

test(lerp_not_list, error(type_error(list, foo))) :-
    vec_lerp(foo, [2], 0.5, _).

test(lerp_unbound, error(instantiation_error)) :-
    vec_lerp(_, [2], 0.5, _).

test(short_quaternion, error(domain_error(quaternion, [0, 0, 1]))) :-
    quat_rotate([0, 0, 1], [1, 0, 0], _).

test(long_vector, error(domain_error(vector3, [1, 0, 0, 0]))) :-
    quat_rotate([0, 0, 0, 1], [1, 0, 0, 0], _).

test(quaternion_element, error(type_error(number, x))) :-
    quat_multiply([0, 0, 0, 1], [x, 0, 0, 1], _).

test(zero_quaternion, error(domain_error(non_zero_quaternion, [0, 0, 0, 0]))) :-
    quat_normalize([0, 0, 0, 0], _).

test(zero_quaternion_slerp, error(domain_error(non_zero_quaternion, [0, 0, 0, 0]))) :-
    quat_slerp([0, 0, 0, 1], [0, 0, 0, 0], 0.5, _).

test(bad_pose, error(domain_error(pose, [[1, 2, 3]]))) :-
    pose_inverse([[1, 2, 3]], _).

test(bad_pose_in_chain, error(domain_error(quaternion, [0, 1]))) :-
    pose_chain([[[0, 0, 0], [0, 0, 0, 1]], [[0, 0, 0], [0, 1]]], _).

test(bad_time, error(type_error(time, later))) :-
    pose_interpolate(0, [[0, 0, 0], [0, 0, 0, 1]], 1, [[0, 0, 0], [0, 0, 0, 1]], later, _).

test(bad_time_fraction, error(type_error(time, '1'))) :-
    time_fraction(0, '1', 0.5, _).

:- end_tests(rtl_math_errors).
