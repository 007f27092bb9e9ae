"""The service types of the live ROS 1 node (thesis A.1), built at runtime with genpy.

The 2015 release defined its services in its catkin package; Debian's ROS has no such
package and retalisc is not built with catkin, so the `.srv` texts below (package `retalis`)
are turned into rospy service classes the way rosbag builds message classes from the
definitions in a bag: `genpy.dynamic.generate_dynamic` makes the request and response
classes, genmsg computes the service's MD5 sum. A catkin package holding the same `.srv`
files (docs/ros.md lists them) gives C++ and Python clients the same types, MD5 included.

    from retalisc.live.ros1_services import service_class
    query_all = rospy.ServiceProxy("/retalis/query_all", service_class("query_all"))
    reply = query_all(query="mem(head_cam, tf(V, Q))", at="")

Every reply carries `ok` and `error`: a request that is refused (does not parse, fails the
sandbox, names an unknown memory...) is answered with `ok` False and the reason.
"""
from __future__ import annotations

from typing import Dict, Tuple

PACKAGE = "retalis"

MESSAGES = {
    "Substitution": "string[] variables\nstring[] values\n",
}

# service name -> (type name, .srv text)
SERVICES: Dict[str, Tuple[str, str]] = {
    "add_output_subscription": ("AddOutputSubscription",
                                "string topic\nstring msg_type\nstring event\nstring conditions\n"
                                "string template\nstring start\nstring end\n"
                                "---\nbool ok\nstring error\nstring id\n"),
    "delete_output_subscription": ("DeleteOutputSubscription",
                                   "string id\nstring end\n---\nbool ok\nstring error\n"),
    "add_memory": ("AddMemory", "string memory\n---\nbool ok\nstring error\n"),
    "delete_memory": ("DeleteMemory", "string id\n---\nbool ok\nstring error\n"),
    "add_input_subscription": ("AddInputSubscription",
                               "string topic\nstring msg_type\n---\nbool ok\nstring error\n"),
    "delete_input_subscription": ("DeleteInputSubscription", "string topic\n---\nbool ok\nstring error\n"),
    "query_one": ("QueryOne", "string query\nstring at\n---\nbool ok\nstring error\nbool found\n"
                              f"{PACKAGE}/Substitution answer\n"),
    "query_all": ("QueryAll", "string query\nstring at\n---\nbool ok\nstring error\n"
                              f"{PACKAGE}/Substitution[] answers\n"),
}

_SEPARATOR = "\n" + "=" * 80 + "\n"
_classes: Dict[str, type] = {}


def _catalog(text: str) -> str:
    """A definition followed by the definitions it uses, in the format of ROS 1 bags."""
    for name, definition in MESSAGES.items():
        if f"{PACKAGE}/{name}" in text:
            text += f"{_SEPARATOR}MSG: {PACKAGE}/{name}\n{definition}"
    return text


def service_class(service: str) -> type:
    """The rospy service class of one of SERVICES (by service name or type name)."""
    for name, (type_name, _) in SERVICES.items():
        if service in (name, type_name):
            break
    else:
        raise KeyError(f"no service {service!r} (known: {', '.join(SERVICES)})")
    if name in _classes:
        return _classes[name]
    import genmsg   # optional: Debian's ROS 1 (with genpy), in .venv-ros
    import genmsg.msg_loader as loader
    from genpy.dynamic import generate_dynamic

    type_name, text = SERVICES[name]
    full = f"{PACKAGE}/{type_name}"
    context = genmsg.MsgContext.create_default()
    for message, definition in MESSAGES.items():
        context.register(f"{PACKAGE}/{message}",
                         loader.load_msg_from_string(context, definition, f"{PACKAGE}/{message}"))
    spec = loader.load_srv_from_string(context, text, full)
    loader.load_depends(context, spec, {})
    md5 = genmsg.compute_md5(context, spec)
    request_text, response_text = text.split("---\n")
    request = generate_dynamic(full + "Request", _catalog(request_text))[full + "Request"]
    response = generate_dynamic(full + "Response", _catalog(response_text))[full + "Response"]
    cls = type(type_name, (object,), {"_type": full, "_md5sum": md5, "_request_class": request,
                                      "_response_class": response})
    _classes[name] = cls
    return cls


def substitution_class() -> type:
    """The class of `retalis/Substitution` used by query replies."""
    return type(service_class("query_one")._response_class().answer)
