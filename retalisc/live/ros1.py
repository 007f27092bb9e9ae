"""`retalisc ros PROGRAM --config pub_sub.xml`: the live ROS 1 node (thesis 2.2, A.1).

rospy (Debian's ROS 1, python3-rospy) carries the bytes; the messages themselves are read
and written by rosbags, as in bag replay, so any message type works without its Python
package: a subscription takes whatever its publishers send (`rospy.AnyMsg`, the bytes and
the connection header with the type's full definition), and a publisher announces the type,
MD5 sum and definition rosbags computes for it (they match genpy's). The services are those
of ros1_services.py, under the node's private names (`/retalis/query_all` for node
`retalis`).
"""
from __future__ import annotations

import threading
import warnings
from typing import Dict

from .node import LiveNode, Transport
from .ros1_services import SERVICES, service_class, substitution_class
from .services import answer


class Ros1Transport(Transport):
    wire = "ros1"
    name = "ros"
    offers_services = True

    def __init__(self, node_name: str = "retalis", queue_size: int = 100000):
        import rospy    # optional: Debian's ROS 1, in .venv-ros

        self.rospy = rospy
        self.node_name = node_name
        self.queue_size = queue_size
        self._subscribers: Dict[str, object] = {}
        self._publishers: Dict[str, object] = {}
        self._classes: Dict[str, type] = {}
        self._services = []
        self._lock = threading.Lock()

    def start(self, node: LiveNode) -> None:
        self.node = node
        self.rospy.init_node(self.node_name, anonymous=False, disable_signals=True)
        for name in SERVICES:
            self._services.append(self.rospy.Service(f"~{name}", service_class(name), self._handler(name)))

    # ---- topics ------------------------------------------------------------------------------

    def subscribe(self, topic: str, msgtype: str) -> None:
        self._subscribers[topic] = self.rospy.Subscriber(
            topic, self.rospy.AnyMsg, self._arrived, callback_args=topic, queue_size=None, tcp_nodelay=True)

    def _arrived(self, msg, topic: str) -> None:
        header = getattr(msg, "_connection_header", None) or {}
        self.node.arrived(topic, msg._buff, header.get("type"), header.get("message_definition"))

    def unsubscribe(self, topic: str) -> bool:
        subscriber = self._subscribers.pop(topic, None)
        if subscriber is None:
            return False
        subscriber.unregister()
        return True

    def advertise(self, topic: str, msgtype: str):
        publisher = self._publishers.get(topic)
        if publisher is None or publisher.data_class._type != msgtype:
            if publisher is not None:
                publisher.unregister()
            with warnings.catch_warnings():      # rospy warns about queue_size=None (synchronous)
                warnings.simplefilter("ignore", SyntaxWarning)
                publisher = self._publishers[topic] = self.rospy.Publisher(
                    topic, self._raw_class(msgtype), queue_size=self.queue_size, tcp_nodelay=True)
        return publisher

    def publish(self, topic: str, msgtype: str, data: bytes) -> None:
        publisher = self.advertise(topic, msgtype)
        message = publisher.data_class()
        message._buff = data
        publisher.publish(message)

    def recoverable(self) -> None:
        """Publish synchronously: rospy's queued publisher writes from a thread of its own, and
        what is still in its queue when the process dies is lost although a snapshot taken
        after it counts it as published; without the queue, `publish` returns once the bytes
        are with the operating system (which sends them after a kill)."""
        self.queue_size = None

    def subscriber_count(self, topic: str) -> int:
        publisher = self._publishers.get(topic)
        return 0 if publisher is None else publisher.get_num_connections()

    def _raw_class(self, msgtype: str) -> type:
        cls = self._classes.get(msgtype)
        if cls is None:
            text, md5 = self.node.message_definition(msgtype)
            cls = self._classes[msgtype] = raw_message_class(msgtype, md5, text)
        return cls

    def close(self) -> None:
        for subscriber in self._subscribers.values():
            subscriber.unregister()
        for publisher in self._publishers.values():
            publisher.unregister()
        for service in self._services:
            service.shutdown()
        self.rospy.signal_shutdown("retalisc ros: closed")

    # ---- services ----------------------------------------------------------------------------

    def _handler(self, name: str):
        cls = service_class(name)
        node = self.node
        return lambda request: answer(node, name, request, cls._response_class(), substitution_class())


def raw_message_class(msgtype: str, md5: str, definition: str) -> type:
    """A rospy message class that sends bytes already serialized, announced as `msgtype`."""
    import rospy    # optional: Debian's ROS 1, in .venv-ros

    return type(msgtype.replace("/", "__"), (rospy.AnyMsg,),
                {"_type": msgtype, "_md5sum": md5, "_full_text": definition, "_has_header": False,
                 "__slots__": []})
