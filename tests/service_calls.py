"""The part of the live services tests that is the same on ROS 1 and ROS 2 (tests/ros1_client.py,
tests/ros2_client.py): waiting for a condition, and queries and memories through the node's
services, called with the clients of either ROS (`query_one(query=..., at=...)` and so on)."""
from __future__ import annotations

import time
from typing import Callable


def wait_for(condition, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


def pair(reply) -> list:
    return [reply.ok, reply.error]


def queries_and_memories(result: dict, query_one, query_all, add_mem, del_mem, forbidden: str,
                         three_more: Callable[[], None]) -> None:
    """Fill `result` with the replies; `three_more` publishes three more tf messages and waits
    for their deliveries (between the creation of memory last2 and its query)."""
    answers = query_all(query="mem(tfs, tf(P, C, V))", at="")
    result["query_all"] = [answers.ok, [dict(zip(a.variables, a.values)) for a in answers.answers]]
    one = query_one(query="mem(tfs, tf(P, C, V)^T)", at="102")
    result["query_one"] = [one.ok, one.found, dict(zip(one.answer.variables, one.answer.values))]
    none = query_one(query="mem(tfs, tf(nobody, C, V))", at="")
    result["query_none"] = [none.ok, none.found]
    result["unsafe"] = pair(query_all(query=f"shell('touch {forbidden}')", at=""))
    result["unsafe_one"] = pair(query_one(query=f"open('{forbidden}', write, S)", at=""))
    result["syntax"] = pair(query_all(query="mem(tfs, ", at=""))
    result["add_memory"] = pair(add_mem(memory="c_mem(last2, tf(P, C, V)-[], 2, inf)"))
    result["add_memory_unsafe"] = pair(add_mem(memory="c_mem(bad, tf(P, C, V)-[shell(ls)], 2, inf)"))
    result["add_memory_not_create"] = pair(add_mem(memory="d_mem(tfs)"))
    three_more()
    last2 = query_all(query="mem(last2, tf(_, _, geometry_msgs__0__Vector3(X, _, _)))", at="")
    result["last2"] = sorted(float(a.values[0]) for a in last2.answers)
    result["delete_memory"] = pair(del_mem(id="last2"))
    result["delete_memory_bad"] = pair(del_mem(id="f(X"))
    result["after_delete_memory"] = len(query_all(query="mem(last2, _)", at="").answers)
