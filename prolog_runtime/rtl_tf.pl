:- module(rtl_tf,
          [ tf_lookup/4,                % +Target, +Source, +Time, -Pose
            tf_lookup/6,                % +Target, +Source, +Time, -Pose, -Stamp, -Result
            tf_can_transform/3,         % +Target, +Source, +Time
            tf_wait/5,                  % +Target, +Source, +Time, +Timeout, :Goal
            tf_add/6,                   % +Parent, +Child, +Stamp, +Translation, +Rotation, +Kind
            tf_set_buffer/1,            % +Seconds
            tf_buffer/1,                % -Seconds
            tf_frames/1,                % -Frames
            tf_parent/3,                % +Frame, +Time, -Parent
            tf_links/1,                 % -Count
            tf_records/1,               % -Count
            tf_waiting/1,               % -Count
            tf_clear/0,
            tf_road/1,                  % -Road
            tf_set_road/1,              % +Road
            tf_bytes/1                  % -Bytes
          ]).

/** <module> tf: where was frame X relative to frame Y at time T (docs/tf.md)

The transform tree of the robot, learned from the events of its tf messages, with the
semantics of ROS's tf2 (`tf2::BufferCore`, the version Debian ships: 0.7.6):

  - Every `tf2_msgs__0__TFMessage(Transforms)` or `tf__0__tfMessage(Transforms)` event (the
    `/tf` topic, ROS 1 and ROS 2 headers) adds its transforms as *dynamic* links; the same
    message wrapped as `tf_static(Msg)` (what the bag and live roads make of a message on
    `/tf_static`, and what `--wrap-topic` gives) adds them as *static* links. With
    `--wrap-topic`, `tf(Msg)` is a dynamic message.
  - A frame's links are the records of the transforms whose child it is, each with its own
    parent (a frame whose parent changes keeps both, as tf2). The first transform that names
    a frame as child decides whether the frame is static or dynamic, as in tf2.
  - A static frame keeps its latest transform, valid at any time, never interpolated.
  - A dynamic frame keeps its records for the buffer duration (tf_set_buffer/1, 10 s by
    default): a record older than the newest minus the duration is forgotten; a transform
    arriving older than that, or with a stamp the frame already has, is ignored (tf2's
    TF_OLD_DATA and TF_REPEATED_DATA). A transform naming its own frame as parent, an empty
    frame id, a non-finite value or a quaternion whose squared norm is off 1 by more than
    0.01 is ignored, as tf2 does.
  - Stamps are integer nanoseconds (tf2's `ros::Time`). A time argument is `latest` (or
    `0`, tf2's time 0: the latest time at which every link of the chain has data), a ROS
    stamp `[Secs, NSecs]`, `ns(Nanoseconds)` or a number of seconds.
  - Frame ids are atoms (or strings): the plain form `odom` and the release's quoted form
    `'"odom"'` are both just frame ids; one leading `/` is dropped (tf2 drops it on input;
    here it is dropped on lookups too), inside the quotes of the quoted form as well.

tf_lookup/6 walks from Source and from Target to their common ancestor as tf2's
`walkToTopParent` does, interpolating each dynamic link between the records around the time
(linear for the translation, slerp for the rotation, with tf2's formulas: the two records of
a link whose parent changed between them are not interpolated, the older one is used), and
fails with tf2's reasons. A pose is `[[X, Y, Z], [QX, QY, QZ, QW]]`: the pose of Source's
origin in Target (tf2's `lookupTransform(Target, Source, Time)`).

The store is per program (rtl_clear/0 empties it). It has two roads: the C store
(`foreign/rtl_tfstore`, c/rtl_tfstore.c, built by setup.sh), used when it is built, and the
Prolog store of this file, the reference, used without the C library or after
tf_set_road(prolog). Both hold the same tree and give the same answers: the tests compare
both roads with each other and with tf2's BufferCore (tests/test_tf.py). The tree is state
in snapshots as data (rtl_state:state_data/4: tf_state_dump/1, tf_state_check/1,
tf_state_load/1), the same on both roads.
*/

:- use_module(rtl_ele).
:- use_module(rtl_foreign).
:- use_module(library(pairs)).
:- use_module(library(assoc)).
:- use_module(library(aggregate)).
:- use_module(library(error)).
:- use_module(library(apply)).
:- use_module(library(lists)).

% c_road: the C store is loaded and used (a property of the process, not state)
:- dynamic c_road/0, c_loaded/0.

load_c_store :-
    (   rtl_load_foreign(rtl_tfstore, tf_c_lookup/7)
    ->  retractall(c_loaded), assertz(c_loaded),
        retractall(c_road), assertz(c_road)
    ;   true
    ).

:- load_c_store.

%!  tf_road(-Road) is det.
%!  tf_set_road(+Road) is det.
%
%   The store in use: `c` (the C store, when it is built) or `prolog` (the reference).
%   Setting the road empties the running program's tree first.

tf_road(Road) :-
    (   c_road -> Road = c ; Road = prolog ).

tf_set_road(Road) :-
    must_be(oneof([c, prolog]), Road),
    (   Road == c, \+ c_loaded
    ->  existence_error(foreign_library, rtl_tfstore)
    ;   true
    ),
    current_program(M),
    clear(M),
    retractall(c_road),
    (   Road == c -> assertz(c_road) ; true ).

:- meta_predicate tf_wait(+, +, +, +, 0).

% frame(Program, Frame, Handle, Kind): Kind `static`, `dynamic` or `none` (only a parent)
:- dynamic frame/4.
% handle_frame(Handle, Frame, Kind): the same, by handle
:- dynamic handle_frame/3.
% static_record(Handle, ParentHandle, Stamp, Translation, Rotation)
:- dynamic static_record/5.
% range(Handle, First, Last): the numbers of a dynamic frame's records, by stamp
:- dynamic range/3.
% record(Key, Stamp, ParentHandle, Translation, Rotation), Key = Handle << 32 + Number;
% Translation v(X, Y, Z), Rotation q(X, Y, Z, W)
:- dynamic record/5.
% buffer_ns(Program, Nanoseconds)
:- dynamic buffer_ns/2.
% waiting(Program, N, Target, Source, TimeNs, DeadlineSeconds, Goal)
:- dynamic waiting/7.

default_buffer_ns(10_000_000_000).
max_depth(1000).                                % tf2's MAX_GRAPH_DEPTH

% ---- learning the tree from events ---------------------------------------------------------

:- initialization(install_hooks).

install_hooks :-
    forall(tf_message_type(Pattern),
           rtl_add_type_output_hook(Pattern, rtl_tf:observe)).

tf_message_type(tf2_msgs__0__TFMessage(_)).
tf_message_type(tf__0__tfMessage(_)).
tf_message_type(tf_static(_)).
tf_message_type(tf(_)).

%   observe(+Event, +Start, +End, +Op): the output hook of the tf message types.
observe(Event, _, _, add) :-
    message_transforms(Event, Kind, Transforms),
    !,
    current_program(M),
    add_transforms(Transforms, M, Kind),
    wake(M).
observe(_, _, _, _).

message_transforms(tf2_msgs__0__TFMessage(Ts), dynamic, Ts).
message_transforms(tf__0__tfMessage(Ts), dynamic, Ts).
message_transforms(tf(Msg), dynamic, Ts) :- inner_transforms(Msg, Ts).
message_transforms(tf_static(Msg), static, Ts) :- inner_transforms(Msg, Ts).

inner_transforms(tf2_msgs__0__TFMessage(Ts), Ts).
inner_transforms(tf__0__tfMessage(Ts), Ts).

add_transforms(Ts, M, Kind) :-
    is_list(Ts),
    !,
    add_transform_list(Ts, M, Kind).
add_transforms(_, _, _).

add_transform_list([], _, _).
add_transform_list([T|Ts], M, Kind) :-
    (   transform_fields(T, Parent, Child, Stamp, V, Q)
    ->  add(M, Parent, Child, Stamp, V, Q, Kind)
    ;   true
    ),
    add_transform_list(Ts, M, Kind).

transform_fields(geometry_msgs__0__TransformStamped(Header, Child,
                     geometry_msgs__0__Transform(geometry_msgs__0__Vector3(X, Y, Z),
                                                 geometry_msgs__0__Quaternion(QX, QY, QZ, QW))),
                 Parent, Child, Stamp, v(X, Y, Z), q(QX, QY, QZ, QW)) :-
    header_fields(Header, [S, NS], Parent),
    integer(S), integer(NS),
    Stamp is S * 1_000_000_000 + NS.

header_fields(std_msgs__0__Header(_Seq, Stamp, Frame), Stamp, Frame).     % ROS 1
header_fields(std_msgs__0__Header(Stamp, Frame), Stamp, Frame).           % ROS 2

%!  tf_add(+Parent, +Child, +Stamp, +Translation, +Rotation, +Kind) is det.
%
%   Add one transform, as a tf message does: Translation `[X, Y, Z]`, Rotation
%   `[QX, QY, QZ, QW]`, Kind `dynamic` or `static`, Stamp a time (not `latest`).

tf_add(Parent, Child, Time, V, Q, Kind) :-
    current_program(M),
    (   c_road, tf_c_add(M, Parent, Child, Time, V, Q, Kind)
    ->  true
    ;   V = [X, Y, Z], Q = [QX, QY, QZ, QW],
        must_be(oneof([dynamic, static]), Kind),
        time_ns(Time, Stamp),
        must_be(integer, Stamp),
        add(M, Parent, Child, Stamp, v(X, Y, Z), q(QX, QY, QZ, QW), Kind)
    ),
    wake(M).

add(M, Parent0, Child0, Stamp, v(X, Y, Z), q(QX, QY, QZ, QW), Kind) :-
    c_road,
    !,
    (   tf_c_add(M, Parent0, Child0, ns(Stamp), [X, Y, Z], [QX, QY, QZ, QW], Kind)
    ->  true
    ;   frame_id(Parent0, _), frame_id(Child0, _)      % raises for a frame id that is not text
    ).                                                  % (a stamp past 64 bits: ignored)
add(M, Parent0, Child0, Stamp, V, Q, Kind) :-
    frame_id(Parent0, Parent),
    frame_id(Child0, Child),
    (   Parent \== '', Child \== '', Parent \== Child,
        finite_vector(V), finite_rotation(Q), normalized(Q)
    ->  frame_handle(M, Parent, PH, _),
        frame_handle(M, Child, CH, CKind),
        (   CKind == none
        ->  retract(frame(M, Child, CH, none)),
            assertz(frame(M, Child, CH, Kind)),
            retract(handle_frame(CH, Child, none)),
            assertz(handle_frame(CH, Child, Kind)),
            insert(Kind, M, CH, Stamp, PH, V, Q)
        ;   insert(CKind, M, CH, Stamp, PH, V, Q)
        )
    ;   true
    ).

finite_vector(v(X, Y, Z)) :- finite(X), finite(Y), finite(Z).
finite_rotation(q(X, Y, Z, W)) :- finite(X), finite(Y), finite(Z), finite(W).

finite(X) :- number(X), X =:= X, abs(X) =\= inf.

normalized(q(X, Y, Z, W)) :- abs(X*X + Y*Y + Z*Z + W*W - 1) =< 0.01.

%   frame_id(+Text, -Frame): the frame id of a name, one leading slash dropped.
frame_id(Text, Frame) :-
    (   atom(Text) -> Atom = Text
    ;   string(Text) -> atom_string(Atom, Text)
    ;   type_error(frame_id, Text)
    ),
    (   sub_atom(Atom, 0, 1, _, '/')
    ->  sub_atom(Atom, 1, _, 0, Frame)
    ;   sub_atom(Atom, 0, 2, _, '"/')
    ->  sub_atom(Atom, 2, _, 0, Rest),
        atom_concat('"', Rest, Frame)
    ;   Frame = Atom
    ).

frame_handle(M, Frame, H, Kind) :-
    (   frame(M, Frame, H, Kind)
    ->  true
    ;   flag(rtl_tf_handle, H0, H0 + 1),
        H is H0 + 1,
        Kind = none,
        assertz(frame(M, Frame, H, none)),
        assertz(handle_frame(H, Frame, none))
    ).

insert(static, _, H, Stamp, PH, V, Q) :-
    retractall(static_record(H, _, _, _, _)),
    assertz(static_record(H, PH, Stamp, V, Q)).
insert(dynamic, M, H, Stamp, PH, V, Q) :-
    buffer(M, Buffer),
    (   range(H, First, Last)
    ->  key(H, Last, LastKey),
        record(LastKey, Latest, _, _, _),
        (   Stamp > Latest
        ->  Next is Last + 1,
            key(H, Next, Key),
            assertz(record(Key, Stamp, PH, V, Q)),
            retract(range(H, First, Last)),
            forget(H, First, Next, Stamp, Buffer)
        ;   Latest > Stamp + Buffer                     % tf2's TF_OLD_DATA
        ->  true
        ;   place(H, First, Last, Stamp, Number),
            (   Number =< Last, key(H, Number, AtKey), record(AtKey, Stamp, _, _, _)
            ->  true                                    % tf2's TF_REPEATED_DATA
            ;   shift_up(H, Last, Number),
                key(H, Number, Key),
                assertz(record(Key, Stamp, PH, V, Q)),
                retract(range(H, First, Last)),
                Last1 is Last + 1,
                forget(H, First, Last1, Latest, Buffer)
            )
        )
    ;   key(H, 1, Key),
        assertz(record(Key, Stamp, PH, V, Q)),
        assertz(range(H, 1, 1))
    ).

key(H, Number, Key) :- Key is H << 32 + Number.

% place(+H, +First, +Last, +Stamp, -Number): the first record with a stamp >= Stamp
% (Last + 1 when there is none), by binary search
place(H, First, Last, Stamp, Number) :-
    After is Last + 1,
    place(H, First, Last, Stamp, After, Number).

place(H, First, Last, Stamp, Best, Number) :-
    (   First > Last
    ->  Number = Best
    ;   Mid is (First + Last) >> 1,
        key(H, Mid, Key),
        record(Key, S, _, _, _),
        (   S < Stamp
        ->  Mid1 is Mid + 1, place(H, Mid1, Last, Stamp, Best, Number)
        ;   Mid0 is Mid - 1, place(H, First, Mid0, Stamp, Mid, Number)
        )
    ).

% shift_up(+H, +From, +To): records To..From move up by one number (From downwards)
shift_up(H, From, To) :-
    (   From < To
    ->  true
    ;   key(H, From, Key),
        retract(record(Key, S, P, V, Q)),
        Key1 is Key + 1,
        assertz(record(Key1, S, P, V, Q)),
        From1 is From - 1,
        shift_up(H, From1, To)
    ).

% forget(+H, +First, +Last, +Latest, +Buffer): drop the records older than Latest - Buffer
% (tf2 keeps a record while its stamp + the buffer duration is not before the latest stamp)
forget(H, First, Last, Latest, Buffer) :-
    key(H, First, Key),
    (   First < Last,
        record(Key, S, _, _, _),
        S + Buffer < Latest
    ->  retract(record(Key, _, _, _, _)),
        First1 is First + 1,
        forget(H, First1, Last, Latest, Buffer)
    ;   assertz(range(H, First, Last))
    ).

nonneg_seconds(S) :-
    must_be(number, S),
    (   S >= 0, S =:= S -> true ; domain_error(nonneg_seconds, S) ).

buffer(M, Buffer) :-
    (   buffer_ns(M, B) -> Buffer = B ; default_buffer_ns(Buffer) ).

%!  tf_set_buffer(+Seconds) is det.
%!  tf_buffer(-Seconds) is det.
%
%   The buffer duration of dynamic links (tf2's cache time, 10 s by default). A shorter
%   duration applies from the next transform of each frame on.

tf_set_buffer(Seconds) :-
    nonneg_seconds(Seconds),
    current_program(M),
    Ns is round(Seconds * 1_000_000_000),
    retractall(buffer_ns(M, _)),
    assertz(buffer_ns(M, Ns)),
    (   c_loaded -> tf_c_set_buffer(M, Ns) ; true ).

tf_buffer(Seconds) :-
    current_program(M),
    buffer(M, Ns),
    Seconds is Ns / 1_000_000_000.

% ---- one link at a time (tf2's TimeCache and StaticCache) --------------------------------

%   link_data(+Kind, +H, +Time, -Parent, -V, -Q, -Error): the transform of frame H at Time
%   (0: the latest), Parent 0 and Error set when there is none.
link_data(static, H, _, PH, V, Q, none) :-
    static_record(H, PH, _, V, Q).
link_data(dynamic, H, Time, PH, V, Q, Error) :-
    range(H, First, Last),
    key(H, Last, LastKey),
    record(LastKey, Latest, LP, LV, LQ),
    (   Time =:= 0
    ->  PH = LP, V = LV, Q = LQ, Error = none
    ;   First =:= Last
    ->  (   Time =:= Latest
        ->  PH = LP, V = LV, Q = LQ, Error = none
        ;   PH = 0, direction(Time, Latest, Direction),
            Error = extrapolation(Direction, Time, Latest, Latest)
        )
    ;   Time =:= Latest
    ->  PH = LP, V = LV, Q = LQ, Error = none
    ;   key(H, First, FirstKey),
        record(FirstKey, Earliest, EP, EV, EQ),
        (   Time =:= Earliest
        ->  PH = EP, V = EV, Q = EQ, Error = none
        ;   Time > Latest
        ->  PH = 0, Error = extrapolation(future, Time, Earliest, Latest)
        ;   Time < Earliest
        ->  PH = 0, Error = extrapolation(past, Time, Earliest, Latest)
        ;   place(H, First, Last, Time, N2),         % first record at or after Time
            key(H, N2, K2),
            record(K2, S2, P2, V2, Q2),
            (   S2 =:= Time
            ->  PH = P2, V = V2, Q = Q2
            ;   K1 is K2 - 1,
                record(K1, S1, P1, V1, Q1),
                (   P1 =:= P2
                ->  Ratio is float(Time - S1) / float(S2 - S1),
                    lerp(V1, V2, Ratio, V),
                    slerp(Q1, Q2, Ratio, Q),
                    PH = P1
                ;   PH = P1, V = V1, Q = Q1
                )
            ),
            Error = none
        )
    ).

direction(Time, Stamp, Direction) :-
    (   Time < Stamp -> Direction = past ; Direction = future ).

latest_time_and_parent(static, H, 0, PH) :-
    static_record(H, PH, _, _, _).
latest_time_and_parent(dynamic, H, Latest, PH) :-
    range(H, _, Last),
    key(H, Last, Key),
    record(Key, Latest, PH, _, _).

lerp(v(X1, Y1, Z1), v(X2, Y2, Z2), R, v(X, Y, Z)) :-
    S is 1.0 - R,
    X is S * X1 + R * X2,
    Y is S * Y1 + R * Y2,
    Z is S * Z1 + R * Z2.

% tf2's Quaternion::slerp: along the shorter arc, the first quaternion when they are equal
slerp(q(X1, Y1, Z1, W1), q(X2, Y2, Z2, W2), T, Q) :-
    Dot is X1*X2 + Y1*Y2 + Z1*Z2 + W1*W2,
    Norms is sqrt((X1*X1 + Y1*Y1 + Z1*Z1 + W1*W1) * (X2*X2 + Y2*Y2 + Z2*Z2 + W2*W2)),
    Cos is min(1.0, max(-1.0, abs(Dot) / Norms)),
    Theta is acos(Cos),
    (   Theta =\= 0.0
    ->  D is 1.0 / sin(Theta),
        S0 is sin((1.0 - T) * Theta),
        S1a is sin(T * Theta),
        (   Dot < 0 -> S1 is -S1a ; S1 = S1a ),
        X is (X1 * S0 + X2 * S1) * D,
        Y is (Y1 * S0 + Y2 * S1) * D,
        Z is (Z1 * S0 + Z2 * S1) * D,
        W is (W1 * S0 + W2 * S1) * D,
        Q = q(X, Y, Z, W)
    ;   Q = q(X1, Y1, Z1, W1)
    ).

% ---- composing (tf2's quaternion and vector algebra) -------------------------------------

qmul(q(X1, Y1, Z1, W1), q(X2, Y2, Z2, W2), q(X, Y, Z, W)) :-
    X is W1*X2 + X1*W2 + Y1*Z2 - Z1*Y2,
    Y is W1*Y2 + Y1*W2 + Z1*X2 - X1*Z2,
    Z is W1*Z2 + Z1*W2 + X1*Y2 - Y1*X2,
    W is W1*W2 - X1*X2 - Y1*Y2 - Z1*Z2.

qinv(q(X, Y, Z, W), q(X1, Y1, Z1, W)) :-
    X1 is -X, Y1 is -Y, Z1 is -Z.

% rotate(+Q, +V, -R): quatRotate, Q * V * Q^-1
rotate(q(QX, QY, QZ, QW), v(VX, VY, VZ), v(X, Y, Z)) :-
    PX is QW*VX + QY*VZ - QZ*VY,
    PY is QW*VY + QZ*VX - QX*VZ,
    PZ is QW*VZ + QX*VY - QY*VX,
    PW is -QX*VX - QY*VY - QZ*VZ,
    qmul(q(PX, PY, PZ, PW), q(-QX, -QY, -QZ, QW), q(X, Y, Z, _)).

vadd(v(X1, Y1, Z1), v(X2, Y2, Z2), v(X, Y, Z)) :-
    X is X1 + X2, Y is Y1 + Y2, Z is Z1 + Z2.

vneg(v(X, Y, Z), v(X1, Y1, Z1)) :-
    X1 is -X, Y1 is -Y, Z1 is -Z.

% accumulate(+V, +Q, +Acc0, -Acc): one more link towards the top (TransformAccum::accum)
accumulate(V, Q, t(AV, AQ), t(NV, NQ)) :-
    rotate(Q, AV, RV),
    vadd(RV, V, NV),
    qmul(Q, AQ, NQ).

identity(t(v(0.0, 0.0, 0.0), q(0.0, 0.0, 0.0, 1.0))).

% ---- lookups -------------------------------------------------------------------------------

%!  tf_lookup(+Target, +Source, +Time, -Pose) is semidet.
%
%   Pose is the pose of frame Source in frame Target at Time (see the module header); fails
%   when tf_lookup/6 gives a reason.

tf_lookup(Target, Source, Time, Pose) :-
    tf_lookup(Target, Source, Time, Pose, _, ok).

%!  tf_lookup(+Target, +Source, +Time, -Pose, -Stamp, -Result) is det.
%
%   As tf2's `lookupTransform(Target, Source, Time)`: Result is `ok`, Pose the pose and
%   Stamp the time it is for (`[Secs, NSecs]`; with `latest`, the latest common time), or
%   Result is the reason there is none (Pose and Stamp unbound):
%
%     - `unknown_frame(Frame)`: no transform names Frame (Target is checked first);
%     - `not_connected(Target, Source)`: they are in different trees;
%     - `extrapolation(Direction, Time, Earliest, Latest)`: a link of the chain has no
%       data at Time, which lies before (`past`) or after (`future`) the interval
%       `[Earliest, Latest]` (integer nanoseconds) that link holds;
%     - `loop`: the tree has a cycle (tf2: "the tf tree is invalid").

tf_lookup(Target0, Source0, Time0, Pose, Stamp, Result) :-
    c_road,
    !,
    current_program(M),
    (   tf_c_lookup(M, Target0, Source0, Time0, Pose1, Stamp1, Result1)
    ->  true
    ;   frame_id(Target0, Target),                  % raises for what is not a frame or a time
        frame_id(Source0, Source),
        time_ns(Time0, Time1),
        tf_c_lookup(M, Target, Source, ns(Time1), Pose1, Stamp1, Result1)
    ),
    Pose = Pose1, Stamp = Stamp1, Result = Result1.
tf_lookup(Target0, Source0, Time0, Pose, Stamp, Result) :-
    frame_id(Target0, Target),
    frame_id(Source0, Source),
    time_ns(Time0, Time1),
    current_program(M),
    lookup(M, Target, Source, Time1, Acc, Time, Result0),
    (   Result0 == ok
    ->  Acc = t(v(X, Y, Z), q(QX, QY, QZ, QW)),
        Pose = [[X, Y, Z], [QX, QY, QZ, QW]],
        stamp(Time, Stamp),
        Result = ok
    ;   Result = Result0
    ).

stamp(Ns, [S, NS]) :-
    S is Ns // 1_000_000_000,
    NS is Ns mod 1_000_000_000.

%!  tf_can_transform(+Target, +Source, +Time) is semidet.
%
%   True when tf_lookup/6 would give `ok` (tf2's canTransform: false for unknown frames, but
%   true for a frame and itself, known or not, as tf2 short-circuits it).

tf_can_transform(Target0, Source0, Time0) :-
    c_road,
    !,
    current_program(M),
    (   tf_c_lookup(M, Target0, Source0, Time0, _, _, Result)
    ->  true
    ;   frame_id(Target0, Target),
        frame_id(Source0, Source),
        time_ns(Time0, Time),
        tf_c_lookup(M, Target, Source, ns(Time), _, _, Result)
    ),
    Result == ok.
tf_can_transform(Target0, Source0, Time0) :-
    frame_id(Target0, Target),
    frame_id(Source0, Source),
    time_ns(Time0, Time),
    (   Target == Source                    % tf2 answers so before it looks at the frames
    ->  true
    ;   current_program(M),
        frame(M, Target, _, _),
        frame(M, Source, _, _),
        lookup(M, Target, Source, Time, _, _, ok)
    ).

lookup(M, Target, Source, Time0, Acc, Time, ok) :-
    Target == Source,
    !,
    identity(Acc),
    (   Time0 =:= 0, frame(M, Target, H, Kind), Kind \== none
    ->  latest_time_and_parent(Kind, H, Time, _)
    ;   Time = Time0
    ).
lookup(M, Target, _, _, _, _, unknown_frame(Target)) :-
    \+ frame(M, Target, _, _),
    !.
lookup(M, _, Source, _, _, _, unknown_frame(Source)) :-
    \+ frame(M, Source, _, _),
    !.
lookup(M, Target, Source, Time0, Acc, Time, Result) :-
    frame(M, Target, TH, _),
    frame(M, Source, SH, _),
    (   Time0 =:= 0
    ->  latest_common_time(M, TH, SH, Time, Result0)
    ;   Time = Time0, Result0 = ok
    ),
    (   Result0 == ok
    ->  walk(M, TH, SH, Time, Acc, Result)
    ;   Result = Result0
    ).

kind_of(H, Kind) :-
    handle_frame(H, _, Kind).

% walk(+M, +TH, +SH, +Time, -Acc, -Result): tf2's walkToTopParent with TransformAccum
walk(_, TH, SH, Time, Acc, Result) :-
    identity(Id),
    source_walk(SH, TH, Time, Id, 0, Outcome),
    (   Outcome = done(Acc)
    ->  Result = ok
    ;   Outcome = loop
    ->  Result = loop
    ;   Outcome = top(Top, SAcc, SourceError),
        target_walk(TH, SH, Top, Time, Id, 0, TOutcome),
        (   TOutcome = done(Acc)
        ->  Result = ok
        ;   TOutcome = reached(TAcc)
        ->  full_path(TAcc, SAcc, Acc), Result = ok
        ;   TOutcome = error(Error)
        ->  Result = Error
        ;   TOutcome == loop
        ->  Result = loop
        ;   SourceError \== none
        ->  Result = SourceError
        ;   handles_frames(TH, SH, Target, Source),
            Result = not_connected(Target, Source)
        )
    ).

handles_frames(TH, SH, Target, Source) :-
    handle_frame(TH, Target, _),
    handle_frame(SH, Source, _).

source_walk(Frame, TH, Time, Acc, Depth, Outcome) :-
    kind_of(Frame, Kind),
    (   Kind == none
    ->  Outcome = top(Frame, Acc, none)
    ;   link_data(Kind, Frame, Time, PH, V, Q, Error),
        (   PH =:= 0
        ->  Outcome = top(Frame, Acc, Error)
        ;   Frame =:= TH
        ->  Outcome = done(Acc)
        ;   max_depth(Max), Depth > Max
        ->  Outcome = loop
        ;   accumulate(V, Q, Acc, Acc1),
            Depth1 is Depth + 1,
            source_walk(PH, TH, Time, Acc1, Depth1, Outcome)
        )
    ).

target_walk(Frame, SH, Top, Time, Acc, Depth, Outcome) :-
    (   Frame =:= Top
    ->  Outcome = reached(Acc)
    ;   kind_of(Frame, Kind),
        (   Kind == none
        ->  Outcome = stopped
        ;   link_data(Kind, Frame, Time, PH, V, Q, Error),
            (   PH =:= 0
            ->  Outcome = error(Error)
            ;   Frame =:= SH
            ->  source_parent_of_target(Acc, Acc1),
                Outcome = done(Acc1)
            ;   max_depth(Max), Depth > Max
            ->  Outcome = loop
            ;   accumulate(V, Q, Acc, Acc1),
                Depth1 is Depth + 1,
                target_walk(PH, SH, Top, Time, Acc1, Depth1, Outcome)
            )
        )
    ).

source_parent_of_target(t(TV, TQ), t(V, Q)) :-
    qinv(TQ, Q),
    vneg(TV, NTV),
    rotate(Q, NTV, V).

full_path(t(TV, TQ), t(SV, SQ), t(V, Q)) :-
    qinv(TQ, ITQ),
    vneg(TV, NTV),
    rotate(ITQ, NTV, ITV),
    rotate(ITQ, SV, RSV),
    vadd(RSV, ITV, V),
    qmul(ITQ, SQ, Q).

% latest_common_time(+M, +TH, +SH, -Time, -Result): tf2's getLatestCommonTime
latest_common_time(_, TH, SH, 0, ok) :-
    TH =:= SH, !.
latest_common_time(_, TH, SH, Time, Result) :-
    Max = inf,
    source_times(SH, TH, Max, [], 0, Outcome),
    (   Outcome = direct(Common)
    ->  finite_time(Common, Time), Result = ok
    ;   Outcome == loop
    ->  Result = loop
    ;   Outcome = chain(Chain),
        target_times(TH, SH, Chain, Max, 0, TOutcome),
        (   TOutcome = direct(Common)
        ->  finite_time(Common, Time), Result = ok
        ;   TOutcome = common(CommonParent, Common0)
        ->  chain_times(Chain, CommonParent, Common0, Common),
            finite_time(Common, Time), Result = ok
        ;   TOutcome == loop
        ->  Result = loop
        ;   handles_frames(TH, SH, Target, Source),
            Result = not_connected(Target, Source)
        )
    ).

finite_time(inf, 0) :- !.
finite_time(T, T).

min_time(0, T, T) :- !.
min_time(L, T0, T) :- T0 == inf, !, T = L.
min_time(L, T0, T) :- T is min(L, T0).

% the source's walk: Chain is the list of Latest-Parent pairs, in walk order
source_times(Frame, TH, Common, Chain0, Depth, Outcome) :-
    kind_of(Frame, Kind),
    (   Kind == none
    ->  reverse(Chain0, Chain), Outcome = chain(Chain)
    ;   latest_time_and_parent(Kind, Frame, Latest, PH),
        min_time(Latest, Common, Common1),
        (   PH =:= TH
        ->  Outcome = direct(Common1)
        ;   max_depth(Max), Depth > Max
        ->  Outcome = loop
        ;   Depth1 is Depth + 1,
            source_times(PH, TH, Common1, [Latest-PH|Chain0], Depth1, Outcome)
        )
    ).

target_times(Frame, SH, Chain, Common, Depth, Outcome) :-
    kind_of(Frame, Kind),
    (   Kind == none
    ->  Outcome = none
    ;   latest_time_and_parent(Kind, Frame, Latest, PH),
        min_time(Latest, Common, Common1),
        (   memberchk(_-PH, Chain)
        ->  Outcome = common(PH, Common1)
        ;   PH =:= SH
        ->  Outcome = direct(Common1)
        ;   max_depth(Max), Depth > Max
        ->  Outcome = loop
        ;   Depth1 is Depth + 1,
            target_times(PH, SH, Chain, Common1, Depth1, Outcome)
        )
    ).

chain_times([], _, Common, Common).
chain_times([Latest-PH|Chain], Parent, Common0, Common) :-
    min_time(Latest, Common0, Common1),
    (   PH =:= Parent
    ->  Common = Common1
    ;   chain_times(Chain, Parent, Common1, Common)
    ).

% ---- times ---------------------------------------------------------------------------------

%   time_ns(+Time, -Nanoseconds): 0 for the latest
time_ns(Time, _) :-
    var(Time), !,
    instantiation_error(Time).
time_ns(latest, 0) :- !.
time_ns(ns(N), N) :- !, must_be(integer, N).
time_ns([S, NS], N) :- !,
    must_be(integer, S), must_be(integer, NS),
    N is S * 1_000_000_000 + NS.
time_ns(T, N) :-
    number(T), !,
    N is round(T * 1_000_000_000).
time_ns(T, _) :-
    type_error(tf_time, T).

% ---- waiting for a transform (tf2's waitForTransform, on event time) ---------------------

%!  tf_wait(+Target, +Source, +Time, +Timeout, :Goal) is det.
%
%   Run Goal once as soon as tf_can_transform(Target, Source, Time) holds: now, or when
%   a tf message makes it hold, with the event being processed then. When the clock
%   (event time) passes Time plus Timeout seconds first, Goal is dropped (tf2's
%   waitForTransform returning false): checked as each event moves the clock (an output
%   hook while goals wait), not only when tf messages arrive. Time cannot be `latest`.

tf_wait(Target, Source, Time0, Timeout, Goal) :-
    time_ns(Time0, Time),
    (   Time =:= 0 -> domain_error(tf_stamp, Time0) ; true ),
    nonneg_seconds(Timeout),
    (   tf_can_transform(Target, Source, ns(Time))
    ->  once(Goal)
    ;   current_program(M),
        flag(rtl_tf_wait, N0, N0 + 1),
        Deadline is Time / 1_000_000_000 + Timeout,
        assertz(waiting(M, N0, Target, Source, Time, Deadline, Goal)),
        rtl_add_output_hook(rtl_tf:clock_moved)
    ).

%   The output hook while goals wait: a goal whose deadline the clock has passed is
%   dropped (for a tf message, observe/4 looks first whether it makes the lookup possible).
clock_moved(Event, _, _, add) :-
    \+ tf_message_type(Event),
    !,
    rtl_clock(Clock),
    current_program(M),
    (   number(Clock)
    ->  forall(( waiting(M, N, _, _, _, Deadline, _), Clock > Deadline ),
               retract(waiting(M, N, _, _, _, _, _)))
    ;   true
    ),
    waiting_hook.
clock_moved(_, _, _, _).

% The hook stays while a goal waits.
waiting_hook :-
    (   waiting(_, _, _, _, _, _, _) -> true ; rtl_remove_output_hook(rtl_tf:clock_moved) ).

%!  tf_waiting(-Count) is det.
%
%   The number of tf_wait/5 goals still waiting.

tf_waiting(Count) :-
    current_program(M),
    aggregate_all(count, waiting(M, _, _, _, _, _, _), Count).

wake(M) :-
    (   waiting(M, _, _, _, _, _, _)
    ->  rtl_clock(Clock),
        forall(waiting(M, N, Target, Source, Time, Deadline, Goal),
               wake_one(M, N, Target, Source, Time, Deadline, Goal, Clock)),
        waiting_hook
    ;   true
    ).

wake_one(M, N, Target, Source, Time, Deadline, Goal, Clock) :-
    (   tf_can_transform(Target, Source, ns(Time))
    ->  retract(waiting(M, N, _, _, _, _, _)),
        once(Goal)
    ;   number(Clock), Clock > Deadline
    ->  retract(waiting(M, N, _, _, _, _, _))
    ;   true
    ).

% ---- what is known -------------------------------------------------------------------------

%!  tf_frames(-Frames) is det.
%
%   The frame ids the tree knows, in the order they were first named.

tf_frames(Frames) :-
    current_program(M),
    (   c_road
    ->  tf_c_frames(M, Frames)
    ;   findall(H-F, frame(M, F, H, _), Pairs0),
        keysort(Pairs0, Pairs),
        pairs_values(Pairs, Frames)
    ).

%!  tf_parent(+Frame, +Time, -Parent) is semidet.
%
%   The parent of Frame at Time (tf2's `_getParent`).

tf_parent(Frame0, Time0, Parent) :-
    c_road,
    !,
    frame_id(Frame0, Frame),
    time_ns(Time0, Time),
    current_program(M),
    tf_c_parent(M, Frame, ns(Time), Parent).
tf_parent(Frame0, Time0, Parent) :-
    frame_id(Frame0, Frame),
    time_ns(Time0, Time),
    current_program(M),
    frame(M, Frame, H, Kind),
    Kind \== none,
    link_data(Kind, H, Time, PH, _, _, _),
    PH =\= 0,
    handle_frame(PH, Parent, _).

%!  tf_links(-Count) is det.
%!  tf_records(-Count) is det.
%
%   The number of frames that have a parent (links), and of transforms kept.

tf_links(Count) :-
    c_road,
    !,
    current_program(M),
    tf_c_counts(M, Count, _, _).
tf_links(Count) :-
    current_program(M),
    aggregate_all(count, ( frame(M, _, _, Kind), Kind \== none ), Count).

tf_records(Count) :-
    c_road,
    !,
    current_program(M),
    tf_c_counts(M, _, Count, _).
tf_records(Count) :-
    current_program(M),
    aggregate_all(sum(N),
                  ( frame(M, _, H, Kind),
                    (   Kind == static -> N = 1
                    ;   range(H, F, L) -> N is L - F + 1
                    ) ),
                  Count).

%!  tf_clear is det.
%
%   Forget the running program's tree (and its waiting goals).

tf_clear :-
    current_program(M),
    clear(M).

clear(M) :-
    (   c_loaded -> tf_c_clear(M) ; true ),
    forall(retract(frame(M, _, H, _)),
           ( retractall(handle_frame(H, _, _)),
             retractall(static_record(H, _, _, _, _)),
             (   retract(range(H, First, Last))
             ->  forall(between(First, Last, N), ( key(H, N, K), retractall(record(K, _, _, _, _)) ))
             ;   true
             ) )),
    retractall(waiting(M, _, _, _, _, _, _)),
    waiting_hook.

:- multifile rtl_ele:clear_hook/0.
rtl_ele:clear_hook :-
    current_program(M),
    clear(M).

%!  tf_bytes(-Bytes) is det.
%
%   The memory the running program's tree takes: on the C road the bytes its store
%   allocated, on the Prolog road the size of its clauses.

tf_bytes(Bytes) :-
    current_program(M),
    (   c_road
    ->  tf_c_counts(M, _, _, Bytes)
    ;   aggregate_all(sum(B),
                      ( member(P, [record/5, static_record/5, frame/4, handle_frame/3, range/3]),
                        P = Name/Arity, functor(H, Name, Arity),
                        predicate_property(rtl_tf:H, size(B)) ),
                      Bytes)
    ).

% ---- the tree in snapshots (rtl_state:state_data/4) ----------------------------------------
%
%   The same data on both roads: frame(Frame, Kind) per frame in the order they were first
%   named (Kind static, dynamic or none), then r(I, Stamp, P, X, Y, Z, QX, QY, QZ, QW) per
%   record of the I-th frame, in stamp order, P the number of its parent.

%!  tf_state_dump(-Terms) is det.
%!  tf_state_check(+Terms) is semidet.
%!  tf_state_load(+Terms) is det.

tf_state_dump(Terms) :-
    current_program(M),
    (   c_road
    ->  tf_c_dump(M, Terms)
    ;   findall(H-(F-K), frame(M, F, H, K), Pairs0),
        keysort(Pairs0, Pairs),
        findall(H-I, nth1(I, Pairs, H-_), Numbers),
        list_to_assoc(Numbers, ByHandle),
        findall(frame(F, K), member(_-(F-K), Pairs), Frames),
        findall(R, ( member(H-(_-K), Pairs), prolog_record(K, H, ByHandle, R) ), Records),
        append(Frames, Records, Terms)
    ).

prolog_record(static, H, ByHandle, r(I, S, P, X, Y, Z, QX, QY, QZ, QW)) :-
    static_record(H, PH, S, v(X, Y, Z), q(QX, QY, QZ, QW)),
    get_assoc(H, ByHandle, I),
    get_assoc(PH, ByHandle, P).
prolog_record(dynamic, H, ByHandle, r(I, S, P, X, Y, Z, QX, QY, QZ, QW)) :-
    range(H, First, Last),
    between(First, Last, N),
    key(H, N, Key),
    record(Key, S, PH, v(X, Y, Z), q(QX, QY, QZ, QW)),
    get_assoc(H, ByHandle, I),
    get_assoc(PH, ByHandle, P).

tf_state_check(Terms) :-
    is_list(Terms),
    partition(is_frame_term, Terms, Frames, Records),
    append(Frames, Records, Terms),             % the frames first
    length(Frames, N),
    forall(member(frame(F, K), Frames), ( atom(F), memberchk(K, [static, dynamic, none]) )),
    findall(F, member(frame(F, _), Frames), Names),
    sort(Names, Unique), length(Unique, N),
    check_records(Records, Frames, N, 0, none),
    forall(nth1(I, Frames, frame(_, K)),
           (   K == none -> true ; memberchk(r(I, _, _, _, _, _, _, _, _, _), Records) )).

is_frame_term(frame(_, _)).

% records by frame (ascending numbers), each frame's in increasing stamp order, one for a static frame
check_records([], _, _, _, _).
check_records([r(I, S, P, X, Y, Z, QX, QY, QZ, QW)|Rs], Frames, N, I0, S0) :-
    integer(I), integer(S), integer(P),
    between(1, N, I), between(1, N, P),
    I >= I0,
    nth1(I, Frames, frame(_, K)),
    K \== none,
    maplist(number, [X, Y, Z, QX, QY, QZ, QW]),
    (   I =:= I0 -> K == (dynamic), S0 \== none, S > S0 ; true ),
    check_records(Rs, Frames, N, I, S).

tf_state_load(Terms) :-
    current_program(M),
    clear(M),
    (   c_road
    ->  tf_c_load(M, Terms),
        buffer(M, Buffer),
        tf_c_set_buffer(M, Buffer)
    ;   load_prolog(M, Terms)
    ).

load_prolog(M, Terms) :-
    findall(F-K, member(frame(F, K), Terms), Frames),
    foldl(load_frame(M), Frames, Handles, 1, _),
    forall(member(r(I, S, P, X, Y, Z, QX, QY, QZ, QW), Terms),
           (   nth1(I, Handles, H-K), nth1(P, Handles, PH-_),
               load_record(K, H, S, PH, v(X, Y, Z), q(QX, QY, QZ, QW))
           )).

load_frame(M, F-K, H-K, I, I1) :-
    I1 is I + 1,
    flag(rtl_tf_handle, H0, H0 + 1),
    H is H0 + 1,
    assertz(frame(M, F, H, K)),
    assertz(handle_frame(H, F, K)).

load_record(static, H, S, PH, V, Q) :-
    assertz(static_record(H, PH, S, V, Q)).
load_record(dynamic, H, S, PH, V, Q) :-
    (   retract(range(H, First, Last)) -> Next is Last + 1 ; First = 1, Next = 1 ),
    key(H, Next, Key),
    assertz(record(Key, S, PH, V, Q)),
    assertz(range(H, First, Next)).

current_program(M) :-
    (   rtl_program(M0) -> M = M0 ; M = user ).
