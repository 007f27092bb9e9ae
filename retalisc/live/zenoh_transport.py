"""`retalisc zenoh PROGRAM --config pub_sub.xml --listen ... --connect ...`: components
without a ROS master, over Zenoh (eclipse-zenoh).

Conventions: the key expression of ROS topic `/name` is `name` and a message is its ROS 2
CDR bytes, as the Zenoh bridge for ROS 2 (zenoh-plugin-ros2dds) maps DDS topics `rt/name` to
Zenoh keys, so a ROS 2 system behind that bridge and these components see each other's
topics. Each component is a Zenoh peer with multicast scouting off: it listens on the
endpoints given with --listen and connects to those given with --connect (tcp/127.0.0.1:PORT
on one machine), and keeps trying the ones that are not up, so a component that stops and
starts again is back in the graph without restarting the others.

A published sample carries its output number (node.py) as its attachment: 8 bytes, the
number unsigned little-endian (`int.from_bytes(sample.attachment.to_bytes(), "little")`).
"""
from __future__ import annotations

import json
import struct
from typing import Dict, List, Optional, Sequence

from ..robot_io import require
from .node import LiveNode, Transport


def zenoh_key(topic: str) -> str:
    """`/tf` -> `tf`, `/arm/pose` -> `arm/pose`."""
    return topic.strip("/")


def peer_config(listen: Sequence[str], connect: Sequence[str]):
    """A Zenoh peer configuration: explicit endpoints, no multicast scouting, connections
    retried for ever."""
    zenoh = require("zenoh", "retalisc zenoh")
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps("peer"))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    config.insert_json5("connect/timeout_ms", "-1")            # keep trying, also at start
    config.insert_json5("connect/exit_on_failure", "false")
    config.insert_json5("connect/retry", json.dumps({"period_init_ms": 200, "period_max_ms": 1000,
                                                      "period_increase_factor": 2}))
    return config


def seq_attachment(seq: int) -> bytes:
    """The attachment of a published sample: its output number, 8 bytes, unsigned little-endian."""
    return struct.pack("<Q", seq)


class ZenohTransport(Transport):
    wire = "cdr"
    name = "zenoh"
    attaches_seq = True
    flush_delivers = False       # no wait until the session handed over what was put

    def __init__(self, listen: Sequence[str] = (), connect: Sequence[str] = ()):
        self.zenoh = require("zenoh", "retalisc zenoh")
        self.listen: List[str] = list(listen)
        self.connect: List[str] = list(connect)
        self._subscribers: Dict[str, object] = {}
        self._publishers: Dict[str, object] = {}

    def start(self, node: LiveNode) -> None:
        self.node = node
        self.zenoh.init_log_from_env_or("error")
        self.session = self.zenoh.open(peer_config(self.listen, self.connect))

    def subscribe(self, topic: str, msgtype: str) -> None:
        node = self.node

        def arrived(sample) -> None:
            node.arrived(topic, sample.payload.to_bytes())

        self._subscribers[topic] = self.session.declare_subscriber(zenoh_key(topic), arrived)

    def unsubscribe(self, topic: str) -> bool:
        subscriber = self._subscribers.pop(topic, None)
        if subscriber is None:
            return False
        subscriber.undeclare()
        return True

    def advertise(self, topic: str, msgtype: str):
        publisher = self._publishers.get(topic)
        if publisher is None:
            publisher = self._publishers[topic] = self.session.declare_publisher(
                zenoh_key(topic), congestion_control=self.zenoh.CongestionControl.BLOCK)
        return publisher

    def publish(self, topic: str, msgtype: str, data: bytes, seq: Optional[int] = None) -> None:
        if seq is None:
            self.advertise(topic, msgtype).put(data)
        else:
            self.advertise(topic, msgtype).put(data, attachment=seq_attachment(seq))

    def subscriber_count(self, topic: str) -> int:
        publisher = self._publishers.get(topic)
        return 1 if publisher is not None and publisher.matching_status.matching else 0    # some, or none

    def close(self) -> None:
        for subscriber in self._subscribers.values():
            subscriber.undeclare()
        for publisher in self._publishers.values():
            publisher.undeclare()
        self._subscribers.clear()
        self._publishers.clear()
        self.session.close()
