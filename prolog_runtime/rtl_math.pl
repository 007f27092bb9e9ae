:- module(rtl_math,
          [ vec_lerp/4,                 % +V1, +V2, +Fraction, -V
            quat_normalize/2,           % +Q, -QN
            quat_multiply/3,            % +Q1, +Q2, -Q
            quat_conjugate/2,           % +Q, -QC
            quat_rotate/3,              % +Q, +V, -V2
            quat_slerp/4,               % +Q1, +Q2, +Fraction, -Q
            pose_compose/3,             % +Pose1, +Pose2, -Pose
            pose_inverse/2,             % +Pose, -Inverse
            pose_chain/2,               % +Poses, -Pose
            time_fraction/4,            % +T1, +T2, +T, -Fraction
            pose_interpolate/6,         % +T1, +Pose1, +T2, +Pose2, +T, -Pose
            datime_interpolate/4,       % +T1, +T2, +T, -Fraction       (Retalis 2015)
            convert_to_datime/2,        % +Stamp, -Time                 (Retalis 2015)
            interpolate_quaternion/6,   % +V1, +Q1, +V2, +Q2, +[F], -[V, Q] (Retalis 2015)
            transform_quaternion/2      % +Poses, -Pose                 (Retalis 2015)
          ]).

:- use_module(rtl_time).

/** <module> Vectors, quaternions and poses for state-based knowledge

Small geometry library for Retalis programs that keep the history of robot poses (for
example the transforms of ROS `tf`) and need the pose at a time between two samples.

Conventions:

  - A vector is a list `[X, Y, Z]` of numbers.
  - A quaternion is a list `[QX, QY, QZ, QW]` in ROS order (vector part first, scalar
    part `QW` last). `[0, 0, 0, 1]` is the identity rotation. Quaternions are multiplied
    with the Hamilton product, so a unit quaternion `Q` rotates a vector `V` as
    `Q * V * conj(Q)` and `Q1 * Q2` first rotates by `Q2`, then by `Q1`.
  - A pose (a rigid transform) is a list `[V, Q]` of a translation vector and a unit
    quaternion. The pose of frame B in frame A maps coordinates in B to coordinates in
    A: `P_A = V + rotate(Q, P_B)`.
  - Results are floats. Integer inputs are accepted everywhere.

Rotations and poses assume *unit* quaternions and use them as given (only
quat_normalize/2 and quat_slerp/4 normalise), so normalise quaternions that come from
outside with quat_normalize/2 first when they may be far from unit length.

Every exported predicate is det and checks its arguments: an unbound argument raises an
instantiation error, a non-list a `type_error(list, Culprit)`, an element that is not a
number a `type_error(number, Element)` whose context names the list it is in, and a list
of the wrong length a `domain_error(vector3, V)`, `domain_error(quaternion, Q)`,
`domain_error(pose, P)` or (vec_lerp/4) `domain_error(length(N), V2)`.
*/

                 /*******************************
                 *            VECTORS           *
                 *******************************/

%!  vec_lerp(+V1:list(number), +V2:list(number), +Fraction:number, -V:list(float)) is det.
%
%   Linear interpolation of two lists of numbers of the same (any) length: element-wise
%   `(1 - Fraction) * A + Fraction * B`. Fraction 0 gives V1 and Fraction 1 gives V2
%   (exactly, as floats); a Fraction outside [0, 1] extrapolates along the same line.
%
%   @error domain_error(length(N), V2) if V2 does not have the length N of V1.

vec_lerp(V1, V2, F, V) :-
    Ctx = vec_lerp/4,
    check_numbers(Ctx, 'first list', V1),
    check_numbers(Ctx, 'second list', V2),
    length(V1, N1),
    length(V2, N2),
    (   N1 =:= N2
    ->  true
    ;   throw(error(domain_error(length(N1), V2),
                    context(rtl_math:Ctx, 'the lists must have the same length')))
    ),
    check_number(Ctx, F),
    lerp_list(V1, V2, F, V).

lerp_list([], [], _, []).
lerp_list([A|As], [B|Bs], F, [C|Cs]) :-
    C is float((1 - F) * A + F * B),
    lerp_list(As, Bs, F, Cs).

                 /*******************************
                 *          QUATERNIONS         *
                 *******************************/

%!  quat_normalize(+Q:list(number), -QN:list(float)) is det.
%
%   QN is Q divided by its length. The components are scaled by the largest absolute
%   component first, so very small or very large quaternions do not underflow or
%   overflow.
%
%   @error domain_error(non_zero_quaternion, Q) if all components are zero.

quat_normalize(Q, QN) :-
    check_quat(quat_normalize/2, Q),
    quat_normalize_(quat_normalize/2, Q, QN).

%!  quat_multiply(+Q1:list(number), +Q2:list(number), -Q:list(float)) is det.
%
%   Hamilton product `Q = Q1 * Q2`. For unit quaternions Q is the rotation "first Q2,
%   then Q1" (the rotation matrix of Q is that of Q1 times that of Q2). Not normalised.

quat_multiply(Q1, Q2, Q) :-
    Ctx = quat_multiply/3,
    check_quat(Ctx, Q1),
    check_quat(Ctx, Q2),
    quat_mul_(Q1, Q2, Q).

%!  quat_conjugate(+Q:list(number), -QC:list(float)) is det.
%
%   `[-QX, -QY, -QZ, QW]`: the inverse rotation of a unit quaternion.

quat_conjugate(Q, QC) :-
    check_quat(quat_conjugate/2, Q),
    quat_conj_(Q, QC).

%!  quat_rotate(+Q:list(number), +V:list(number), -V2:list(float)) is det.
%
%   V2 is vector V rotated by the unit quaternion Q, that is the vector part of
%   `Q * [V, 0] * conj(Q)`. Q is used as given (not normalised); for a Q that is not of
%   unit length the result is not a pure rotation of V.

quat_rotate(Q, V, V2) :-
    Ctx = quat_rotate/3,
    check_quat(Ctx, Q),
    check_vec3(Ctx, V),
    quat_rot_(Q, V, V2).

%!  quat_slerp(+Q1:list(number), +Q2:list(number), +Fraction:number, -Q:list(float)) is det.
%
%   Spherical linear interpolation from Q1 (Fraction 0) to Q2 (Fraction 1) at constant
%   angular speed along the shortest arc. Q1 and Q2 are normalised first. When their dot
%   product is negative Q2 is replaced by its negation (the same rotation), so the
%   interpolation never takes the long way round; the result at Fraction 1 is then
%   `-Q2` normalised, which is the same rotation as Q2.
%
%   With `Omega` the angle between the two unit quaternions as 4-vectors (half the angle
%   of the rotation from Q1 to Q2), the result is
%   `(sin((1-F)*Omega) * Q1 + sin(F*Omega) * Q2) / sin(Omega)`. Omega is computed as
%   `2 * atan2(|Q1 - Q2|, |Q1 + Q2|)`, which stays accurate for nearly equal
%   quaternions. When Omega < 1.0e-6 (the two rotations differ by less than 2.0e-6 rad)
%   the normalised linear interpolation `(1-F)*Q1 + F*Q2` is used instead; its
%   difference from the exact slerp there is far below float precision.
%
%   A Fraction outside [0, 1] extrapolates with the same formula (the rotation continues
%   at the same angular speed about the same axis). The result is always normalised.

quat_slerp(Q1, Q2, F, Q) :-
    Ctx = quat_slerp/4,
    check_quat(Ctx, Q1),
    check_quat(Ctx, Q2),
    check_number(Ctx, F),
    quat_slerp_(Ctx, Q1, Q2, F, Q).

                 /*******************************
                 *             POSES            *
                 *******************************/

%!  pose_compose(+Pose1:list, +Pose2:list, -Pose:list) is det.
%
%   Pose1 `[V1, Q1]` is the pose of frame B in frame A, Pose2 `[V2, Q2]` the pose of
%   frame C in frame B; Pose `[V, Q]` is the pose of frame C in frame A, with
%   `V = V1 + rotate(Q1, V2)` and `Q = Q1 * Q2` (Q is not renormalised).

pose_compose(P1, P2, P) :-
    Ctx = pose_compose/3,
    check_pose(Ctx, P1),
    check_pose(Ctx, P2),
    pose_compose_(P1, P2, P).

%!  pose_inverse(+Pose:list, -Inverse:list) is det.
%
%   The inverse transform: for the pose `[V, Q]` of frame B in frame A, the pose of
%   frame A in frame B, `[-rotate(conj(Q), V), conj(Q)]`. Composing a pose with its
%   inverse (either way round) gives the identity up to rounding.

pose_inverse(P, Inv) :-
    check_pose(pose_inverse/2, P),
    pose_inverse_(P, Inv).

%!  pose_chain(+Poses:list, -Pose:list) is det.
%
%   Composes a list of poses left to right with pose_compose/3: for the poses of frame
%   F1 in F0, F2 in F1, ..., Fn in Fn-1, Pose is the pose of Fn in F0. The empty list
%   gives the identity `[[0.0,0.0,0.0],[0.0,0.0,0.0,1.0]]`.

pose_chain(Poses, P) :-
    Ctx = pose_chain/2,
    check_list(Ctx, Poses),
    forall(member(P0, Poses), check_pose(Ctx, P0)),
    identity_pose(I),
    foldl(chain_step, Poses, I, P).

chain_step(Next, Acc, P) :-
    pose_compose_(Acc, Next, P).

identity_pose([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]).

%!  time_fraction(+T1, +T2, +T, -Fraction:float) is det.
%
%   `Fraction = (T - T1) / (T2 - T1)`: 0 at T1, 1 at T2, below 0 before T1 and above
%   1 after T2. When T1 and T2 are the same time Fraction is 0.0 (whatever T is). A time is
%   a number of seconds, a ROS stamp `[Sec, NSec]` or a `datime/7` term (nanoseconds in its
%   counter). The differences are taken first and exactly (each time as the exact rational
%   it stands for: a float's own value, a stamp's `Sec + NSec/10^9`), then divided, and
%   only the quotient is rounded to a float: no precision is lost to the size of epoch
%   seconds (a float time near 1.4e9 is only good to 2.4e-7 s, so times given as floats
%   carry that uncertainty in themselves; stamps none).

time_fraction(T1, T2, T, F) :-
    time_fraction_(time_fraction/4, T1, T2, T, F).

time_fraction_(Ctx, T1, T2, T, F) :-
    exact_time(Ctx, T1, X1),
    exact_time(Ctx, T2, X2),
    exact_time(Ctx, T, X),
    exact_fraction(X1, X2, X, F).

exact_fraction(X1, X2, X, F) :-
    (   X1 =:= X2
    ->  F = 0.0
    ;   F is float((X - X1) / (X2 - X1))
    ).

% exact_time(+Ctx, +Time, -Exact): Time as an exact rational number of seconds.
exact_time(Ctx, T, X) :-
    (   var(T)
    ->  throw(error(instantiation_error, context(rtl_math:Ctx, _)))
    ;   integer(T)
    ->  X = T
    ;   float(T)
    ->  (   T =:= T, abs(T) =\= inf
        ->  X is rational(T)
        ;   throw(error(type_error(time, T), context(rtl_math:Ctx, 'a time must be finite')))
        )
    ;   T = [S, NS], integer(S), integer(NS), between(0, 999999999, NS)
    ->  X is S + NS rdiv 1000000000
    ;   T = datime(Y, Mo, D, H, Mi, Sec, NS), integer(NS), between(0, 999999999, NS),
        rtl_time_seconds(datime(Y, Mo, D, H, Mi, Sec), Base)
    ->  X is rational(Base) + NS rdiv 1000000000
    ;   rtl_time_seconds(T, Secs)
    ->  X is rational(Secs)
    ;   T = datime(_, _, _, _, _, _, NS)
    ->  throw(error(domain_error(datime_nanoseconds, NS), context(rtl_math:Ctx,
                    'the counter of datime/7 is the nanoseconds of the stamp, an integer in [0, 10^9)')))
    ;   compound(T), \+ is_list(T), catch(V is T, _, fail), number(V)
    ->  exact_time(Ctx, V, X)              % an expression such as T + 0.1, as prev and next take
    ;   throw(error(type_error(time, T), context(rtl_math:Ctx,
                    'a time is seconds, an arithmetic expression, [Secs, NSecs] or datime/7')))
    ).

%!  pose_interpolate(+T1:number, +Pose1:list, +T2:number, +Pose2:list, +T:number,
%!                   -Pose:list) is det.
%
%   The pose at time T given Pose1 at time T1 and Pose2 at time T2. With F the
%   time_fraction/4 of T, the translation is vec_lerp/4 of the two translations and the
%   rotation quat_slerp/4 of the two rotations (shortest arc, normalised), both at F.
%
%   When `T =:= T1` the term Pose1 itself is returned unchanged, and otherwise when
%   `T =:= T2` Pose2 itself, so a time that hits a sample reads that sample back
%   exactly. When `T1 =:= T2` (F is 0) Pose1 itself is returned for every T.
%
%   Extrapolation: a T outside the interval between T1 and T2 is allowed and gives F < 0
%   or F > 1; the translation then continues along the straight line through the two
%   translations (constant velocity) and the rotation continues about the same axis at
%   the same angular speed (the slerp formula with F outside [0, 1]). Whether such an
%   extrapolation is meaningful is the caller's decision.

pose_interpolate(T1, P1, T2, P2, T, P) :-
    Ctx = pose_interpolate/6,
    exact_time(Ctx, T1, X1),
    exact_time(Ctx, T2, X2),
    exact_time(Ctx, T, X),
    check_pose(Ctx, P1),
    check_pose(Ctx, P2),
    (   ( X =:= X1 ; X1 =:= X2 )
    ->  P = P1
    ;   X =:= X2
    ->  P = P2
    ;   exact_fraction(X1, X2, X, F),
        P1 = [V1, Q1],
        P2 = [V2, Q2],
        lerp_list(V1, V2, F, V),
        quat_slerp_(Ctx, Q1, Q2, F, Q),
        P = [V, Q]
    ).

                 /*******************************
                 *   THE RETALIS 2015 BUILTINS  *
                 *******************************/

%   The original release (Listings A.3-A.4 of the thesis) called these from its programs;
%   they are here under the same names and argument orders so that those programs run
%   unchanged. They are thin, checked wrappers of the predicates above.
%
%   Times. The original stamped events with datime(Y, M, D, H, Min, S, Counter) terms whose
%   Counter held the ROS nanoseconds; retalisc stamps every event with a number of seconds
%   (new_event(E, Sec, NSec) gives `Sec + NSec/10^9`), and so do the record times that
%   prev/5, next/6 and next_inf/5 return. The time arguments below accept a number of
%   seconds, a ROS stamp `[Sec, NSec]` or a `datime/7` term (read as rtl_time:
%   rtl_time_seconds/2 reads it: the counter is the stamp's nanoseconds, checked).

%!  datime_interpolate(+T1, +T2, +T, -Fraction:float) is det.
%
%   `Fraction = (T - T1) / (T2 - T1)`, the position of T between T1 and T2 (0 at T1, 1 at
%   T2, outside [0, 1] before T1 or after T2). When T1 and T2 are the same time Fraction
%   is 0.0. As time_fraction/4: the times are subtracted exactly before the division, so
%   no precision is lost to the size of epoch seconds.
%
%   @error type_error(time, X) for an argument that is not a time.
%   @error domain_error(datime_nanoseconds, C) for a datime/7 whose counter C is not an
%   integer in [0, 10^9).
%   @error evaluation_error(float_overflow) when T1 and T2 are so close that Fraction is
%   beyond the largest float.

datime_interpolate(T1, T2, T, F) :-
    time_fraction_(datime_interpolate/4, T1, T2, T, F).

%!  convert_to_datime(+Stamp, -Time:number) is det.
%
%   The time of a ROS stamp `[Sec, NSec]` as the runtime writes event times: the number
%   `Sec + NSec/10^9`, computed exactly as new_event/3 stamps an event, so a record raised
%   with the same stamp is found at exactly this time by prev and next. A number is
%   returned unchanged and a `datime/7` term is converted to its seconds. (In the 2015
%   release the result was a datime/7 term; every time argument of retalisc accepts the
%   number in its place.)

convert_to_datime(Stamp, T) :-
    (   var(Stamp)
    ->  throw(error(instantiation_error, context(rtl_math:convert_to_datime/2, _)))
    ;   rtl_time_seconds(Stamp, T0)
    ->  T = T0
    ;   throw(error(type_error(time, Stamp), context(rtl_math:convert_to_datime/2,
                    'a time is seconds, [Secs, NSecs] or datime/7')))
    ).

%!  interpolate_quaternion(+V1:list, +Q1:list, +V2:list, +Q2:list, +Fraction,
%!                         -Pose:list) is det.
%
%   Pose `[V, Q]` between the pose `[V1, Q1]` (at Fraction 0) and `[V2, Q2]` (at Fraction
%   1): V is the linear interpolation of the translations (vec_lerp/4) and Q the spherical
%   linear interpolation of the rotations along the shortest arc (quat_slerp/4: Q2 is
%   negated first when the two quaternions are more than 90 degrees apart as 4-vectors, so
%   antipodal inputs, which are the same rotation, give that rotation), normalised.
%   Fraction is written `[F]` as in the original's calls, or as a plain number.
%   Quaternions are `[QX, QY, QZ, QW]` (ROS order).

interpolate_quaternion(V1, Q1, V2, Q2, Fraction, [V, Q]) :-
    Ctx = interpolate_quaternion/6,
    (   Fraction = [F]
    ->  true
    ;   F = Fraction
    ),
    check_number(Ctx, F),
    check_vec3(Ctx, V1),
    check_vec3(Ctx, V2),
    check_quat(Ctx, Q1),
    check_quat(Ctx, Q2),
    lerp_list(V1, V2, F, V),
    quat_slerp_(Ctx, Q1, Q2, F, Q).

%!  transform_quaternion(+Poses:list, -Pose:list) is det.
%
%   Composes the poses `[[X, Y, Z], [QX, QY, QZ, QW]]` left to right (pose_chain/2): for
%   the pose of frame F1 in F0, F2 in F1, ..., Fn in Fn-1, Pose is the pose of Fn in F0.
%   In Listing A.4 the list ends with the marker's pose relative to the camera, so Pose
%   is the marker's pose in the first frame (the world). Each pose's quaternion is
%   normalised before it is used (quaternions from messages are only near unit length),
%   and so is the result's.

transform_quaternion(Poses, [V, QN]) :-
    Ctx = transform_quaternion/2,
    check_list(Ctx, Poses),
    forall(member(P0, Poses), check_pose(Ctx, P0)),
    identity_pose(I),
    foldl(unit_chain_step(Ctx), Poses, I, [V, Q]),
    quat_normalize_(Ctx, Q, QN).

unit_chain_step(Ctx, [V, Q0], Acc, P) :-
    quat_normalize_(Ctx, Q0, Q),
    pose_compose_(Acc, [V, Q], P).

                 /*******************************
                 *   UNCHECKED IMPLEMENTATION   *
                 *******************************/

quat_normalize_(Ctx, Q, [X, Y, Z, W]) :-
    Q = [X0, Y0, Z0, W0],
    M is max(max(abs(X0), abs(Y0)), max(abs(Z0), abs(W0))),
    (   M =:= 0
    ->  throw(error(domain_error(non_zero_quaternion, Q),
                    context(rtl_math:Ctx, 'a zero quaternion has no direction')))
    ;   true
    ),
    A is X0 / M, B is Y0 / M, C is Z0 / M, D is W0 / M,
    N is sqrt(A*A + B*B + C*C + D*D),
    X is float(A / N), Y is float(B / N), Z is float(C / N), W is float(D / N).

quat_mul_([X1, Y1, Z1, W1], [X2, Y2, Z2, W2], [X, Y, Z, W]) :-
    X is float(W1*X2 + X1*W2 + Y1*Z2 - Z1*Y2),
    Y is float(W1*Y2 - X1*Z2 + Y1*W2 + Z1*X2),
    Z is float(W1*Z2 + X1*Y2 - Y1*X2 + Z1*W2),
    W is float(W1*W2 - X1*X2 - Y1*Y2 - Z1*Z2).

quat_conj_([X, Y, Z, W], [CX, CY, CZ, CW]) :-
    CX is float(-X), CY is float(-Y), CZ is float(-Z), CW is float(W).

%   v' = v + W*t + u x t  with  t = 2 (u x v),  u = [X, Y, Z]: the expansion of
%   q v q* for a unit quaternion.
quat_rot_([X, Y, Z, W], [VX, VY, VZ], [RX, RY, RZ]) :-
    TX is 2 * (Y*VZ - Z*VY),
    TY is 2 * (Z*VX - X*VZ),
    TZ is 2 * (X*VY - Y*VX),
    RX is float(VX + W*TX + (Y*TZ - Z*TY)),
    RY is float(VY + W*TY + (Z*TX - X*TZ)),
    RZ is float(VZ + W*TZ + (X*TY - Y*TX)).

%   Below this angle between the two unit quaternions (as 4-vectors) quat_slerp/4 uses
%   the normalised linear interpolation.
slerp_min_angle(1.0e-6).

quat_slerp_(Ctx, Q1, Q2, F, Q) :-
    quat_normalize_(Ctx, Q1, A),
    quat_normalize_(Ctx, Q2, B0),
    dot4(A, B0, D),
    (   D < 0
    ->  scale4(-1.0, B0, B)
    ;   B = B0
    ),
    diff4(A, B, Dif), sum4(A, B, Sum),
    norm4(Dif, ND), norm4(Sum, NS),
    Omega is 2 * atan2(ND, NS),
    slerp_min_angle(Min),
    (   Omega < Min
    ->  CA is 1 - F,
        CB = F
    ;   S is sin(Omega),
        CA is sin((1 - F) * Omega) / S,
        CB is sin(F * Omega) / S
    ),
    scale4(CA, A, SA), scale4(CB, B, SB), sum4(SA, SB, R),
    quat_normalize_(Ctx, R, Q).

dot4([A1, A2, A3, A4], [B1, B2, B3, B4], D) :-
    D is A1*B1 + A2*B2 + A3*B3 + A4*B4.

norm4(V, N) :-
    dot4(V, V, D),
    N is sqrt(D).

scale4(K, [A1, A2, A3, A4], [B1, B2, B3, B4]) :-
    B1 is K*A1, B2 is K*A2, B3 is K*A3, B4 is K*A4.

sum4([A1, A2, A3, A4], [B1, B2, B3, B4], [C1, C2, C3, C4]) :-
    C1 is A1+B1, C2 is A2+B2, C3 is A3+B3, C4 is A4+B4.

diff4([A1, A2, A3, A4], [B1, B2, B3, B4], [C1, C2, C3, C4]) :-
    C1 is A1-B1, C2 is A2-B2, C3 is A3-B3, C4 is A4-B4.

pose_compose_([V1, Q1], [V2, Q2], [V, Q]) :-
    quat_rot_(Q1, V2, RV2),
    V1 = [X1, Y1, Z1],
    RV2 = [X2, Y2, Z2],
    X is float(X1 + X2), Y is float(Y1 + Y2), Z is float(Z1 + Z2),
    V = [X, Y, Z],
    quat_mul_(Q1, Q2, Q).

pose_inverse_([V, Q], [VI, QC]) :-
    quat_conj_(Q, QC),
    quat_rot_(QC, V, [X, Y, Z]),
    NX is -X, NY is -Y, NZ is -Z,
    VI = [NX, NY, NZ].

                 /*******************************
                 *        ARGUMENT CHECKS       *
                 *******************************/

check_number(Ctx, X) :-
    (   var(X)
    ->  throw(error(instantiation_error, context(rtl_math:Ctx, _)))
    ;   number(X)
    ->  true
    ;   throw(error(type_error(number, X), context(rtl_math:Ctx, _)))
    ).

check_list(Ctx, L) :-
    (   is_list(L)
    ->  true
    ;   var(L)
    ->  throw(error(instantiation_error, context(rtl_math:Ctx, _)))
    ;   '$skip_list'(_, L, Tail), var(Tail)
    ->  throw(error(instantiation_error, context(rtl_math:Ctx, _)))
    ;   throw(error(type_error(list, L), context(rtl_math:Ctx, _)))
    ).

%   check_numbers(+Ctx, +What, +L): L is a proper list of numbers.
check_numbers(Ctx, What, L) :-
    check_list(Ctx, L),
    (   member(E, L), \+ number(E)
    ->  format(atom(Msg), 'element of the ~w ~q', [What, L]),
        (   var(E)
        ->  throw(error(instantiation_error, context(rtl_math:Ctx, Msg)))
        ;   throw(error(type_error(number, E), context(rtl_math:Ctx, Msg)))
        )
    ;   true
    ).

check_quat(Ctx, Q) :-
    check_numbers(Ctx, quaternion, Q),
    (   Q = [_, _, _, _]
    ->  true
    ;   throw(error(domain_error(quaternion, Q),
                    context(rtl_math:Ctx, 'a quaternion is [QX, QY, QZ, QW]')))
    ).

check_vec3(Ctx, V) :-
    check_numbers(Ctx, vector, V),
    (   V = [_, _, _]
    ->  true
    ;   throw(error(domain_error(vector3, V),
                    context(rtl_math:Ctx, 'a vector is [X, Y, Z]')))
    ).

check_pose(Ctx, P) :-
    check_list(Ctx, P),
    (   P = [V, Q]
    ->  check_vec3(Ctx, V),
        check_quat(Ctx, Q)
    ;   throw(error(domain_error(pose, P),
                    context(rtl_math:Ctx, 'a pose is [[X, Y, Z], [QX, QY, QZ, QW]]')))
    ).
