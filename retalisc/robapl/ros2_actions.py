"""External actions of a RobAPL agent as ROS 2 service calls and ROS 2 actions, through rclpy
(thesis 7.2.3: an external action has a result; a long action's result comes later as an event).

In an actions file (`retalisc robapl run ... --actions FILE.py`):

    from retalisc.robapl.ros2_actions import Ros2Actions

    def register(actions):
        ros2 = Ros2Actions(actions, node_name="nao_agent")
        ros2.service("close_gripper", "/gripper", "std_srvs/srv/SetBool")
        ros2.action("move_to", "/perform", "robapl_interfaces/action/Perform")

Each registers an external action by name, as `Actions.register` does for a Python callable.
When its node executes, the request (or goal) is sent and the node waits: the response (or the
action's result) becomes the event `action_result(Handle, Value)`, a failure (`success` false,
a rejected or aborted goal, no server, no answer within `timeout` seconds) the event
`action_failed(Handle, Reason)`. An aborted node (its plan fails, pauses or is pre-empted)
cancels its goal; a service request cannot be withdrawn, its late answer is dropped.

Time: while a ROS 2 call is outstanding the agent's clock runs with the wall clock from the
call's time (`ResultInbox`): an event of the event base later than now waits until its time
comes or a result arrives first, and a result is stamped with the agent time of its arrival.
When nothing is outstanding the clock jumps to the next event, as without ROS 2.

Requests, goals and results (the defaults; `request=`, `goal=` and `result=` replace them):
the action's arguments fill the request's fields in their declared order (an atom `true` or
`false` for a boolean field, a number for a numeric one, text for a string); a Perform goal
(robapl_interfaces, ros/robapl_interfaces) gets the action's name and its arguments as text.
A response or result with a false `success` field fails with its `message` (or `result`); else
its value is its one field besides `success`, or all its fields as `type(Field, ...)`.
"""
from __future__ import annotations

import atexit
import importlib
import threading
import time as _time
from typing import Callable, Dict, List, Optional, Tuple

from .executor import PENDING, Actions, ActionFailed, term_value
from .terms import Compound, Term

DEFAULT_TIMEOUT = 30.0


class MissingRclpy(Exception):
    """This Python has no rclpy (ROS 2's Python client)."""


def interface_class(type_name: str):
    """The rclpy class of `pkg/srv/Type` or `pkg/action/Type` (its generated code must be installed)."""
    parts = type_name.split("/")
    if len(parts) != 3 or parts[1] not in ("srv", "action"):
        raise ValueError(f"a ROS 2 interface type is pkg/srv/Type or pkg/action/Type, not {type_name!r}")
    package, kind, name = parts
    try:
        return getattr(importlib.import_module(f"{package}.{kind}"), name)
    except (ImportError, AttributeError):
        raise ValueError(f"no generated code for the ROS 2 type {type_name}: build or install the "
                         f"package {package} (ros/setup_ros2.sh builds robapl_interfaces)") from None


def fill_message(cls, values: tuple):
    """A message of `cls` whose fields, in their declared order, take `values`."""
    fields = list(cls.get_fields_and_field_types().items())
    if len(values) > len(fields):
        raise ActionFailed(f"{cls.__name__} has {len(fields)} fields, the action gave {len(values)} arguments")
    message = cls()
    for (field, kind), value in zip(fields, values):
        setattr(message, field, _field_value(kind, value))
    return message


def _field_value(kind: str, value):
    if kind == "boolean":
        if isinstance(value, bool) or value in ("true", "false"):
            return value if isinstance(value, bool) else value == "true"
        raise ActionFailed(f"a boolean field wants true or false, not {value!r}")
    if kind in ("float", "double"):
        return float(value)
    if kind.startswith(("int", "uint", "octet", "byte")):
        return int(value)
    if kind == "string":
        return value if isinstance(value, str) else str(value)
    if kind.startswith("sequence<string"):
        return [str(v) for v in (value if isinstance(value, (list, tuple)) else [value])]
    return value


def message_value(message) -> Tuple[bool, Term]:
    """(succeeded, value) of a response or action result, by the defaults of the module's doc."""
    fields = list(message.get_fields_and_field_types())
    if "success" in fields and not message.success:
        reason = next((getattr(message, f) for f in ("message", "result") if f in fields), "") or "failed"
        return False, str(reason)
    rest = [f for f in fields if f != "success"]
    if len(rest) == 1:
        return True, _term(getattr(message, rest[0]))
    name = type(message).__name__.lower().removesuffix("_response").removesuffix("_result") or "response"
    return True, Compound(name, tuple(_term(getattr(message, f)) for f in rest)) if rest else term_value(True)


def _term(value) -> Term:
    if isinstance(value, (bool, int, float, str)):
        return term_value(value)
    if isinstance(value, (list, tuple)):
        return Compound("list", tuple(_term(v) for v in value)) if value else term_value("[]")
    return str(value)


class ResultInbox:
    """Where the results of outstanding ROS 2 calls wait for the executor (`Actions.results`),
    with the agent's clock while a call is outstanding (the module's doc, "Time")."""

    def __init__(self, timeout: float = DEFAULT_TIMEOUT):
        self.timeout = timeout
        self._cond = threading.Condition()
        self._offset: Optional[float] = None         # agent time = monotonic() + offset
        self._waiting: Dict[str, float] = {}         # handle -> the agent time of its call
        self._answers: List[Tuple[float, Term]] = []

    def now(self) -> float:
        return _time.monotonic() + (self._offset or 0.0)

    def expect(self, handle: str, at: float) -> None:
        with self._cond:
            if self._offset is None or self.now() < at:
                self._offset = at - _time.monotonic()
            self._waiting[handle] = at

    def answer(self, handle: str, succeeded: bool, value) -> None:
        """Called from rclpy's thread when a call is answered."""
        with self._cond:
            if self._waiting.pop(handle, None) is None:
                return                      # aborted or timed out: dropped
            functor = "action_result" if succeeded else "action_failed"
            self._answers.append((self.now(), Compound(functor, (handle, value))))
            self._cond.notify_all()

    def forget(self, handle: str) -> bool:
        with self._cond:
            return self._waiting.pop(handle, None) is not None

    def waiting_for(self, handle: str) -> bool:
        with self._cond:
            return handle in self._waiting

    def outstanding(self) -> int:
        with self._cond:
            return len(self._waiting)

    def collect(self, next_time: Optional[float]) -> List[Tuple[float, Term]]:
        """The results in by the time the executor may take its next event (at `next_time`,
        None when the event base is empty): waits while calls are outstanding, no result is in
        and that time has not come; a call unanswered for `timeout` seconds fails."""
        with self._cond:
            while self._waiting and not self._answers:
                now = self.now()
                for handle, at in list(self._waiting.items()):
                    if now >= at + self.timeout:
                        del self._waiting[handle]
                        self._answers.append((at + self.timeout, Compound("action_failed", (handle, "timeout"))))
                if self._answers or (next_time is not None and now >= next_time):
                    break
                until = min(at + self.timeout for at in self._waiting.values())
                if next_time is not None:
                    until = min(until, next_time)
                self._cond.wait(max(until - now, 0.001))
            answers, self._answers = self._answers, []
            return answers


class Ros2Actions:
    """An rclpy node of the agent, spun in a thread of its own, through which the registered
    actions call services and send goals."""

    def __init__(self, actions: Actions, node_name: str = "robapl_agent", timeout: float = DEFAULT_TIMEOUT):
        try:
            import rclpy
            from rclpy.executors import SingleThreadedExecutor
        except ImportError:
            raise MissingRclpy("ROS 2 actions need rclpy: run retalisc in .venv-ros2's Python "
                               "(bash setup.sh makes it; $RETALISC_ROS2_PYTHON names another)") from None
        self.actions = actions
        self.inbox = ResultInbox(timeout)
        actions.results = self.inbox
        self._context = rclpy.context.Context()
        rclpy.init(context=self._context)
        self.node = rclpy.create_node(node_name, context=self._context)
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self.node)
        self._spinner = threading.Thread(target=self._spin, name="robapl-ros2", daemon=True)
        self._spinner.start()
        self._goals: Dict[str, object] = {}
        self._closed = False
        atexit.register(self.close)

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except Exception:               # the context was shut down by close()
            pass

    def service(self, name: str, service: str, type_name: str, request: Optional[Callable] = None,
                result: Optional[Callable] = None, wait: float = 10.0) -> None:
        """Registers action `name`: a call of `service` (type `pkg/srv/Type`). `request(cls,
        *args)` builds the request, `result(response)` gives (succeeded, value)."""
        cls = interface_class(type_name)
        client = self.node.create_client(cls, service)
        answer = result or message_value

        def call(*args, context):
            if not client.wait_for_service(timeout_sec=wait):
                raise ActionFailed(f"no ROS 2 service {service}")
            message = request(cls.Request, *args) if request else fill_message(cls.Request, args)
            self.inbox.expect(context.handle, context.time)
            future = client.call_async(message)
            future.add_done_callback(lambda done: self._answered(context.handle, done, answer))
            return PENDING

        self.actions.register(name, call, abort=self.inbox.forget)

    def action(self, name: str, action: str, type_name: str, goal: Optional[Callable] = None,
               result: Optional[Callable] = None, wait: float = 10.0, feedback: Optional[Callable] = None) -> None:
        """Registers action `name`: a goal sent to the ROS 2 action server `action` (type
        `pkg/action/Type`), cancelled when the node is aborted. `goal(cls, *args)` builds the
        goal, `result(result_message)` gives (succeeded, value), `feedback(handle, message)` sees
        the feedback."""
        from rclpy.action import ActionClient

        cls = interface_class(type_name)
        client = ActionClient(self.node, cls, action)
        answer = result or message_value
        perform = type_name == "robapl_interfaces/action/Perform"

        def make_goal(args):
            if goal:
                return goal(cls.Goal, *args)
            if perform:
                return cls.Goal(name=name, arguments=[_text(a) for a in args])
            return fill_message(cls.Goal, args)

        def call(*args, context):
            if not client.wait_for_server(timeout_sec=wait):
                raise ActionFailed(f"no ROS 2 action server {action}")
            message = make_goal(args)
            handle = context.handle
            self.inbox.expect(handle, context.time)
            on_feedback = (lambda m: feedback(handle, m.feedback)) if feedback else None
            sent = client.send_goal_async(message, feedback_callback=on_feedback)
            sent.add_done_callback(lambda done: self._goal_sent(handle, done, answer))
            return PENDING

        def abort(handle):
            self.inbox.forget(handle)
            goal_handle = self._goals.pop(handle, None)
            if goal_handle is not None:
                goal_handle.cancel_goal_async()

        self.actions.register(name, call, abort=abort)

    def _answered(self, handle: str, future, answer: Callable) -> None:
        error = future.exception()
        if error is not None:
            self.inbox.answer(handle, False, str(error))
            return
        succeeded, value = answer(future.result())
        self.inbox.answer(handle, succeeded, value)

    def _goal_sent(self, handle: str, future, answer: Callable) -> None:
        from action_msgs.msg import GoalStatus

        goal_handle = future.result()
        if not goal_handle.accepted:
            self.inbox.answer(handle, False, "goal rejected")
            return
        self._goals[handle] = goal_handle
        # its node aborted before the goal was accepted: whoever takes it from _goals cancels it
        if not self.inbox.waiting_for(handle) and self._goals.pop(handle, None) is not None:
            goal_handle.cancel_goal_async()
            return

        def done(result_future):
            self._goals.pop(handle, None)
            wrapped = result_future.result()
            if wrapped.status != GoalStatus.STATUS_SUCCEEDED:
                names = {GoalStatus.STATUS_CANCELED: "canceled", GoalStatus.STATUS_ABORTED: "aborted"}
                self.inbox.answer(handle, False, names.get(wrapped.status, f"status {wrapped.status}"))
                return
            succeeded, value = answer(wrapped.result)
            self.inbox.answer(handle, succeeded, value)

        goal_handle.get_result_async().add_done_callback(done)

    def close(self) -> None:
        """Cancels the goals still running, destroys the node and shuts its context down."""
        if self._closed:
            return
        self._closed = True
        for goal_handle in list(self._goals.values()):
            goal_handle.cancel_goal_async()
        self._executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        self._context.try_shutdown()
        self._spinner.join(timeout=2.0)


def _text(value) -> str:
    if isinstance(value, dict):
        (functor, args), = value.items()
        return f"{functor}({','.join(_text(a) for a in args)})"
    return str(value)

