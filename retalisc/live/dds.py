"""`retalisc ros2 PROGRAM --config pub_sub.xml`: ROS 2 topics over DDS, without ROS 2.

ROS 2 talks DDS, and follows conventions any DDS implementation can follow (docs/ros.md
lists where each is specified):

- the DDS topic of ROS topic `/name` is `rt/name`;
- the DDS type of message `pkg/msg/Type` is `pkg::msg::dds_::Type_`, a struct whose members
  are the message's fields in order (nested messages, arrays and sequences alike), as rosidl
  generates it from the message definition;
- the data are the message in CDR (XCDR1, with its encapsulation header), exactly what
  rosbags' `serialize_cdr` writes and ROS 2 bags store;
- QoS: ROS 2's default profile, reliable and volatile, but keeping all samples instead of
  the last 10 (history is not part of DDS's request/offered matching, so this matches the
  same peers; a burst is then slowed down by the reliable protocol instead of overwritten);
  `/tf_static` is transient-local with keep last 1, as tf2's static broadcaster, so a late
  joiner gets it.

The IDL classes are made at runtime from the rosbags type store (cyclonedds `IdlStruct`
dataclasses named by the convention) and registered with DDS (type names, type information);
the samples themselves go through cyclonedds' C layer as CDR bytes, read and written by
rosbags (the IDL classes' own Python (de)serialization, which gives the same bytes, is used
when that layer is missing). Unless CYCLONEDDS_URI says otherwise, DDS stays on the loopback interface with
multicast off and unicast discovery of 127.0.0.1 (LOOPBACK_CONFIG).
"""
from __future__ import annotations

import dataclasses
import os
import threading
import time
import types as pytypes
from typing import Dict, Optional, Tuple

from ..robot_io import require
from .config import store_type
from .node import LiveNode, Transport

# rosbags' Nodetype values (as in robot_io/messages.py)
BASE, NAME, ARRAY, SEQUENCE = 1, 2, 3, 4

LOOPBACK_CONFIG = (
    "<CycloneDDS><Domain Id=\"any\"><General><Interfaces><NetworkInterface address=\"127.0.0.1\"/>"
    "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
    "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>"
    "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>")

STATIC_TOPICS = ("/tf_static",)


def dds_topic(topic: str) -> str:
    """`/tf` -> `rt/tf` (ROS 2 topic names over DDS)."""
    return "rt/" + topic.lstrip("/")


def dds_type(msgtype: str) -> str:
    """`pkg/msg/Type` -> `pkg::msg::dds_::Type_`."""
    package, _, name = store_type(msgtype).split("/")
    return f"{package}::msg::dds_::{name}_"


class IdlTypes:
    """cyclonedds IDL classes for the message types of a rosbags type store."""

    def __init__(self, store):
        self.store = store
        self.idl = require("cyclonedds.idl", "retalisc ros2")
        self.t = require("cyclonedds.idl.types", "retalisc ros2")
        self._classes: Dict[str, type] = {}
        t = self.t
        self._base = {"bool": bool, "byte": t.uint8, "octet": t.uint8, "char": t.uint8, "int8": t.int8,
                      "uint8": t.uint8, "int16": t.int16, "uint16": t.uint16, "int32": t.int32,
                      "uint32": t.uint32, "int64": t.int64, "uint64": t.uint64, "float32": t.float32,
                      "float64": t.float64, "string": str}

    def idl_class(self, msgtype: str) -> type:
        cls = self._classes.get(msgtype)
        if cls is None:
            _, fields = self.store.fielddefs[msgtype]
            annotations = {name: self._member(desc) for name, desc in fields}
            package, _, name = msgtype.split("/")
            cls = pytypes.new_class(f"{package}__{name}", (self.idl.IdlStruct,), {"typename": dds_type(msgtype)},
                                    lambda namespace: namespace.update({"__annotations__": annotations}))
            cls = self._classes[msgtype] = dataclasses.dataclass(cls)
        return cls

    def _member(self, desc):
        kind, detail = desc
        if kind == BASE:
            name, bound = detail
            if name == "string" and bound:
                return self.t.bounded_str[bound]
            if name not in self._base:
                raise ValueError(f"the field type {name} is not supported over DDS")
            return self._base[name]
        if kind == NAME:
            return self.idl_class(detail)
        inner, size = detail
        if kind == ARRAY:
            return self.t.array[self._member(inner), size]
        return self.t.sequence[self._member(inner), size] if size else self.t.sequence[self._member(inner)]


try:        # cyclonedds' C layer: samples as CDR bytes; the public API (de)serializes in Python
    from cyclonedds._clayer import ddspy_take as _take, ddspy_write as _write
except ImportError:          # pragma: no cover - another cyclonedds: the public API
    _take = _write = None


_TIMEOUT = -10      # DDS_RETCODE_TIMEOUT: a keep-all writer waited max_blocking_time for its readers


def _raw_take():
    """reader -> the CDR bytes of up to 256 valid samples taken, or None without the C layer."""
    if _take is None:
        return None
    from cyclonedds.core import InstanceState, SampleState, ViewState    # optional: the `live` extra

    mask = SampleState.Any | ViewState.Any | InstanceState.Any

    def take(reader):
        taken = _take(reader._ref, mask, 256)
        if isinstance(taken, int):
            raise RuntimeError(f"DDS take failed ({taken})")
        return [bytes(data) for data, info in taken if info.valid_data]

    return take


class DdsTransport(Transport):
    wire = "cdr"
    name = "ros2"

    def __init__(self, domain: Optional[int] = None):
        require("cyclonedds", "retalisc ros2")
        if "CYCLONEDDS_URI" not in os.environ:
            os.environ["CYCLONEDDS_URI"] = LOOPBACK_CONFIG
        self.domain = int(os.environ.get("ROS_DOMAIN_ID", "0")) if domain is None else domain
        self._topics: Dict[str, object] = {}
        self._readers: Dict[str, tuple] = {}
        self._lock = threading.Lock()
        self._stopping = False
        self._writers: Dict[str, Tuple[str, object, type]] = {}

    def start(self, node: LiveNode) -> None:
        from cyclonedds.domain import DomainParticipant     # optional (the `live` extra), as below

        from cyclonedds.core import WaitSet

        self.node = node
        self.types = IdlTypes(node.store)
        self.participant = DomainParticipant(self.domain)
        self._waitset = WaitSet(self.participant)
        self._thread = threading.Thread(target=self._take_loop, name="retalis-dds-reader", daemon=True)
        self._thread.start()

    def _qos(self, topic: str, reader: bool):
        from cyclonedds.core import Policy, Qos
        from cyclonedds.util import duration

        if topic in STATIC_TOPICS:
            return Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.TransientLocal,
                       Policy.History.KeepLast(100 if reader else 1))
        return Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.Volatile,
                   Policy.History.KeepAll)

    def _topic(self, topic: str, msgtype: str):
        from cyclonedds.topic import Topic

        cls = self.types.idl_class(store_type(msgtype))
        entry = self._topics.get(topic)
        if entry is None or entry[1] is not cls:
            entry = self._topics[topic] = (Topic(self.participant, dds_topic(topic), cls), cls)
        return entry

    def subscribe(self, topic: str, msgtype: str) -> None:
        from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState
        from cyclonedds.sub import DataReader

        dds, cls = self._topic(topic, msgtype)
        reader = DataReader(self.participant, dds, qos=self._qos(topic, True))
        condition = ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any)
        with self._lock:
            self._readers[topic] = (reader, condition, cls)
            self._waitset.attach(condition)

    def _take_loop(self) -> None:
        """The reader thread: waits on the readers' conditions (the wait runs without Python's
        lock) and takes what came. Taking here, not in a DDS listener, keeps Python off
        cyclonedds' receive threads, which would otherwise wait for Python's lock while the
        socket buffers overflow under load."""
        from cyclonedds.util import duration

        raw = _raw_take()
        while not self._stopping:
            self._waitset.wait(duration(milliseconds=100))
            with self._lock:
                readers = list(self._readers.items())
            for topic, (reader, _, cls) in readers:
                while True:
                    if raw is not None:
                        taken = raw(reader)
                    else:
                        taken = [s.serialize() for s in reader.take(N=256) if isinstance(s, cls)]
                    if not taken:
                        break
                    for data in taken:
                        self.node.arrived(topic, data)

    def unsubscribe(self, topic: str) -> bool:
        with self._lock:
            entry = self._readers.pop(topic, None)
            if entry is None:
                return False
            self._waitset.detach(entry[1])
        return True            # the reader goes with its last reference

    def advertise(self, topic: str, msgtype: str):
        from cyclonedds.pub import DataWriter

        entry = self._writers.get(topic)
        if entry is None or entry[0] != msgtype:
            dds, cls = self._topic(topic, msgtype)
            entry = self._writers[topic] = (msgtype, DataWriter(self.participant, dds, qos=self._qos(topic, False)),
                                            cls)
        return entry

    def flush(self, timeout: float) -> None:
        """Wait (in all at most `timeout` s) until the matched readers acknowledged every
        sample written: a sample still to be repeated by a writer dies with the process."""
        from cyclonedds.util import duration

        deadline = time.monotonic() + timeout
        for _, writer, _ in list(self._writers.values()):
            left = deadline - time.monotonic()
            if left <= 0:
                break
            try:
                writer.wait_for_acks(duration(seconds=left))
            except Exception:        # a timeout: a reader is behind; the snapshot goes on
                pass

    def subscriber_count(self, topic: str) -> int:
        entry = self._writers.get(topic)
        return 0 if entry is None else len(entry[1].get_matched_subscriptions())

    def publish(self, topic: str, msgtype: str, data: bytes) -> None:
        _, writer, cls = self.advertise(topic, msgtype)
        if _write is not None:                # the CDR bytes as rosbags wrote them
            padded = data.ljust((len(data) + 3) & ~3, b"\0")
            code = _write(writer._ref, padded)
            while code == _TIMEOUT:           # a reader is behind: wait for it, lose nothing
                code = _write(writer._ref, padded)
            if code < 0:
                raise RuntimeError(f"DDS write on {dds_topic(topic)} failed ({code})")
        else:
            writer.write(cls.deserialize(data))

    def close(self) -> None:
        self._stopping = True
        if getattr(self, "_thread", None) is not None:
            self._thread.join(2)
        self._readers.clear()
        self._writers.clear()
        self._topics.clear()
        self.participant = None
