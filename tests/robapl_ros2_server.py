"""The other side of tests/test_robapl_ros2.py: an independent rclpy process (run with
.venv-ros2's Python) serving what a RobAPL agent's ROS 2 actions call:

- /gripper, std_srvs/SetBool: success = data, message "closed" or "refused";
- /press, std_srvs/Trigger: answers after 0.3 s, message "pressed";
- /perform, robapl_interfaces/Perform (when its code is installed): runs 4 s in steps of 0.1 s
  with feedback, cancellable; the goal named `fail` is aborted.

It prints `ready` on standard error once everything is served, and one JSON object per line on
standard output for each request, goal, cancel and result it saw."""
from __future__ import annotations

import json
import sys
import threading
import time

import rclpy
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from std_srvs.srv import SetBool, Trigger

STEPS = 40
_lock = threading.Lock()


def say(**record) -> None:
    with _lock:
        print(json.dumps(record), flush=True)


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("robapl_test_server")
    group = ReentrantCallbackGroup()

    def gripper(request, response):
        say(service="gripper", data=request.data)
        response.success, response.message = request.data, "closed" if request.data else "refused"
        return response

    def press(request, response):
        say(service="press")
        time.sleep(0.3)
        response.success, response.message = True, "pressed"
        return response

    node.create_service(SetBool, "/gripper", gripper, callback_group=group)
    node.create_service(Trigger, "/press", press, callback_group=group)
    try:
        from robapl_interfaces.action import Perform
    except ImportError:
        Perform = None
    if Perform is not None:
        from rclpy.action import ActionServer, CancelResponse

        def execute(goal_handle):
            goal = goal_handle.request
            say(goal=goal.name, arguments=list(goal.arguments))
            if goal.name == "fail":
                goal_handle.abort()
                say(result=goal.name, status="aborted")
                return Perform.Result(success=False, result="it broke")
            for step in range(STEPS):
                if goal_handle.is_cancel_requested:
                    goal_handle.canceled()
                    say(result=goal.name, status="canceled", step=step)
                    return Perform.Result(success=False, result="canceled")
                goal_handle.publish_feedback(Perform.Feedback(progress=step / STEPS))
                time.sleep(0.1)
            goal_handle.succeed()
            say(result=goal.name, status="succeeded")
            return Perform.Result(success=True, result=f"{goal.name} done")

        def cancel(goal_handle):
            say(cancel=goal_handle.request.name)
            return CancelResponse.ACCEPT

        ActionServer(node, Perform, "/perform", execute, cancel_callback=cancel, callback_group=group)
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    print("ready" + ("" if Perform is not None else " (services only)"), file=sys.stderr, flush=True)
    try:
        executor.spin()
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass


if __name__ == "__main__":
    main()
