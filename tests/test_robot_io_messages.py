"""ROS message <-> event term conversion (retalisc/robot_io/messages.py; term text: retalisc/driver/values.py):
the Retalis release's convention, generated converters against the generic reference,
SWI-Prolog reading what we write, and round trips message -> term -> message on every
message type of the sample recordings."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robot_io_support import SHARED_NAMES, same_value, shared_bag

import numpy as np  # noqa: E402  (rosbags brings numpy)

from retalisc.driver.bridge import Bridge  # noqa: E402


def prolog_string(text: str) -> str:
    """`text` as a Prolog string literal (test goals only; the product passes text as data)."""
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r")
    return '"' + escaped + '"'

from retalisc.robot_io.bags import Recording, typestore  # noqa: E402
from retalisc.driver.values import String, Term, is_atom, read_term, write_term  # noqa: E402
from retalisc.robot_io.messages import (  # noqa: E402
    ConversionError, Convention, MessageConverter, topic_functor, type_functor)
from retalisc.robot_io.samples import nao_records, sample_store  # noqa: E402

ROS1 = typestore("ros1_noetic")
ROS2 = typestore("ros2_humble")


def t(store, name):
    return store.types[name]


def pose_stamped(store, seq=7, frame="/odom"):
    header = dict(stamp=t(store, "builtin_interfaces/msg/Time")(sec=1413748205, nanosec=981209993), frame_id=frame)
    if store is ROS1:
        header["seq"] = seq
    return t(store, "geometry_msgs/msg/PoseStamped")(
        header=t(store, "std_msgs/msg/Header")(**header),
        pose=t(store, "geometry_msgs/msg/Pose")(
            position=t(store, "geometry_msgs/msg/Point")(x=0.0, y=-0.01, z=0.1),
            orientation=t(store, "geometry_msgs/msg/Quaternion")(x=0.05, y=0.008, z=-0.02, w=0.9)))


# ---- the convention -------------------------------------------------------------------------

def test_type_and_topic_functors():
    assert type_functor("geometry_msgs/msg/PoseStamped") == "geometry_msgs__0__PoseStamped"
    assert type_functor("tf2_msgs/msg/TFMessage") == "tf2_msgs__0__TFMessage"
    assert type_functor("tf/tfMessage") == "tf__0__tfMessage"
    assert type_functor("tf/msg/tfMessage") == "tf__0__tfMessage"
    assert topic_functor("/tf") == "tf"
    assert topic_functor("/arm/joint_states") == "arm__0__joint_states"


def test_listing_2_3_pose_stamped_ros1_and_ros2():
    expected_pose = ("geometry_msgs__0__Pose(geometry_msgs__0__Point(0.0,-0.01,0.1),"
                     "geometry_msgs__0__Quaternion(0.05,0.008,-0.02,0.9)))")
    ros1 = MessageConverter(ROS1, Convention(plain_strings=False))      # the release's quoted strings
    text, time = ros1.event(pose_stamped(ROS1), "geometry_msgs/msg/PoseStamped", "/pose", 5_000_000_000)
    assert text == ("geometry_msgs__0__PoseStamped(std_msgs__0__Header(7,[1413748205,981209993],"
                    "'\"/odom\"')," + expected_pose)
    plain, _ = MessageConverter(ROS1).event(pose_stamped(ROS1), "geometry_msgs/msg/PoseStamped", "/pose", 0)
    assert plain == text.replace("'\"/odom\"'", "'/odom'")       # plain strings by default
    assert time == 1413748205.981209993          # header.stamp, not the record time
    ros2 = MessageConverter(ROS2)
    assert ros2.term(pose_stamped(ROS2), "geometry_msgs/msg/PoseStamped") == (
        "geometry_msgs__0__PoseStamped(std_msgs__0__Header([1413748205,981209993],'/odom'),"
        + expected_pose)


def test_options_plain_strings_and_wrap_topic():
    converter = MessageConverter(ROS1, Convention(plain_strings=True, wrap_topic=True))
    text, _ = converter.event(pose_stamped(ROS1), "geometry_msgs/msg/PoseStamped", "/robot/pose", 0)
    assert text.startswith("robot__0__pose(geometry_msgs__0__PoseStamped(std_msgs__0__Header(7,[1413748205,981209993],'/odom'),")
    msgtype, back = converter.message(text)
    assert msgtype == "geometry_msgs/msg/PoseStamped" and same_value(back, pose_stamped(ROS1))


def test_messages_without_header_take_the_record_time_and_tf_types_exist_for_ros1():
    tf = t(ROS1, "tf2_msgs/msg/TFMessage")(transforms=[])
    converter = MessageConverter(ROS1)
    assert converter.event(tf, "tf2_msgs/msg/TFMessage", "/tf", 1_500_000_000) == ("tf2_msgs__0__TFMessage([])", 1.5)
    assert converter.term(t(ROS1, "tf/msg/tfMessage")(transforms=[]), "tf/msg/tfMessage") == "tf__0__tfMessage([])"
    # a zero stamp (not set) also falls back to the record time
    unset = pose_stamped(ROS1)
    unset.header.stamp = t(ROS1, "builtin_interfaces/msg/Time")(sec=0, nanosec=0)
    assert converter.event(unset, "geometry_msgs/msg/PoseStamped", "/p", 2_000_000_000)[1] == 2.0


def test_base_types_special_values_and_empty_messages():
    converter = MessageConverter(ROS2)
    empty = t(ROS2, "std_msgs/msg/Empty")(structure_needs_at_least_one_member=0)
    assert converter.term(empty, "std_msgs/msg/Empty") == "std_msgs__0__Empty"
    assert converter.message("std_msgs__0__Empty")[0] == "std_msgs/msg/Empty"
    values = t(ROS2, "std_msgs/msg/Float64MultiArray")(
        layout=t(ROS2, "std_msgs/msg/MultiArrayLayout")(dim=[], data_offset=0),
        data=np.array([math.inf, -math.inf, math.nan, 1e-05, -0.0]))
    text = converter.term(values, "std_msgs/msg/Float64MultiArray")
    assert text == "std_msgs__0__Float64MultiArray(std_msgs__0__MultiArrayLayout([],0),[1.0Inf,-1.0Inf,1.5NaN,1e-05,-0.0])"
    assert MessageConverter(ROS2, generated=False).term(values, "std_msgs/msg/Float64MultiArray") == text
    point = t(ROS2, "geometry_msgs/msg/Point")(x=math.nan, y=math.inf, z=1.0)
    assert converter.term(point, "geometry_msgs/msg/Point") == "geometry_msgs__0__Point(1.5NaN,1.0Inf,1.0)"
    flag = t(ROS2, "std_msgs/msg/Bool")(data=True)
    assert converter.term(flag, "std_msgs/msg/Bool") == "std_msgs__0__Bool(true)"
    raw = t(ROS2, "std_msgs/msg/UInt8MultiArray")(
        layout=t(ROS2, "std_msgs/msg/MultiArrayLayout")(dim=[], data_offset=0), data=np.array([0, 255], dtype=np.uint8))
    assert converter.term(raw, "std_msgs/msg/UInt8MultiArray").endswith(",[0,255])")


TRICKY = ["", "it's", "back\\slash", "line\nbreak", "tab\there", "quote\"inside", "ünïcødé ✓", "nul\x00byte",
          "\x7f\x1b", "'\"", "end\\"]


def _prolog_leaves(text: str):
    """The atoms (as code lists) and numbers of the term SWI-Prolog reads from `text`, in
    sub_term/2 order."""
    bridge = Bridge()
    goal = (f"term_string(T, {prolog_string(text)}), "
            "findall(L, (sub_term(X, T), (atom(X) -> atom_codes(X, Cs), L = a(Cs) ; number(X) -> L = n(X))), Ls), "
            "format(string(Out), '~q', [Ls])")
    leaves = []
    for item in read_term(bridge.call_text(goal)):
        if item.name == "a":
            leaves.append("".join(map(chr, item.args[0])))
        else:
            leaves.append(item.args[0])
    return leaves


def _python_leaves(value, out):
    if isinstance(value, Term):
        for arg in value.args:
            _python_leaves(arg, out)
    elif isinstance(value, list):
        for item in value:
            _python_leaves(item, out)
    elif is_atom(value):
        out.append(value)
    elif isinstance(value, (int, float)):
        out.append(value)
    return out


@pytest.mark.parametrize("plain", [False, True])
def test_swi_prolog_reads_strings_and_floats_as_written(plain):
    joint = t(ROS2, "sensor_msgs/msg/JointState")(
        header=t(ROS2, "std_msgs/msg/Header")(stamp=t(ROS2, "builtin_interfaces/msg/Time")(sec=1, nanosec=2), frame_id="a'b"),
        name=TRICKY, position=np.array([1e-05, -2.5e300, math.inf, 5e-324]), velocity=np.array([]), effort=np.array([]))
    text = MessageConverter(ROS2, Convention(plain_strings=plain)).term(joint, "sensor_msgs/msg/JointState")
    wrap = (lambda s: s) if plain else (lambda s: f'"{s}"')
    prolog = _prolog_leaves(text)
    assert [x for x in prolog if isinstance(x, str)] == [wrap("a'b")] + [wrap(s) for s in TRICKY]
    assert [x for x in prolog if not isinstance(x, str)] == [1, 2, 1e-05, -2.5e300, math.inf, 5e-324]
    assert _python_leaves(read_term(text), []) == prolog


# ---- terms back to messages ------------------------------------------------------------------

def test_back_from_terms_with_either_header():
    ros2 = MessageConverter(ROS2)
    ros1_text = MessageConverter(ROS1).term(pose_stamped(ROS1), "geometry_msgs/msg/PoseStamped")
    msgtype, msg = ros2.message(ros1_text)          # a ROS 1 header (with seq) for ROS 2
    assert msgtype == "geometry_msgs/msg/PoseStamped" and same_value(msg, pose_stamped(ROS2))
    ros2_text = ros2.term(pose_stamped(ROS2), "geometry_msgs/msg/PoseStamped")
    _, msg1 = MessageConverter(ROS1).message(ros2_text)   # and the other way: seq 0
    assert msg1.header.seq == 0 and msg1.header.frame_id == "/odom"
    # a time may be seconds; a string may be a Prolog string or an atom without the quotes
    _, msg = ros2.message('geometry_msgs__0__PoseStamped(std_msgs__0__Header(12.25,"map"),'
                          'geometry_msgs__0__Pose(geometry_msgs__0__Point(1,2,3),geometry_msgs__0__Quaternion(0,0,0,1)))')
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (12, 250_000_000, "map")
    assert msg.pose.position.x == 1.0 and isinstance(msg.pose.position.x, float)


@pytest.mark.parametrize("text, message", [
    ("geometry_msgs__0__Point(1,2)", "geometry_msgs__0__Point has 3 fields (x, y, z), the term 2"),
    ("geometry_msgs__0__Point(a,2,3)", "geometry_msgs__0__Point.x: expected a number, not a"),
    ("std_msgs__0__UInt8(300)", "std_msgs__0__UInt8.data: 300 is out of the range of uint8"),
    ("std_msgs__0__Header([1,2000000000],'\"x\"')", "nanoseconds 2000000000 outside [0, 1e9)"),
    ("unknown__0__Type(1)", "unknown__0__Type(1) is not a message of a known type"),
    ("geometry_msgs__0__PoseStamped(X, Y)", "not ground: variable X"),
    ("sensor_msgs__0__JointState(std_msgs__0__Header([1,2],'\"\"'),[a|b],[],[],[])",
     "sensor_msgs__0__JointState.name: expected a list, not '[|]'(a,b)"),
])
def test_terms_that_are_not_messages_say_why(text, message):
    with pytest.raises(ConversionError) as error:
        MessageConverter(ROS2).message(text)
    assert message in str(error.value)


def test_field_names_that_are_not_identifiers_use_the_generic_walk():
    from rosbags.typesys import get_types_from_msg
    store = typestore("ros2_humble")
    store.register(get_types_from_msg("int32 ok\n", "test_msgs/msg/Odd"))
    fields = store.fielddefs["test_msgs/msg/Odd"]
    store.fielddefs["test_msgs/msg/Odd"] = (fields[0], [("import", fields[1][0][1])])   # as a crafted bag could
    msg = type("Odd", (), {"import": 3})()
    converter = MessageConverter(store)
    assert converter.term(msg, "test_msgs/msg/Odd") == "test_msgs__0__Odd(3)"
    assert "test_msgs/msg/Odd" not in converter._sources          # no code was generated for it


def test_generated_source_is_cached_and_readable():
    converter = MessageConverter(ROS2)
    source = converter.source("tf2_msgs/msg/TFMessage")
    assert "def convert(m):" in source and "def element_1(m):" in source and "tf2_msgs__0__TFMessage([" in source
    assert converter.term_function("tf2_msgs/msg/TFMessage") is converter.term_function("tf2_msgs/msg/TFMessage")


# ---- data terms -----------------------------------------------------------------------------

_atoms = st.text(max_size=8)
_leaves = st.one_of(st.integers(-2**70, 2**70), st.floats(allow_nan=False), _atoms,
                    st.builds(String, st.text(max_size=8)))
_data = st.recursive(_leaves, lambda inner: st.one_of(
    st.lists(inner, max_size=4),
    st.builds(Term, st.text(min_size=1, max_size=6), st.lists(inner, min_size=1, max_size=4).map(tuple))),
    max_leaves=12)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_data)
def test_data_terms_read_back_what_swi_prolog_writes(value):
    text = write_term(value)
    assert same_kinds(read_term(text), value)
    written = Bridge().call_text(f"term_string(T, {prolog_string(text)}), format(string(Out), '~q', [T])")
    assert same_kinds(read_term(written), value)


def same_kinds(a, b) -> bool:
    """Equal values of the same kinds (an atom is not a string)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, list):
        return len(a) == len(b) and all(map(same_kinds, a, b))
    if isinstance(a, Term):
        return a.name == b.name and len(a.args) == len(b.args) and all(map(same_kinds, a.args, b.args))
    return a == b


# ---- random messages: generated = generic, exact round trips -------------------------------------

CUSTOM = """int8 a
uint8 b
int16 c
uint16 d
int32 e
uint32 f
int64 g
uint64 h
float32 i
float64 j
bool k
string l
time m
duration n
int32[] ints
float64[3] floats
bool[] flags
string[] names
uint8[] raw
geometry_msgs/Point[] points
std_msgs/Empty nothing
"""


def _custom_store(store):
    from rosbags.typesys import get_types_from_msg
    store.register(get_types_from_msg(CUSTOM, "test_msgs/msg/AllTypes"))
    return store


@pytest.fixture(scope="module", params=[1, 2], ids=["ros1", "ros2"])
def custom(request):
    return _custom_store(typestore("ros1_noetic" if request.param == 1 else "ros2_humble"))


def _int(bits, signed):
    return st.integers(-2 ** (bits - 1), 2 ** (bits - 1) - 1) if signed else st.integers(0, 2 ** bits - 1)


_float32 = st.floats(width=32)
_float = st.floats()
_text = st.text(max_size=10)


@st.composite
def _all_types(draw, store):
    T = store.types
    point = st.builds(T["geometry_msgs/msg/Point"], x=_float, y=_float, z=_float)
    return T["test_msgs/msg/AllTypes"](
        a=draw(_int(8, True)), b=draw(_int(8, False)), c=draw(_int(16, True)), d=draw(_int(16, False)),
        e=draw(_int(32, True)), f=draw(_int(32, False)), g=draw(_int(64, True)), h=draw(_int(64, False)),
        i=draw(_float32), j=draw(_float), k=draw(st.booleans()), l=draw(_text),
        m=T["builtin_interfaces/msg/Time"](sec=draw(_int(32, True)), nanosec=draw(st.integers(0, 999_999_999))),
        n=T["builtin_interfaces/msg/Duration"](sec=draw(_int(32, True)), nanosec=draw(st.integers(0, 999_999_999))),
        ints=np.array(draw(st.lists(_int(32, True), max_size=4)), dtype=np.int32),
        floats=np.array(draw(st.lists(_float, min_size=3, max_size=3)), dtype=np.float64),
        flags=np.array(draw(st.lists(st.booleans(), max_size=3)), dtype=np.bool_),
        names=draw(st.lists(_text, max_size=3)),
        raw=np.array(draw(st.lists(_int(8, False), max_size=5)), dtype=np.uint8),
        points=draw(st.lists(point, max_size=3)),
        nothing=T["std_msgs/msg/Empty"](structure_needs_at_least_one_member=0))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                    HealthCheck.too_slow])
@given(data=st.data(), plain=st.booleans())
def test_random_messages_round_trip_and_generated_equals_generic(custom, data, plain):
    msg = data.draw(_all_types(custom))
    convention = Convention(plain_strings=plain)
    generated = MessageConverter(custom, convention)
    text = generated.term(msg, "test_msgs/msg/AllTypes")
    assert text == MessageConverter(custom, convention, generated=False).term(msg, "test_msgs/msg/AllTypes")
    msgtype, back = generated.message(text)
    assert msgtype == "test_msgs/msg/AllTypes"
    assert same_value(back, msg)
    assert generated.term(back, msgtype) == text


# ---- every message type of the sample recordings --------------------------------------------

def _round_trip_recording(path: Path, per_topic: int = 25) -> dict:
    """The first `per_topic` messages of every topic: the generated text equals the generic
    one, and term -> message serializes to the same bytes as the original. Returns the
    number of messages checked per type."""
    counts: dict = {}
    with Recording(path) as bag:
        store = bag.typestore
        generated, generic = MessageConverter(store), MessageConverter(store, generated=False)
        serialize = store.serialize_ros1 if bag.format == "ros1" else store.serialize_cdr
        for topic in bag.topics():
            for number, record in enumerate(bag.records([topic])):
                if number == per_topic:
                    break
                assert record.msg is not None, record.error
                text = generated.term(record.msg, record.msgtype)
                assert text == generic.term(record.msg, record.msgtype), record.msgtype
                msgtype, back = generated.message(text)
                assert msgtype == record.msgtype
                assert bytes(serialize(back, msgtype)) == bytes(serialize(record.msg, msgtype)), record.msgtype
                assert same_value(back, record.msg)
                counts[msgtype] = counts.get(msgtype, 0) + 1
    return counts


SHARED_TYPES = {  # bag: (number of message types, a type that must be among them)
    "evo_nav2_turtlebot.mcap": (3, "nav_msgs/msg/Odometry"),
    "evo_tf_example.bag": (1, "tf2_msgs/msg/TFMessage"),
    "evo_tf_example_ros2": (1, "tf2_msgs/msg/TFMessage"),
    "fiducials_aruco_transforms.bag": (1, "fiducial_msgs/msg/FiducialTransformArray"),   # custom, from the bag
    "tf_bag_franka.bag": (15, "visualization_msgs/msg/InteractiveMarkerInit"),
    "tf_bag_franka_ros2": (1, "tf2_msgs/msg/TFMessage"),
}


@pytest.mark.parametrize("name", SHARED_NAMES)
def test_round_trip_every_message_type_of_the_shared_bags(name):
    counts = _round_trip_recording(shared_bag(name), per_topic=2)
    types, example = SHARED_TYPES[name]
    assert len(counts) == types and example in counts


@pytest.mark.parametrize("fmt", ["ros1", "ros2", "mcap"])
def test_round_trip_every_message_type_of_the_generated_bags(tmp_path, fmt):
    from retalisc.robot_io.samples import write_nao_bag
    path = write_nao_bag(tmp_path / ("nao.bag" if fmt == "ros1" else "nao"), fmt, seconds=2.0, tf_rate=20)
    counts = _round_trip_recording(path)
    assert set(counts) == {"tf2_msgs/msg/TFMessage", "ar_pose/msg/ARMarkers", "geometry_msgs/msg/PoseStamped",
                           "visualization_msgs/msg/MarkerArray"}


def test_sample_records_are_in_arrival_order_with_late_detections():
    records = nao_records(sample_store(2), seconds=3.0, tf_rate=20)
    times = [ns for _, _, ns, _ in records]
    assert times == sorted(times)
    converter = MessageConverter(sample_store(2))
    stamps = [converter.stamp_ns(msg, msgtype) for _, msgtype, _, msg in records if msgtype != "tf2_msgs/msg/TFMessage"]
    assert stamps != sorted(stamps)       # detections recorded late: record order is not stamp order
