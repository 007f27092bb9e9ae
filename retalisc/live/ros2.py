"""`retalisc ros2 PROGRAM --config pub_sub.xml`: the live ROS 2 node on rclpy (thesis 2.2, A.1).

A real rclpy node (name and namespace from `--name`/`--namespace` or `--ros-args -r
__node:=... -r __ns:=...`), so the graph API, `ros2 node info` and the parameter services
see it. rclpy carries serialized CDR both ways (the input subscriptions' bytes, taken by a
reader thread of the transport's own, `Ros2Transport._read`; `Publisher.publish(bytes)`);
the runtime reads the messages into terms in C (robot_io/ros1_terms.py, `cdr=True`) and
rosbags writes them, as in bag replay. rclpy's executor, in another thread, serves the
services, the parameters, rclpy's /clock and the heartbeat's timer (`every`). rclpy 7 (Jazzy) has no dynamic types: the Python package of every
type the node subscribes or publishes must be importable (its generated code supplies the
type support), else the request is refused with an error naming the package and the node
goes on. A type that rosbags does not ship (ar_pose/ARMarkers, a user's own) is read with the
definition of its installed `.msg` file (message_definition).

The Retalis services (ros1_services.SERVICES) are served under the node's private names
(`/retalis/query_all`) with the types of the interface package `retalis_interfaces`
(ros/retalis_interfaces, built by setup.sh); services.answer runs each request through the
LiveNode exactly as on ROS 1.

QoS (pub_sub.xml, config.QosSpec): by default an input is read best effort (a best-effort
reader matches both reliable and best-effort publishers, ROS 2's QoS compatibility rules)
keeping the last INPUT_DEPTH messages; an output is published reliably (which reliable and
best-effort readers both accept) keeping the last OUTPUT_DEPTH; /tf_static both ways is
reliable and transient-local as tf2's static broadcaster and listener are, so a late joiner
gets what was published before it came.

Time: the node's clock is rclpy's (`use_sim_time` true: the last /clock message), which
stamps header-less messages and means `now` in requests. Parameters (PARAMETERS) say what
the node runs; they are read-only.
"""
from __future__ import annotations

import importlib
import re
import threading
from typing import Dict, List, Optional

from .config import QosSpec, ros1_type, store_type
from .node import LiveNode, Transport
from .ros1_services import SERVICES
from .services import ROS2_FIELDS, answer

INTERFACES = "retalis_interfaces"
INPUT_DEPTH = 1000
OUTPUT_DEPTH = 1000
STATIC_TOPICS = ("/tf_static",)
STATIC_DEPTH = 100
# the read-only parameters the node declares (launch files set them through the command line)
PARAMETERS = ("program", "config", "name", "max_delay", "state_dir")


class MissingType(Exception):
    """A message or service type whose generated Python code is not installed."""


def message_class(msgtype: str) -> type:
    """The rclpy message class of `pkg/Type`, or MissingType naming the package to install."""
    package, name = ros1_type(msgtype).split("/")
    try:
        module = importlib.import_module(f"{package}.msg")
    except ModuleNotFoundError:
        raise MissingType(f"no ROS 2 package {package} with the generated code of {package}/msg/{name}: "
                          f"install it (apt ros-<distro>-{package.replace('_', '-')}) or build its .msg files "
                          f"with colcon and source the workspace (docs/ros.md)") from None
    cls = getattr(module, name, None)
    if cls is None:
        raise MissingType(f"the ROS 2 package {package} has no message {name}")
    return cls


_BUILTIN = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
            "uint32", "int64", "uint64", "string", "wstring"}
_SEPARATOR = "\n" + "=" * 80 + "\n"


def message_definition(msgtype: str, known) -> str:
    """The definition of `pkg/Type` from its installed `.msg` file (`share/pkg/msg/Type.msg`,
    found through the ament index, as `ros2 interface show` finds it), followed, in the format
    of ROS 1 bags, by those of the types it uses that `known` (a rosbags store's fielddefs)
    lacks: what a LiveNode needs to read a type rosbags does not ship. MissingType when a
    `.msg` file is not installed."""
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    texts: Dict[str, str] = {}
    pending = [ros1_type(msgtype)]
    while pending:
        name = pending.pop()
        package, type_name = name.split("/")
        try:
            path = f"{get_package_share_directory(package)}/msg/{type_name}.msg"
            text = open(path, encoding="utf-8").read()
        except (PackageNotFoundError, OSError):
            raise MissingType(f"no definition of {package}/msg/{type_name} installed (share/{package}/msg/"
                              f"{type_name}.msg): install or build the package and source it") from None
        texts[name] = text
        for line in text.splitlines():
            words = line.split("#")[0].split()
            if len(words) < 2 or "=" in words[1]:
                continue
            field = re.sub(r"\[.*\]$", "", words[0]).split("<=")[0]
            if field in _BUILTIN:
                continue
            used = field if "/" in field else f"{package}/{field}"
            if used not in texts and used not in pending and f"{used.split('/')[0]}/msg/{used.split('/')[1]}" not in known:
                pending.append(used)
    first = ros1_type(msgtype)
    return texts[first] + "".join(f"{_SEPARATOR}MSG: {name}\n{text}" for name, text in texts.items() if name != first)


def service_classes() -> Dict[str, type]:
    """service name -> the rclpy service class of retalis_interfaces."""
    try:
        module = importlib.import_module(f"{INTERFACES}.srv")
    except ModuleNotFoundError:
        raise MissingType(f"no ROS 2 package {INTERFACES} (the Retalis services): build ros/{INTERFACES} "
                          f"with colcon and source the workspace, or run `bash setup.sh` (docs/ros.md)") from None
    return {name: getattr(module, type_name) for name, (type_name, _) in SERVICES.items()}


def qos_profile(spec: Optional[QosSpec], topic: str, subscriber: bool):
    """The rclpy QoSProfile of a topic: pub_sub.xml's profile and policies over the defaults."""
    from rclpy import qos

    if spec is not None and spec.profile is not None:
        profile = {"sensor_data": qos.qos_profile_sensor_data, "default": qos.qos_profile_system_default,
                   "services_default": qos.qos_profile_services_default,
                   "parameters": qos.qos_profile_parameters}[spec.profile]
        profile = qos.QoSProfile(history=profile.history, depth=profile.depth, reliability=profile.reliability,
                                 durability=profile.durability)
    elif topic in STATIC_TOPICS:
        profile = qos.QoSProfile(depth=STATIC_DEPTH, reliability=qos.ReliabilityPolicy.RELIABLE,
                                 durability=qos.DurabilityPolicy.TRANSIENT_LOCAL)
    elif subscriber:
        profile = qos.QoSProfile(depth=INPUT_DEPTH, reliability=qos.ReliabilityPolicy.BEST_EFFORT,
                                 durability=qos.DurabilityPolicy.VOLATILE)
    else:
        profile = qos.QoSProfile(depth=OUTPUT_DEPTH, reliability=qos.ReliabilityPolicy.RELIABLE,
                                 durability=qos.DurabilityPolicy.VOLATILE)
    if spec is not None:
        if spec.reliability is not None:
            profile.reliability = (qos.ReliabilityPolicy.RELIABLE if spec.reliability == "reliable"
                                   else qos.ReliabilityPolicy.BEST_EFFORT)
        if spec.durability is not None:
            profile.durability = (qos.DurabilityPolicy.TRANSIENT_LOCAL if spec.durability == "transient_local"
                                  else qos.DurabilityPolicy.VOLATILE)
        if spec.history == "keep_all":
            profile.history = qos.HistoryPolicy.KEEP_ALL
        elif spec.depth is not None or spec.history == "keep_last":
            profile.history = qos.HistoryPolicy.KEEP_LAST
            profile.depth = spec.depth or profile.depth
    return profile


def _own_reader_group():
    """A callback group (rclpy's, imported here: rclpy is optional) that no executor runs."""
    from rclpy.callback_groups import CallbackGroup

    class OwnReader(CallbackGroup):
        """The callback group of the input subscriptions: no executor ever waits on them or
        runs them (Ros2Transport._read does)."""

        def can_execute(self, entity) -> bool:
            return False

        def beginning_execution(self, entity) -> bool:
            return False

        def ending_execution(self, entity) -> None:
            pass

    return OwnReader()


def _run_event(handler) -> None:
    """Take a ready QoS event of an input subscription and run its callback (rclpy's default
    ones log a warning), in the reader thread."""
    taken = handler.take_data()
    if taken:
        handler.callback(taken)


class Ros2Transport(Transport):
    wire = "cdr"
    name = "ros2"

    def __init__(self, node_name: str = "retalis", namespace: str = "", ros_args: List[str] = (),
                 parameters: Optional[Dict[str, str]] = None, domain: Optional[int] = None):
        import os

        import rclpy

        self.rclpy = rclpy
        self.node_name = node_name
        self.namespace = namespace
        self.ros_args = list(ros_args)
        self.parameters = dict(parameters or {})
        self.domain = int(os.environ.get("ROS_DOMAIN_ID") or 0) if domain is None else domain
        self._subscriptions: Dict[str, tuple] = {}     # topic -> (subscription, definition), read by _read
        self._retired: List[object] = []                 # subscriptions for _read to destroy
        self._lock = threading.Lock()
        self._closing = False
        self._publishers: Dict[str, tuple] = {}
        self._matched: Dict[str, int] = {}              # topic -> its subscribers, from matched events
        self._thread: Optional[threading.Thread] = None
        self._reader: Optional[threading.Thread] = None
        self.context = None

    def start(self, node: LiveNode) -> None:
        from rclpy.executors import SingleThreadedExecutor
        from rcl_interfaces.msg import ParameterDescriptor

        self.node = node
        self.services = service_classes()       # before the node: a missing package is an error at start
        self.context = self.rclpy.Context()
        self.rclpy.init(args=["retalisc"] + self.ros_args, context=self.context, domain_id=self.domain)
        self.ros = self.rclpy.create_node(self.node_name, namespace=self.namespace or None, context=self.context,
                                          start_parameter_services=True)
        self.parameters["name"] = self.ros.get_name()       # as remapped by --ros-args -r __node:=
        for key in PARAMETERS:
            self.ros.declare_parameter(key, self.parameters.get(key, ""),
                                       ParameterDescriptor(read_only=True, description=f"retalisc ros2: {key}"))
        self.clock = self.ros.get_clock()
        self._served = [self.ros.create_service(cls, f"~/{name}", self._handler(name))
                        for name, cls in self.services.items()]
        # Services, parameters and rclpy's /clock (use_sim_time) in an executor's thread; the
        # input topics in a reader thread of their own (_read), out of the executor's sight
        # (their callback group never lets it run them, _own_reader_group).
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.ros)
        self._thread = threading.Thread(target=self._spin, name="retalis-rclpy", daemon=True)
        self._thread.start()
        from rclpy.guard_condition import GuardCondition

        self._group = _own_reader_group()
        self._wake = GuardCondition(None, None, context=self.context)
        self._reader = threading.Thread(target=self._read, name="retalis-ros2-reader", daemon=True)
        self._reader.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:        # the context was shut down (close)
            if self.context.ok():
                raise

    def _read(self) -> None:
        """The reader thread: wait (without the GIL) until an input subscription has data, then
        take every message waiting in each, one from each subscription in turn, and hand the
        bytes to the LiveNode. rclpy's executor costs about 300 us of Python per message
        (it builds its wait set and a task for each callback), which at the thesis's load took
        a fifth of a core and kept the GIL from the consumer thread; this loop costs a few
        tens of microseconds a message and takes a burst in one wake-up (docs/ros.md,
        Performance). Subscriptions are added and destroyed here, between two waits
        (`subscribe` and `unsubscribe` wake it)."""
        from contextlib import ExitStack

        from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

        arrived = self.node.arrived
        wait_set, size = None, None
        while not self._closing:
            with self._lock:
                for subscription in self._retired:
                    self.ros.destroy_subscription(subscription)
                self._retired.clear()
                readers = list(self._subscriptions.items())
            events = [handler for _, (subscription, _) in readers for handler in subscription.event_handlers]
            with ExitStack() as held:          # the handles stay valid while they are waited on
                held.enter_context(self.context.handle)
                for _, (subscription, _) in readers:
                    held.enter_context(subscription.handle)
                for handler in events:
                    held.enter_context(handler)
                held.enter_context(self._wake.handle)
                if size != (len(readers), len(events)):
                    size = (len(readers), len(events))
                    wait_set = _rclpy.WaitSet(len(readers), 1, 0, 0, 0, len(events), self.context.handle)
                wait_set.clear_entities()
                for _, (subscription, _) in readers:
                    wait_set.add_subscription(subscription.handle)
                for handler in events:
                    handler.add_to_wait_set(wait_set)
                wait_set.add_guard_condition(self._wake.handle)
                wait_set.wait(-1)
                for handler in events:
                    if handler.is_ready(wait_set):
                        _run_event(handler)
                ready = wait_set.get_ready_entities("subscription")
                pending = [(topic, subscription.handle, subscription.msg_type, definition)
                           for topic, (subscription, definition) in readers if subscription.handle.pointer in ready]
                while pending and not self._closing:
                    left = []
                    for topic, handle, cls, definition in pending:
                        taken = handle.take_message(cls, True)
                        if taken is not None:
                            arrived(topic, taken[0], None, definition)
                            left.append((topic, handle, cls, definition))
                    pending = left

    @property
    def fully_qualified_name(self) -> str:
        return self.ros.get_fully_qualified_name()

    def now_ns(self) -> int:
        return self.clock.now().nanoseconds

    # ---- topics ------------------------------------------------------------------------------

    def subscribe(self, topic: str, msgtype: str) -> None:
        cls = message_class(msgtype)
        # a type rosbags does not know: its definition from the installed package, with each message
        definition = (None if store_type(msgtype) in self.node.store.fielddefs
                      else message_definition(msgtype, self.node.store.fielddefs))
        profile = qos_profile(self.node.config.qos(topic, True), topic, True)
        # the callback is never called (_own_reader_group): _read takes the bytes itself
        # and its QoS events (incompatible QoS: a warning) are _read's too (_run_event)
        subscription = self.ros.create_subscription(cls, topic, lambda data: None, profile, raw=True,
                                                    callback_group=self._group)
        with self._lock:
            self._subscriptions[topic] = (subscription, definition)
        self._wake.trigger()

    def unsubscribe(self, topic: str) -> bool:
        with self._lock:
            entry = self._subscriptions.pop(topic, None)
            if entry is None:
                return False
            self._retired.append(entry[0])
        self._wake.trigger()
        return True

    def advertise(self, topic: str, msgtype: str):
        entry = self._publishers.get(topic)
        if entry is None or entry[0] != msgtype:
            if entry is not None:
                self.ros.destroy_publisher(entry[1])
            profile = qos_profile(self.node.config.qos(topic, False), topic, False)
            entry = self._publishers[topic] = (msgtype, self._create_publisher(topic, msgtype, profile))
        return entry[1]

    def _create_publisher(self, topic: str, msgtype: str, profile):
        """An rclpy publisher whose subscriber count `subscriber_count` keeps from its matched
        events (run by the executor's thread when the graph changes): asking rmw for the count
        with every message cost a graph query per output. Without matched events (an rmw
        that has none), the count is asked each time."""
        from rclpy.event_handler import PublisherEventCallbacks

        def matched(status, topic=topic) -> None:
            self._matched[topic] = status.current_count

        self._matched.pop(topic, None)
        try:
            publisher = self.ros.create_publisher(message_class(msgtype), topic, profile,
                                                  event_callbacks=PublisherEventCallbacks(matched=matched))
        except Exception:        # UnsupportedEventTypeError: no matched events from this rmw
            return self.ros.create_publisher(message_class(msgtype), topic, profile)
        self._matched.setdefault(topic, publisher.get_subscription_count())
        return publisher

    def publish(self, topic: str, msgtype: str, data: bytes) -> None:
        self.advertise(topic, msgtype).publish(data)

    def flush(self, timeout: float) -> None:
        """Wait (in all at most `timeout` s) until the reliable readers acknowledged what was
        published."""
        import time

        from rclpy.duration import Duration

        deadline = time.monotonic() + timeout
        for _, publisher in list(self._publishers.values()):
            left = deadline - time.monotonic()
            if left <= 0:
                break
            publisher.wait_for_all_acked(Duration(nanoseconds=int(left * 1e9)))

    def every(self, seconds: float, callback) -> bool:
        """An rclpy timer on the node's clock (ROS time: /clock under use_sim_time, so a paused
        simulation pauses the heartbeat), run by the executor's thread."""
        self._timers = getattr(self, "_timers", []) + [self.ros.create_timer(seconds, callback)]
        return True

    def subscriber_count(self, topic: str) -> int:
        entry = self._publishers.get(topic)
        if entry is None:
            return 0
        count = self._matched.get(topic)
        return entry[1].get_subscription_count() if count is None else count

    def close(self) -> None:
        if self.context is None:
            return
        self._closing = True
        if self._reader is not None:
            self._wake.trigger()
            self._reader.join(2)
        self.executor.shutdown(timeout_sec=2)
        self.ros.destroy_node()
        self.rclpy.try_shutdown(context=self.context)
        if self._thread is not None:
            self._thread.join(2)

    # ---- services ----------------------------------------------------------------------------

    def _handler(self, name: str):
        from retalis_interfaces.msg import Substitution

        node = self.node
        return lambda request, response: answer(node, name, request, response, Substitution, ROS2_FIELDS)
