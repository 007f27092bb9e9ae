"""Derived events back into the robot's tools: an MCAP file (`--out-bag FILE.mcap`, written
with the `mcap` package) and a live Foxglove WebSocket server (`--foxglove [PORT]`, with
`foxglove-sdk`), both fed by a bag replay.

What goes out (`Publisher`):

- every replayed input message, on its own topic and type, at its record time;
- every derived event and subscription delivery whose term is a message of a known type
  (`geometry_msgs__0__PoseStamped(...)`, found from the functor and the number of
  arguments in the recording's type store, else in the standard store of its ROS version):
  that ROS message, CDR-encoded, on the subscription's topic for a delivery (the consumer
  name, with a leading `/` added: consumer `marker1` -> `/marker1`), on
  `/retalis/<pkg>/<Type>` otherwise;
- every other output (other derived events, retractions, answers of synchronized
  queries): a JSON message on `/retalis/events`: `{"event": TEXT, "start": S, "end": E,
  "name": FUNCTOR, "args": [...]}` (+ `"consumer"`, `"op"`, `"query"` when present), the
  arguments as JSON values (numbers, the text of atoms and strings, lists, and compounds as
  `{"name": ..., "args": [...]}`), so a plot panel can follow `args[0]`;
- each at its event time (the end of its interval) as log time.

Input events echoed by `--echo-input` are the input messages already written: they are not
written twice. In the MCAP file the JSON channel has no schema record: rosbags (0.11) cannot
open an MCAP file that holds a `jsonschema` schema, and MCAP allows JSON channels without one;
the JSON Schema is in the channel's metadata (`jsonschema`). The live server announces it as
the channel's schema.
"""
from __future__ import annotations

import json
import math
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Tuple

from . import require
from ..driver.values import String, Term, Value, is_atom, read_term, write_term
from .messages import ConversionError, Convention, MessageConverter, type_functor
from .wire import MessageWriter

EVENTS_TOPIC = "/retalis/events"
EVENT_SCHEMA = {
    "title": "retalis.Event",
    "description": "An output line of a Retalis program (derived event, delivery, retraction, query answer).",
    "type": "object",
    "properties": {
        "event": {"type": "string", "description": "the event term (writeq)"},
        "start": {"type": "number"}, "end": {"type": "number"},
        "name": {"type": "string", "description": "functor of the event"},
        "args": {"type": "array", "description": "arguments as JSON values"},
        "consumer": {"type": "string"}, "op": {"type": "string"},
        "query": {"type": "object", "description": "the answer of a synchronized query"},
    },
    "required": ["event", "start", "end"],
}


@dataclass(frozen=True)
class Message:
    """One message for a robot tool."""

    topic: str
    schema_name: str        # a ROS message type, or "retalis.Event"
    schema_encoding: str    # "ros2msg" or "jsonschema"
    schema: bytes
    encoding: str           # "cdr" or "json"
    data: bytes
    time_ns: int


class Publisher:
    """Input records and output events as messages (see the module docstring)."""

    def __init__(self, store, fallback_store=None, convention: Convention = Convention()):
        self.stores = [store] + ([fallback_store] if fallback_store is not None else [])
        self.converters = [MessageConverter(s, convention) for s in self.stores]
        self.writers = [MessageWriter(converter, "cdr") for converter in self.converters]
        self.convention = convention
        self._schemas: Dict[Tuple[int, str], bytes] = {}
        self._fed: Dict[float, List[Tuple[str, object]]] = {}

    # -- inputs --

    def input(self, topic: str, msgtype: str, time_ns: int, msg) -> Message:
        store = self.stores[0]
        return Message(topic, msgtype, "ros2msg", self._schema(0, msgtype), "cdr",
                       bytes(store.serialize_cdr(msg, msgtype)), time_ns)

    def advertisement(self, topic: str, msgtype: Optional[str]) -> Message:
        """A message without data that names the channel of `topic` (`msgtype` None: the JSON
        events channel), to advertise it before the first message."""
        if msgtype is None:
            return self._json({}, 0)
        return Message(topic, msgtype, "ros2msg", self._schema(0, msgtype), "cdr", b"", 0)

    def fed(self, events: List[Tuple[str, float]]) -> None:
        """The events of the batch just fed (to recognize their echo among the outputs)."""
        self._fed = {}
        for text, seconds in events:
            self._fed.setdefault(seconds, []).append((text, None))

    # -- outputs --

    def output(self, event) -> Optional[Message]:
        """The message of an OutputEvent, or None for the echo of a fed input."""
        if event.op == "answer":
            return self._json({"event": "", "start": event.start, "end": event.end, "query": event.query},
                              event.end)
        term = event.term                   # the runtime's data: nothing is read again
        if event.op == "add" and event.consumer is None and self._is_echo(event, term):
            return None
        if event.op == "add" and term is not None:
            for index, converter in enumerate(self.converters):
                msgtype = converter.message_type(term)
                if msgtype is None:
                    continue
                try:
                    data = self.writers[index].write(term, msgtype)
                except ConversionError:
                    break
                topic = _consumer_topic(event.consumer) if event.consumer else "/retalis/" + \
                    type_functor(msgtype).replace("__0__", "/")
                return Message(topic, msgtype, "ros2msg", self._schema(index, msgtype), "cdr", data,
                               _ns(event.end))
        payload = {"event": event.event, "start": event.start, "end": event.end}
        if isinstance(term, Term):
            payload["name"] = term.name
            payload["args"] = [_json_value(arg, self.convention) for arg in term.args]
        elif is_atom(term):
            payload["name"], payload["args"] = term, []
        if event.consumer is not None:
            payload["consumer"] = event.consumer
        if event.op != "add":
            payload["op"] = event.op
        return self._json(payload, event.end)

    def _is_echo(self, event, term) -> bool:
        if event.start != event.end or term is None:
            return False
        candidates = self._fed.get(event.start)
        if not candidates:
            return False
        for i, (text, parsed) in enumerate(candidates):
            if parsed is None:
                parsed = read_term(text)
                candidates[i] = (text, parsed)
            if parsed == term:
                del candidates[i]
                return True
        return False

    def _json(self, payload: dict, end) -> Message:
        return Message(EVENTS_TOPIC, "retalis.Event", "jsonschema", json.dumps(EVENT_SCHEMA).encode(), "json",
                       json.dumps(payload, allow_nan=False, default=str).encode(), _ns(end))

    def _schema(self, index: int, msgtype: str) -> bytes:
        key = (index, msgtype)
        schema = self._schemas.get(key)
        if schema is None:
            text, _ = self.stores[index].generate_msgdef(msgtype, ros_version=2)
            schema = self._schemas[key] = text.encode()
        return schema


def _consumer_topic(consumer: str) -> str:
    return consumer if consumer.startswith("/") else "/" + consumer


def _ns(seconds) -> int:
    if not isinstance(seconds, (int, float)) or not math.isfinite(seconds):
        return 0
    return max(0, round(seconds * 1e9))


def _json_value(term: Value, convention: Convention):
    if isinstance(term, bool):
        return term
    if isinstance(term, int):
        return term
    if isinstance(term, float):
        return term if math.isfinite(term) else str(term)
    if isinstance(term, String):
        return str(term)
    if is_atom(term):
        name = term
        if not convention.plain_strings and len(name) >= 2 and name[0] == '"' and name[-1] == '"':
            return name[1:-1]
        return name
    if isinstance(term, list):
        return [_json_value(item, convention) for item in term]
    if isinstance(term, Term):
        return {"name": term.name, "args": [_json_value(arg, convention) for arg in term.args]}
    return write_term(term)


# ---- sinks ---------------------------------------------------------------------------------

class McapSink:
    """Writes messages to an MCAP file (profile ros2)."""

    def __init__(self, path):
        writer_module = require("mcap.writer", "--out-bag")
        self.path = Path(path)
        self._stream = open(self.path, "wb")
        self._writer = writer_module.Writer(self._stream)
        self._writer.start(profile="ros2", library="retalisc")
        self._schemas: Dict[Tuple[str, str], int] = {}
        self._channels: Dict[Tuple[str, str], int] = {}
        self._sequence = 0
        self.count = 0

    def write(self, message: Message) -> None:
        key = (message.topic, message.schema_name)
        channel = self._channels.get(key)
        if channel is None:
            if message.encoding == "json":
                channel = self._writer.register_channel(
                    topic=message.topic, message_encoding="json", schema_id=0,
                    metadata={"jsonschema": message.schema.decode()})
            else:
                schema_key = (message.schema_name, message.schema_encoding)
                schema = self._schemas.get(schema_key)
                if schema is None:
                    schema = self._schemas[schema_key] = self._writer.register_schema(
                        name=message.schema_name, encoding=message.schema_encoding, data=message.schema)
                channel = self._writer.register_channel(topic=message.topic, message_encoding=message.encoding,
                                                        schema_id=schema)
            self._channels[key] = channel
        self._sequence += 1
        self._writer.add_message(channel, log_time=message.time_ns, data=message.data,
                                 publish_time=message.time_ns, sequence=self._sequence)
        self.count += 1

    def describe(self) -> str:
        return f"out-bag: {self.path}"

    def close(self) -> None:
        if self._stream is not None:
            self._writer.finish()
            self._stream.close()
            self._stream = None


class FoxgloveSink:
    """Serves messages live over Foxglove's WebSocket protocol (foxglove-sdk). A channel
    created while clients are connected waits up to `advertise_wait` seconds for them to
    subscribe, so its first message reaches them."""

    def __init__(self, port: int = 8765, host: str = "127.0.0.1", advertise_wait: float = 0.5):
        foxglove = require("foxglove", "--foxglove")
        self._foxglove = foxglove
        self.context = foxglove.Context()
        self._listener = _Listener()
        self.server = foxglove.start_server(name="retalisc", host=host, port=port, context=self.context,
                                            server_listener=self._listener)
        self.port = self.server.port
        self.host = host
        self.advertise_wait = advertise_wait
        self._channels: Dict[Tuple[str, str], object] = {}
        self.count = 0

    def channel(self, message: Message):
        key = (message.topic, message.schema_name)
        channel = self._channels.get(key)
        if channel is None:
            schema = self._foxglove.Schema(name=message.schema_name, encoding=message.schema_encoding,
                                           data=message.schema)
            channel = self._foxglove.Channel(message.topic, schema=schema, message_encoding=message.encoding,
                                             context=self.context)
            self._channels[key] = channel
            if self._listener.clients():
                self._listener.wait_subscribed(channel.id(), self.advertise_wait)
        return channel

    def advertise(self, message: Message) -> None:
        """Create the channel of `message` now (before the replay starts)."""
        self.channel(message)

    def wait_for_client(self, timeout: Optional[float] = None, settle: float = 0.5) -> bool:
        """Block until a client subscribes to a channel (then `settle` seconds more for its other
        subscriptions), or `timeout` seconds pass. Returns whether a client came."""
        came = self._listener.first.wait(timeout)
        if came:
            time.sleep(settle)
        return came

    def write(self, message: Message) -> None:
        self.channel(message).log(message.data, log_time=message.time_ns)
        self.count += 1

    def describe(self) -> str:
        return f"foxglove: ws://{self.host}:{self.port}"

    def close(self) -> None:
        for channel in self._channels.values():
            channel.close()
        self.server.stop()


class _Listener:
    """Foxglove server callbacks: who subscribed to what."""

    def __init__(self):
        self.first = threading.Event()
        self._lock = threading.Condition()
        self._subscribed: Dict[int, set] = {}     # channel id -> client ids

    def clients(self) -> bool:
        with self._lock:
            return any(self._subscribed.values())

    def wait_subscribed(self, channel_id: int, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        with self._lock:
            while not self._subscribed.get(channel_id):
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._lock.wait(left)
        return True

    def on_subscribe(self, client, channel) -> None:
        with self._lock:
            self._subscribed.setdefault(channel.id, set()).add(client.id)
            self._lock.notify_all()
        self.first.set()

    def on_unsubscribe(self, client, channel) -> None:
        with self._lock:
            self._subscribed.get(channel.id, set()).discard(client.id)
