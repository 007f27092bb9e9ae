"""The Retalis services (thesis A.1) as a ROS node serves them, whatever the ROS: a request
(an object with the request fields of ros1_services.SERVICES, from rospy or rclpy) goes to
the LiveNode's call of the same name (which runs it in the consumer thread, through the
Engine's API and its sandbox), and the Reply fills the response: `ok` and `error` always,
`id`, `found`/`answer` or `answers` when the request succeeded."""
from __future__ import annotations

from typing import Callable, Dict, Optional

from .node import LiveNode, Reply

# The request fields that ROS 2's interface package names differently: rosidl's C++ generator
# refuses C++ keywords as field names (ros/retalis_interfaces/srv/AddOutputSubscription.srv).
ROS2_FIELDS = {"template": "event_template"}


def dispatch(node: LiveNode, name: str, request, renamed: Optional[Dict[str, str]] = None) -> Reply:
    """Run the request of service `name` on `node`; `renamed`: field name -> the request's."""
    if name == "add_output_subscription":
        template = getattr(request, (renamed or {}).get("template", "template"))
        return node.add_output_subscription(request.topic, request.msg_type, request.event, request.conditions,
                                            template, request.start, request.end)
    if name == "delete_output_subscription":
        return node.delete_output_subscription(request.id, request.end)
    if name == "add_memory":
        return node.add_memory(request.memory)
    if name == "delete_memory":
        return node.delete_memory(request.id)
    if name == "add_input_subscription":
        return node.add_input_subscription(request.topic, request.msg_type)
    if name == "delete_input_subscription":
        return node.delete_input_subscription(request.topic)
    if name in ("query_one", "query_all"):
        return node.query(request.query, request.at, name == "query_all")
    return Reply(False, f"unknown service {name}")


def answer(node: LiveNode, name: str, request, response, substitution: Callable[..., object],
           renamed: Optional[Dict[str, str]] = None):
    """Serve `request` of service `name`: `response` filled from its Reply; `substitution`
    makes a Substitution message (variables=[...], values=[...])."""
    reply = dispatch(node, name, request, renamed)
    response.ok, response.error = reply.ok, reply.error
    if reply.ok and name == "add_output_subscription":
        response.id = str(reply.value)
    elif reply.ok and name == "query_one":
        response.found = reply.value is not None
        if reply.value is not None:
            response.answer = _substitution(substitution, reply.value)
    elif reply.ok and name == "query_all":
        response.answers = [_substitution(substitution, value) for value in reply.value]
    return response


def _substitution(make: Callable[..., object], answer: dict):
    return make(variables=list(answer), values=[answer[key] for key in answer])
