"""ROS 1 messages handed to the runtime as bytes (retalisc/robot_io/ros1_terms.py,
prolog_runtime/rtl_ros1.pl, c/rtl_ros1.c) against the text road they replace
(robot_io/messages.py + read_term), which is the oracle: the same event term and time for
every message, on every base type, array form and string; refusals (truncated or padded
bytes, bad UTF-8, non-finite floats) that leave the message to the text road, which says
what is wrong or writes the float; and the bag replay and live node giving the same output
either way."""
from __future__ import annotations

import json
import math
import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("rosbags")
np = pytest.importorskip("numpy")

from rosbags.typesys import get_types_from_msg  # noqa: E402

from retalisc.driver.bridge import PrologError  # noqa: E402
from retalisc.driver.engine import Engine, Ros1Bytes  # noqa: E402
from retalisc.robot_io.bags import typestore  # noqa: E402
from retalisc.robot_io.messages import Convention, MessageConverter  # noqa: E402
from retalisc.robot_io.ros1_terms import Ros1Terms  # noqa: E402

ALL_MSG = """std_msgs/Header header
bool b
int8 i8
uint8 u8
byte by
char ch
int16 i16
uint16 u16
int32 i32
uint32 u32
int64 i64
uint64 u64
float32 f32
float64 f64
string s
time t
duration d
float64[3] fixed
uint8[] raw
bool[] flags
string[] names
string[2] pair
rtl_test/Item[] items
std_msgs/Empty nothing
"""
ITEM_MSG = """int32 k
string label
float32[] values
"""


def make_store():
    store = typestore("ros1_noetic")
    types = {}
    types.update(get_types_from_msg(ALL_MSG, "rtl_test/msg/All"))
    types.update(get_types_from_msg(ITEM_MSG, "rtl_test/msg/Item"))
    store.register(types)
    return store


STORE = make_store()
T = STORE.types


@pytest.fixture(scope="module")
def engine():
    engine = Engine.from_source("", "ros1_terms.rtl")
    engine.set_flag("echo_input", "true")
    engine.set_flag("max_future", "inf")    # the drawn stamps go up to 2038: not a limit test
    probe = Ros1Terms(engine, STORE)
    if probe.event(b"", "std_msgs/msg/Empty", "/e", 1) is None:
        pytest.skip("the runtime's C helper rtl_ros1 is not built (bash prolog_runtime/c/build.sh)")
    return engine


def fed(engine, event, seconds):
    """The event text the runtime echoes for one input event; None when it refuses the bytes."""
    try:
        out = engine.feed_batch([(event, seconds)])
    except PrologError as error:
        assert getattr(error, "undecodable", False), str(error)
        assert error.batch_index == 0 and error.delivered == []
        return None
    assert len(out) == 1
    return json.loads(out[0].line)


def both_roads(engine, msg, msgtype, convention=Convention(), topic="/x", record_ns=1_500_000_000_123):
    data = bytes(STORE.serialize_ros1(msg, msgtype))
    text, seconds = MessageConverter(STORE, convention).event(msg, msgtype, topic, record_ns)
    road = Ros1Terms(engine, STORE, convention).event(data, msgtype, topic, record_ns)
    assert road is not None, msgtype
    assert isinstance(road[0], Ros1Bytes) and road[1] == seconds
    return fed(engine, text, seconds), fed(engine, road[0], road[1])


# ---- messages of every kind -------------------------------------------------------------------

i = st.integers
finite = st.floats(allow_nan=False, allow_infinity=False)
finite32 = st.floats(allow_nan=False, allow_infinity=False, width=32)
text = st.text(max_size=12)


@st.composite
def all_messages(draw):
    stamp = T["builtin_interfaces/msg/Time"](sec=draw(i(0, 2**31 - 1)), nanosec=draw(i(0, 10**9 - 1)))
    items = [T["rtl_test/msg/Item"](k=draw(i(-2**31, 2**31 - 1)), label=draw(text),
                                    values=np.array(draw(st.lists(finite32, max_size=3)), dtype=np.float32))
             for _ in range(draw(i(0, 3)))]
    return T["rtl_test/msg/All"](
        header=T["std_msgs/msg/Header"](seq=draw(i(0, 2**32 - 1)), stamp=stamp, frame_id=draw(text)),
        b=draw(st.booleans()), i8=draw(i(-128, 127)), u8=draw(i(0, 255)), by=draw(i(-128, 127)), ch=draw(i(0, 255)),
        i16=draw(i(-2**15, 2**15 - 1)), u16=draw(i(0, 2**16 - 1)), i32=draw(i(-2**31, 2**31 - 1)),
        u32=draw(i(0, 2**32 - 1)), i64=draw(i(-2**63, 2**63 - 1)), u64=draw(i(0, 2**64 - 1)),
        f32=draw(finite32), f64=draw(finite), s=draw(st.text(max_size=40)),
        t=T["builtin_interfaces/msg/Time"](sec=draw(i(0, 2**31 - 1)), nanosec=draw(i(0, 10**9 - 1))),
        d=T["builtin_interfaces/msg/Duration"](sec=draw(i(-2**31, 2**31 - 1)), nanosec=draw(i(0, 10**9 - 1))),
        fixed=np.array(draw(st.lists(finite, min_size=3, max_size=3))),
        raw=np.array(draw(st.lists(i(0, 255), max_size=6)), dtype=np.uint8),
        flags=np.array(draw(st.lists(st.booleans(), max_size=4)), dtype=np.bool_),
        names=draw(st.lists(text, max_size=3)), pair=[draw(text), draw(text)], items=items,
        nothing=T["std_msgs/msg/Empty"]())


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(msg=all_messages(), plain=st.booleans(), wrap=st.booleans())
def test_the_bytes_give_the_term_and_time_of_the_text(engine, msg, plain, wrap):
    text_road, bytes_road = both_roads(engine, msg, "rtl_test/msg/All",
                                       Convention(plain_strings=plain, wrap_topic=wrap), topic="/a/b")
    assert text_road is not None and bytes_road == text_road


# ---- CDR (ROS 2 and Zenoh nodes): the same road with CDR's alignment -------------------------------

def make_cdr_store():
    store = typestore("ros2_humble")
    types = {}
    types.update(get_types_from_msg(ALL_MSG.replace("time t", "builtin_interfaces/Time t")
                                    .replace("duration d", "builtin_interfaces/Duration d"), "rtl_test/msg/All"))
    types.update(get_types_from_msg(ITEM_MSG, "rtl_test/msg/Item"))
    store.register(types)
    return store


CDR_STORE = make_cdr_store()


def cdr_message(msg):
    """The message `msg` (of STORE) in CDR_STORE's types: the header without its seq."""
    values = {}
    for name in msg.__dataclass_fields__:
        value = getattr(msg, name)
        if name == "header":
            value = CDR_STORE.types["std_msgs/msg/Header"](stamp=value.stamp, frame_id=value.frame_id)
        elif name == "items":
            value = [CDR_STORE.types["rtl_test/msg/Item"](k=item.k, label=item.label, values=item.values) for item in value]
        values[name] = value
    return CDR_STORE.types["rtl_test/msg/All"](**values)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(msg=all_messages(), plain=st.booleans(), wrap=st.booleans())
def test_cdr_bytes_give_the_term_and_time_of_the_text(engine, msg, plain, wrap):
    """CDR bytes (every base type at every alignment, strings with their NUL, padding at the
    end) read in C give the text road's term and time (the header's stamp)."""
    msg = cdr_message(msg)
    convention = Convention(plain_strings=plain, wrap_topic=wrap)
    data = bytes(CDR_STORE.serialize_cdr(msg, "rtl_test/msg/All"))
    text, seconds = MessageConverter(CDR_STORE, convention).event(msg, "rtl_test/msg/All", "/a/b", 1_500_000_000_123)
    road = Ros1Terms(engine, CDR_STORE, convention, cdr=True).event(data, "rtl_test/msg/All", "/a/b",
                                                                     1_500_000_000_123)
    assert road is not None and road[1] == seconds
    assert fed(engine, road[0], road[1]) == fed(engine, text, seconds)


def test_cdr_tf_message_and_refusals(engine):
    """A ROS 2 TFMessage: its first transform's stamp, ROS 2's header; damaged CDR is refused
    (the text road then says what is wrong)."""
    T2 = CDR_STORE.types
    transform = T2["geometry_msgs/msg/TransformStamped"](
        header=T2["std_msgs/msg/Header"](stamp=T2["builtin_interfaces/msg/Time"](sec=1413748205, nanosec=5),
                                         frame_id="odom"),
        child_frame_id="base_link",
        transform=T2["geometry_msgs/msg/Transform"](translation=T2["geometry_msgs/msg/Vector3"](x=1.5, y=-0.0, z=1e-300),
                                                    rotation=T2["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
    msg = T2["tf2_msgs/msg/TFMessage"](transforms=[transform] * 3)
    data = bytes(CDR_STORE.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
    terms = Ros1Terms(engine, CDR_STORE, Convention(), cdr=True)
    road = terms.event(data, "tf2_msgs/msg/TFMessage", "/tf", 7)
    text, seconds = MessageConverter(CDR_STORE).event(msg, "tf2_msgs/msg/TFMessage", "/tf", 7)
    assert road[1] == seconds == 1413748205_000000005 / 1e9
    out = fed(engine, road[0], road[1])
    assert out == fed(engine, text, seconds)
    assert out["event"].startswith("tf2_msgs__0__TFMessage([geometry_msgs__0__TransformStamped("
                                   "std_msgs__0__Header([1413748205,5],odom),base_link,")
    big_endian = data[:1] + b"\x00" + data[2:]
    for bad in (data[:-1], data + b"\x00" * 4, data + b"\x01", big_endian, data[:4],
                data.replace(b"odom\x00", b"odo\xff\x00")):
        assert fed(engine, terms.event(bad, "tf2_msgs/msg/TFMessage", "/tf", 7)[0], 1.0) is None, bad


def test_the_release_convention_on_the_nao_types(engine):
    transform = T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](seq=3, stamp=T["builtin_interfaces/msg/Time"](sec=1413748205, nanosec=5),
                                        frame_id="/odom"),
        child_frame_id="/base_link",
        transform=T["geometry_msgs/msg/Transform"](translation=T["geometry_msgs/msg/Vector3"](x=1.5, y=-0.0, z=1e-300),
                                                   rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
    text_road, bytes_road = both_roads(engine, T["tf2_msgs/msg/TFMessage"](transforms=[transform] * 3),
                                       "tf2_msgs/msg/TFMessage", Convention(plain_strings=False))
    assert bytes_road == text_road
    assert bytes_road["event"].startswith("tf2_msgs__0__TFMessage([geometry_msgs__0__TransformStamped("
                                          "std_msgs__0__Header(3,[1413748205,5],'\"/odom\"'),'\"/base_link\"',")
    assert bytes_road["end"] == 1413748205_000000005 / 1e9    # no header: its first transform's stamp
    empty_text, empty_bytes = both_roads(engine, T["std_msgs/msg/Empty"](), "std_msgs/msg/Empty")
    assert empty_bytes == empty_text and empty_bytes["event"] == "std_msgs__0__Empty"


def test_the_stamp_is_the_header_stamp_or_the_record_time(engine):
    pose = T["geometry_msgs/msg/PoseStamped"](
        header=T["std_msgs/msg/Header"](seq=1, stamp=T["builtin_interfaces/msg/Time"](sec=7, nanosec=250_000_000),
                                        frame_id="m"),
        pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=3.0),
                                         orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
    terms = Ros1Terms(engine, STORE)
    data = bytes(STORE.serialize_ros1(pose, "geometry_msgs/msg/PoseStamped"))
    assert terms.event(data, "geometry_msgs/msg/PoseStamped", "/p", 9_000_000_000)[1] == 7.25
    assert terms.event(data, "geometry_msgs/msg/PoseStamped", "/p", 9_000_000_000, record_stamp=True)[1] == 9.0
    pose.header.stamp.sec, pose.header.stamp.nanosec = 0, 0        # not set: the record time
    data = bytes(STORE.serialize_ros1(pose, "geometry_msgs/msg/PoseStamped"))
    assert terms.event(data, "geometry_msgs/msg/PoseStamped", "/p", 9_000_000_000)[1] == 9.0
    assert terms.event(data[:6], "geometry_msgs/msg/PoseStamped", "/p", 9_000_000_000) is None   # too short


# ---- what the bytes road refuses ------------------------------------------------------------

def test_refusals_leave_the_message_to_the_text_road(engine):
    msg = T["rtl_test/msg/Item"](k=1, label="ok", values=np.array([1.0], dtype=np.float32))
    data = bytes(STORE.serialize_ros1(msg, "rtl_test/msg/Item"))
    handle = Ros1Terms(engine, STORE).event(data, "rtl_test/msg/Item", "/i", 1)[0].handle
    assert fed(engine, Ros1Bytes(handle, data), 1.0) is not None
    assert fed(engine, Ros1Bytes(handle, data[:-1]), 1.0) is None              # truncated
    assert fed(engine, Ros1Bytes(handle, data + b"\0"), 1.0) is None           # trailing bytes
    bad_utf8 = data.replace(b"ok", b"\xff\xfe")
    assert fed(engine, Ros1Bytes(handle, bad_utf8), 1.0) is None
    with pytest.raises(Exception):
        STORE.deserialize_ros1(bad_utf8, "rtl_test/msg/Item")                 # the text road rejects it too
    huge = data[:4] + struct.pack("<I", 2**31) + data[8:]                     # a string longer than the bytes
    assert fed(engine, Ros1Bytes(handle, huge), 1.0) is None
    for value in (math.inf, -math.inf, math.nan):
        msg.values = np.array([value], dtype=np.float32)
        nonfinite = bytes(STORE.serialize_ros1(msg, "rtl_test/msg/Item"))
        assert fed(engine, Ros1Bytes(handle, nonfinite), 1.0) is None
    # a refusal stops the batch at that event, after delivering what came before
    with pytest.raises(PrologError) as caught:
        engine.feed_batch([("a(1)", 1.0), (Ros1Bytes(handle, data[:3]), 1.0), ("a(2)", 1.0)])
    assert caught.value.undecodable and caught.value.batch_index == 1
    assert [json.loads(o.line)["event"] for o in caught.value.delivered] == ["a(1)"]


def has_non_finite_float(value) -> bool:
    """Whether a decoded message holds an infinite or NaN float anywhere (not a string "NaN")."""
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, (str, bytes, int)):
        return False
    if hasattr(value, "dtype"):
        return value.dtype.kind == "f" and not bool(np.isfinite(value).all())
    if isinstance(value, (list, tuple)):
        return any(has_non_finite_float(v) for v in value)
    if hasattr(value, "__dataclass_fields__"):
        return any(has_non_finite_float(getattr(value, name)) for name in value.__dataclass_fields__)
    return False


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(msg=all_messages(), cut=st.integers(0, 10_000), position=st.integers(0, 10_000), byte=st.integers(0, 255),
       extra=st.binary(max_size=3))
def test_damaged_bytes_are_refused_or_read_as_rosbags_reads_them(engine, msg, cut, position, byte, extra):
    data = bytearray(STORE.serialize_ros1(msg, "rtl_test/msg/All"))
    data[position % len(data)] = byte
    data = bytes(data[:len(data) - cut % 8] + extra)
    handle = Ros1Terms(engine, STORE).event(bytes(STORE.serialize_ros1(msg, "rtl_test/msg/All")),
                                            "rtl_test/msg/All", "/a", 1)[0].handle
    bytes_road = fed(engine, Ros1Bytes(handle, data), 1.0)
    try:
        decoded = STORE.deserialize_ros1(data, "rtl_test/msg/All")
        text, _ = MessageConverter(STORE).event(decoded, "rtl_test/msg/All", "/a", 1_000_000_000)
    except Exception:
        assert bytes_road is None                  # what rosbags refuses, the runtime refuses
        return
    if has_non_finite_float(decoded):
        assert bytes_road is None                  # non-finite floats: the text road writes them
    else:
        assert bytes_road is not None and bytes_road["event"] == fed(engine, text, 1.0)["event"]


# ---- the replay and the live node -------------------------------------------------------------

def test_replay_takes_the_text_road_for_refused_messages(tmp_path, capsys):
    """A recording with a message of a non-finite float and one cut short: the first is
    converted by the text road (1.0Inf), the second rejected as before, the rest read from
    the bytes."""
    from rosbags.rosbag1 import Writer

    from retalisc.robot_io.replay import BagOptions, replay_bag

    msgtype = "rtl_test/msg/Item"
    good = [T[msgtype](k=k, label=f"n{k}", values=np.array([k / 2], dtype=np.float32)) for k in range(3)]
    inf = T[msgtype](k=9, label="inf", values=np.array([math.inf], dtype=np.float32))
    path = tmp_path / "items.bag"
    with Writer(path) as writer:
        connection = writer.add_connection("/items", msgtype, typestore=STORE)
        for n, raw in enumerate([STORE.serialize_ros1(good[0], msgtype), STORE.serialize_ros1(inf, msgtype),
                                 bytes(STORE.serialize_ros1(good[1], msgtype))[:-2],
                                 STORE.serialize_ros1(good[2], msgtype)]):
            writer.write(connection, 1_000_000_000 * (n + 1), bytes(raw))
    engine = Engine.from_source("", "replay.rtl")
    engine.set_flag("echo_input", "true")
    out = tmp_path / "out.jsonl"
    assert replay_bag(engine, str(path), str(out), BagOptions(), progress=False) == 0
    events = [json.loads(line)["event"] for line in out.read_text().splitlines()]
    assert events == ["rtl_test__0__Item(0,n0,[0.0])", "rtl_test__0__Item(9,inf,[1.0Inf])",
                      "rtl_test__0__Item(2,n2,[1.0])"]
    err = capsys.readouterr().err
    assert "/items#3: rejected: cannot decode:" in err and "4 messages" in err and "1 rejected" in err


def test_the_live_node_takes_the_text_road_for_refused_messages():
    """LiveNode on a ROS 1 transport in memory: good messages by the bytes road, a
    non-finite float by the text road, a truncated message rejected and reported."""
    from retalisc.live.config import parse_config
    from retalisc.live.node import LiveNode, Transport

    class Ros1Memory(Transport):
        wire = "ros1"
        name = "memory"

        def start(self, node):
            self.node = node

        def subscribe(self, topic, msgtype):
            pass

    msgtype = "rtl_test/msg/Item"
    engine = Engine.from_source("", "live_ros1.rtl")
    engine.set_flag("echo_input", "true")
    seen, log = [], []
    node = LiveNode(engine, Ros1Memory(), parse_config(
        "<publish_subscribe><subscribe_to name='/items' msg_type='rtl_test/Item'/></publish_subscribe>"),
                    log=log.append)
    node._deliveries.append(lambda event: seen.append(event.event))
    node.store.register({k: v for k, v in get_types_from_msg(ITEM_MSG, msgtype).items()})
    node.start()
    inf = T[msgtype](k=9, label="inf", values=np.array([-math.inf], dtype=np.float32))
    for raw in [STORE.serialize_ros1(T[msgtype](k=1, label="a", values=np.array([], dtype=np.float32)), msgtype),
                STORE.serialize_ros1(inf, msgtype), bytes(STORE.serialize_ros1(inf, msgtype))[:5],
                STORE.serialize_ros1(T[msgtype](k=2, label="b", values=np.array([0.5], dtype=np.float32)), msgtype)]:
        node.arrived("/items", bytes(raw))
    node.close()
    assert seen == ["rtl_test__0__Item(1,a,[])", "rtl_test__0__Item(9,inf,[-1.0Inf])",
                    "rtl_test__0__Item(2,b,[0.5])"]
    assert node.ros1_terms.bytes_types() == [msgtype]
    assert node.stats.rejected["/items"] == 1 and len(log) == 1 and log[0].startswith("/items#3: rejected:")
