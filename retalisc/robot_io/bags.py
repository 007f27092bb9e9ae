"""Recordings: reading ROS 1 `.bag` files, ROS 2 bag folders (sqlite3 or MCAP storage) and
bare MCAP files with `rosbags`, and writing small ones.

Messages come in record order: the order of the time each message was recorded, which is
the order it arrived on the robot, not the order of its header stamp (a late detection stays
late). The message types are the bag's own definitions when it embeds them (ROS 1 bags,
MCAP files, recent ROS 2 bags), custom types included; a ROS 2 bag without definitions is
read with a rosbags type store (`ros2_humble` unless told otherwise).
"""
from __future__ import annotations

import struct
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Iterable, Iterator, List, NamedTuple, Optional, Sequence, Tuple

from . import require

DEFAULT_ROS2_STORE = "ros2_humble"

# tf2_msgs/TFMessage is missing from rosbags' ROS 1 (noetic) type store; tf/tfMessage, the
# type of the thesis's recordings, has the same definition.
_TF_MESSAGE = "geometry_msgs/TransformStamped[] transforms\n"


class BagError(Exception):
    """A recording that cannot be opened or read; the message names the file and the reason."""


class Record(NamedTuple):
    """One message of a recording. `msg` is None when it could not be decoded (`error` says
    why), or when the record was read undecoded (`raw_records`): `raw` is its bytes."""

    topic: str
    msgtype: str
    time_ns: int
    msg: object
    error: Optional[str] = None
    raw: Optional[bytes] = None


@dataclass(frozen=True)
class TopicInfo:
    msgtype: str
    count: int


def typestore(name: str):
    """A rosbags type store by name (`ros1_noetic`, `ros2_humble`, ...). The ROS 1 store gets
    tf2_msgs/TFMessage and tf/tfMessage, which it lacks."""
    typesys = require("rosbags.typesys", "reading ROS messages")
    try:
        store = typesys.get_typestore(typesys.Stores(name))
    except ValueError:
        names = ", ".join(s.value for s in typesys.Stores if s.value not in ("empty",))
        raise BagError(f"unknown type store {name!r} (known: {names})") from None
    if name == "ros1_noetic":
        add_ros1_tf_types(store)
    return store


def add_ros1_tf_types(store) -> None:
    """Register tf2_msgs/msg/TFMessage and tf/msg/tfMessage in a ROS 1 type store."""
    typesys = require("rosbags.typesys", "reading ROS messages")
    types = {}
    for name in ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage"):
        if name not in store.fielddefs:
            types.update(typesys.get_types_from_msg(_TF_MESSAGE, name))
    if types:
        store.register(types)


def bag_format(path: Path) -> str:
    """`ros1`, `ros2` (a bag folder, sqlite3 or MCAP storage) or `mcap` (a bare MCAP file)."""
    if path.is_dir():
        if not (path / "metadata.yaml").exists():
            raise BagError(f"{path}: a ROS 2 bag folder holds a metadata.yaml; this one does not")
        return "ros2"
    if path.suffix == ".bag":
        return "ros1"
    if path.suffix == ".mcap":
        return "mcap"
    if path.suffix == ".db3" and (path.parent / "metadata.yaml").exists():
        return "ros2"
    raise BagError(f"{path}: not a recording (expected a ROS 1 .bag file, a ROS 2 bag folder or an .mcap file)")


class Recording:
    """An open recording: `with Recording(path) as bag: for record in bag.records(): ...`."""

    def __init__(self, path, default_store: str = DEFAULT_ROS2_STORE):
        self.path = Path(path)
        if not self.path.exists():
            raise BagError(f"{self.path}: no such file or folder")
        self.format = bag_format(self.path)
        if self.format == "ros2" and self.path.suffix == ".db3":
            self.path = self.path.parent
        self.default_store = default_store
        self._reader = None
        self._store = None

    def __enter__(self) -> "Recording":
        if self.format == "ros1":
            module = require("rosbags.rosbag1", "reading bags")
        else:
            module = require("rosbags.rosbag2", "reading bags")
        typesys = require("rosbags.typesys", "reading bags")
        try:
            reader = module.Reader(self.path)
            reader.open()
        except (module.ReaderError, OSError, ValueError, KeyError) as error:
            raise BagError(f"{self.path}: cannot read this {self.format} recording: {error}") from None
        try:
            self._store = _typestore_of(reader.connections, self.format == "ros1", self.default_store)
        except (typesys.TypesysError, ValueError, KeyError) as error:
            reader.close()
            raise BagError(f"{self.path}: cannot read the message definitions of this recording: {error}") from None
        except BaseException:
            reader.close()
            raise
        self._reader = reader
        return self

    def __exit__(self, *exc) -> bool:
        if self._reader is not None:
            self._reader.close()
            self._reader = None
        return False

    @property
    def typestore(self):
        """The type store the messages are decoded with (the bag's own definitions, when it
        has them)."""
        return self._store

    @property
    def start_ns(self) -> int:
        return self._reader.start_time if self._reader.message_count else 0

    @property
    def end_ns(self) -> int:
        return self._reader.end_time if self._reader.message_count else 0

    @property
    def message_count(self) -> int:
        return self._reader.message_count

    def topics(self) -> Dict[str, TopicInfo]:
        """Every topic with its message type and number of messages, in name order."""
        result: Dict[str, TopicInfo] = {}
        for connection in self._reader.connections:
            info = result.get(connection.topic)
            count = connection.msgcount + (info.count if info else 0)
            result[connection.topic] = TopicInfo(connection.msgtype, count)
        return dict(sorted(result.items()))

    def records(self, topics: Optional[Sequence[str]] = None, start_ns: Optional[int] = None,
                stop_ns: Optional[int] = None) -> Iterator[Record]:
        """The messages of `topics` (default: all) recorded in [start_ns, stop_ns), in record
        order, decoded."""
        reader = self._reader
        connections = [c for c in reader.connections if topics is None or c.topic in topics]
        if not connections:
            return
        deserialize = self._store.deserialize_ros1 if self.format == "ros1" else self._store.deserialize_cdr
        errors = _read_errors()
        for connection, time_ns, raw in reader.messages(connections=connections, start=start_ns, stop=stop_ns):
            try:
                msg = deserialize(raw, connection.msgtype)
            except errors as error:
                yield Record(connection.topic, connection.msgtype, time_ns, None, f"cannot decode: {error}")
                continue
            yield Record(connection.topic, connection.msgtype, time_ns, msg)

    def raw_records(self, topics: Optional[Sequence[str]] = None, start_ns: Optional[int] = None,
                    stop_ns: Optional[int] = None) -> Iterator[Record]:
        """As `records`, but undecoded: each Record's `raw` holds the message's serialized
        bytes (ROS 1 serialization in a ROS 1 bag, CDR otherwise) and `msg` is None."""
        reader = self._reader
        connections = [c for c in reader.connections if topics is None or c.topic in topics]
        if not connections:
            return
        for connection, time_ns, raw in reader.messages(connections=connections, start=start_ns, stop=stop_ns):
            yield Record(connection.topic, connection.msgtype, time_ns, None, None, raw)

    def decode(self, record: Record) -> Record:
        """The record of `raw_records` decoded (as `records` gives it)."""
        deserialize = self._store.deserialize_ros1 if self.format == "ros1" else self._store.deserialize_cdr
        try:
            msg = deserialize(record.raw, record.msgtype)
        except _read_errors() as error:
            return record._replace(error=f"cannot decode: {error}")
        return record._replace(msg=msg)


_STORES: "OrderedDict[tuple, object]" = OrderedDict()
_STORES_KEPT = 8


def _typestore_of(connections, ros1: bool, default_store: str):
    """The type store of a recording: the definitions its connections embed (each parsed
    once: many connections share one), else the named default store (a ROS 2 bag without
    definitions). The digests recorded with the definitions are checked. Stores are kept
    for the last few sets of definitions, so opening the same recording again costs
    neither the parsing nor rosbags' generation of decoders."""
    interfaces = require("rosbags.interfaces", "reading bags")
    typesys = require("rosbags.typesys", "reading bags")
    none = interfaces.MessageDefinitionFormat.NONE
    definitions = sorted({(c.msgtype, c.msgdef.format.value, c.msgdef.data, c.digest or "")
                          for c in connections if c.msgdef.format != none})
    key = (ros1, tuple(definitions) if definitions else default_store)
    store = _STORES.get(key)
    if store is not None:
        _STORES.move_to_end(key)
        return store
    if not definitions:
        store = typestore(default_store)
    else:
        types: dict = {}
        msg_format = interfaces.MessageDefinitionFormat.MSG.value
        for msgtype, kind, data, _ in definitions:
            if kind == msg_format:
                types.update(typesys.get_types_from_msg(data, msgtype))
            else:
                separator = "=" * 80 + "\n"
                parts = data.split(separator)[1:] if data.startswith(separator + "IDL: ") else [data]
                for part in parts:
                    types.update(typesys.get_types_from_idl(part.split("\n", 1)[1] if part.startswith("IDL: ")
                                                            else part))
        store = typesys.get_typestore(typesys.Stores.EMPTY)
        store.register(types)
        digest_of = (lambda name: store.generate_msgdef(name)[1]) if ros1 else store.hash_rihs01
        for msgtype, _, _, digest in definitions:
            if digest and digest_of(msgtype) != digest:
                raise ValueError(f"message type {msgtype}: the definition does not match its digest {digest}")
    _STORES[key] = store
    if len(_STORES) > _STORES_KEPT:
        _STORES.popitem(last=False)
    return store


def _read_errors() -> Tuple[type, ...]:
    serde = require("rosbags.serde", "reading bags")
    return (serde.SerdeError, ValueError, IndexError, KeyError, UnicodeDecodeError, struct.error)


def write_bag(path, fmt: str, store, records: Iterable[Tuple[str, str, int, object]],
              overwrite: bool = False) -> Path:
    """Write `records` (topic, msgtype, time_ns, msg), in their order, to a new recording:
    `fmt` is `ros1` (a .bag file), `ros2` (a sqlite3 bag folder) or `mcap` (a ROS 2 bag
    folder with MCAP storage). `store` is the type store the messages belong to. Returns the
    path to give to Recording (the folder for ROS 2 bags). With `overwrite`, a recording
    already at `path` (a file, or a folder holding a ROS 2 bag's metadata.yaml) is removed
    first; anything else there is a BagError, left as it is."""
    path = Path(path)
    records = list(records)
    if overwrite:
        remove_recording(path)
    if fmt == "ros1":
        rosbag1 = require("rosbags.rosbag1", "writing bags")
        connections: Dict[Tuple[str, str], object] = {}
        with rosbag1.Writer(path) as writer:
            for topic, msgtype, time_ns, msg in records:
                key = (topic, msgtype)
                if key not in connections:
                    connections[key] = writer.add_connection(topic, msgtype, typestore=store)
                writer.write(connections[key], time_ns, store.serialize_ros1(msg, msgtype))
        return path
    rosbag2 = require("rosbags.rosbag2", "writing bags")
    plugin = {"ros2": rosbag2.StoragePlugin.SQLITE3, "mcap": rosbag2.StoragePlugin.MCAP}.get(fmt)
    if plugin is None:
        raise ValueError(f"unknown bag format {fmt!r}: ros1, ros2 or mcap")
    connections = {}
    with rosbag2.Writer(path, version=9, storage_plugin=plugin) as writer:
        for topic, msgtype, time_ns, msg in records:
            key = (topic, msgtype)
            if key not in connections:
                connections[key] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[key], time_ns, store.serialize_cdr(msg, msgtype))
    return path


def remove_recording(path: Path) -> None:
    """Remove the recording at `path` (nothing there: nothing to do): a file, or a ROS 2 bag
    folder (one with metadata.yaml, or empty). Raises BagError for another folder."""
    import shutil

    path = Path(path)
    if path.is_dir() and not path.is_symlink():
        if any(path.iterdir()) and not (path / "metadata.yaml").is_file():
            raise BagError(f"{path} is a folder that is not a ROS 2 bag: not overwritten")
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def mcap_file(folder: Path) -> Path:
    """The .mcap file inside a ROS 2 bag folder with MCAP storage."""
    files = sorted(Path(folder).glob("*.mcap"))
    if not files:
        raise BagError(f"{folder}: no .mcap file inside")
    return files[0]


def topic_list(text: Optional[str]) -> Optional[List[str]]:
    """`--topics /tf,/odom` as a list (None: every topic)."""
    if text is None:
        return None
    topics = [t.strip() for t in text.split(",") if t.strip()]
    return topics or None
