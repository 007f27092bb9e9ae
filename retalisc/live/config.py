"""The `pub_sub.xml` configuration of a live component (thesis 2.2, Listing 2.2; A.2.2).

    <?xml version="1.0"?>
    <publish_subscribe>
      <subscribe_to name="/ar_pose_marker" msg_type="ar_pose/ARMarkers"/>
      <publish_to   name="robot_marker_pos" msg_type="geometry_msgs/Transform"/>
    </publish_subscribe>

`subscribe_to` subscribes the component to a topic: its messages become events.
`publish_to` gives the message type of a topic the component may publish subscription
deliveries on (consumer `robot_marker_pos` of a subscription -> topic `/robot_marker_pos`).
On ROS 2 (`retalisc ros2`) either element may also give the topic's quality of service: a
named profile `qos="sensor_data"` (or default, services_default, parameters) and/or the
policies `reliability="reliable|best_effort"`, `durability="volatile|transient_local"`,
`history="keep_last|keep_all"`, `depth="N"` (keep the last N), which override the profile's (QosSpec; ros2.py has the
defaults).
The file of Listing 2.2 is accepted as printed: its declaration `<?XML version="1.0"?>`
(upper case, which XML parsers refuse) is read as the ordinary one, and spaces around the
`/` of a type name are ignored. A document type declaration or entity is refused (the file
is read as data).
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional


class ConfigError(Exception):
    """A configuration that cannot be read; the message starts with `FILE:` (and the line)."""


QOS_PROFILES = ("sensor_data", "default", "services_default", "parameters")
RELIABILITY = ("reliable", "best_effort")
DURABILITY = ("volatile", "transient_local")
HISTORY = ("keep_last", "keep_all")


@dataclass(frozen=True)
class QosSpec:
    """A topic's quality of service as pub_sub.xml gives it; None: not given."""

    profile: Optional[str] = None
    reliability: Optional[str] = None
    durability: Optional[str] = None
    depth: Optional[int] = None
    history: Optional[str] = None


@dataclass(frozen=True)
class TopicSpec:
    name: str       # resolved: a leading "/" added to relative names
    msgtype: str    # ROS 1 spelling: pkg/Type
    qos: Optional[QosSpec] = None


@dataclass
class PubSubConfig:
    subscribe: List[TopicSpec] = field(default_factory=list)
    publish: List[TopicSpec] = field(default_factory=list)

    def qos(self, topic: str, subscriber: bool) -> Optional[QosSpec]:
        """The QoS pub_sub.xml gives the subscription (or the publisher) of `topic`."""
        for spec in self.subscribe if subscriber else self.publish:
            if spec.name == topic:
                return spec.qos
        return None

    def publish_type(self, topic: str) -> Optional[str]:
        for spec in self.publish:
            if spec.name == topic:
                return spec.msgtype
        return None


_DECLARATION = re.compile(r"\A(\ufeff)?\s*<\?xml\b[^>]*\?>", re.IGNORECASE)
_TYPE = re.compile(r"\A[A-Za-z][A-Za-z0-9_]*(/msg)?/[A-Za-z][A-Za-z0-9_]*\Z")


def resolve_topic(name: str) -> str:
    """A topic name as published: relative names are resolved in the root namespace."""
    name = name.strip()
    return name if name.startswith("/") else "/" + name


def ros1_type(msgtype: str) -> str:
    """`pkg/Type` (ROS 1 spelling) of `pkg/Type`, `pkg/msg/Type` or ` pkg / Type `; ValueError
    for anything else."""
    text = re.sub(r"\s+", "", msgtype)
    if not _TYPE.match(text):
        raise ValueError(f"{msgtype!r} is not a message type (pkg/Type)")
    parts = text.split("/")
    return f"{parts[0]}/{parts[-1]}"


def store_type(msgtype: str) -> str:
    """The rosbags spelling `pkg/msg/Type`."""
    package, name = ros1_type(msgtype).split("/")
    return f"{package}/msg/{name}"


def parse_config(text: str, name: str = "pub_sub.xml") -> PubSubConfig:
    match = _DECLARATION.match(text)
    if match:       # keep the positions of what follows (errors give line and column)
        text = re.sub(r"[^\n]", " ", match.group(0)) + text[match.end():]
    if re.search(r"<!(DOCTYPE|ENTITY)", text, re.IGNORECASE):
        raise ConfigError(f"{name}: a document type declaration is not allowed in a configuration")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as error:
        line, column = error.position
        raise ConfigError(f"{name}:{line}:{column + 1}: not well-formed XML") from None
    if root.tag != "publish_subscribe":
        raise ConfigError(f"{name}: the root element is <{root.tag}>, expected <publish_subscribe>")
    config = PubSubConfig()
    for element in root:
        if element.tag not in ("subscribe_to", "publish_to"):
            raise ConfigError(f"{name}: unknown element <{element.tag}> (expected <subscribe_to> or <publish_to>)")
        topic, msgtype = element.get("name"), element.get("msg_type")
        if not topic or not topic.strip() or msgtype is None:
            raise ConfigError(f"{name}: <{element.tag}> needs the attributes name and msg_type")
        try:
            spec = TopicSpec(resolve_topic(topic), ros1_type(msgtype), _qos(element))
        except ValueError as error:
            raise ConfigError(f"{name}: <{element.tag} name={topic!r}>: {error}") from None
        (config.subscribe if element.tag == "subscribe_to" else config.publish).append(spec)
    return config


def _qos(element) -> Optional[QosSpec]:
    """The QoS attributes of a <subscribe_to>/<publish_to>; ValueError for a bad value."""
    values = {key: element.get(key) for key in ("qos", "reliability", "durability", "depth", "history")}
    if all(value is None for value in values.values()):
        return None
    for key, allowed in (("qos", QOS_PROFILES), ("reliability", RELIABILITY), ("durability", DURABILITY),
                         ("history", HISTORY)):
        if values[key] is not None and values[key] not in allowed:
            raise ValueError(f"{key}={values[key]!r} is not one of {', '.join(allowed)}")
    depth = values["depth"]
    if depth is not None:
        if not re.fullmatch(r"[0-9]{1,9}", depth) or int(depth) < 1:
            raise ValueError(f"depth={depth!r} is not a whole number of messages from 1 to 999999999")
        depth = int(depth)
    if depth is not None and values["history"] == "keep_all":
        raise ValueError("depth is the number of messages a keep_last history keeps: not with history=\"keep_all\"")
    return QosSpec(values["qos"], values["reliability"], values["durability"], depth, values["history"])


def load_config(path) -> PubSubConfig:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise ConfigError(f"{path}: cannot read: {error}") from None
    return parse_config(text, str(path))
