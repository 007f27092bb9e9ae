"""Processes of the live tests (ROS 1 master and nodes, DDS and Zenoh components): started
with a free port where they need one, stopped by their process id in a fixture finaliser,
even when the test fails."""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import List, Optional

ROOT = Path(__file__).resolve().parent.parent
LIVE = ROOT / "tests" / "live"


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_port(port: int, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return True
        time.sleep(0.05)
    return False


class Processes:
    """The processes a test started; `stop_all` ends each by its pid (SIGTERM, then SIGKILL)."""

    def __init__(self, directory: Path):
        self.directory = directory
        self.started: List[subprocess.Popen] = []

    def start(self, name: str, argv: List[str], env: dict) -> subprocess.Popen:
        out = open(self.directory / f"{name}.out", "w")
        err = open(self.directory / f"{name}.err", "w")
        process = subprocess.Popen(argv, env=env, stdout=out, stderr=err, stdin=subprocess.DEVNULL,
                                   start_new_session=True)
        process.name = name
        self.started.append(process)
        return process

    def err(self, name: str) -> str:
        return (self.directory / f"{name}.err").read_text()

    def out(self, name: str) -> str:
        return (self.directory / f"{name}.out").read_text()

    def wait_for_line(self, process: subprocess.Popen, text: str, timeout: float = 30.0) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            err = self.err(process.name)
            if text in err:
                return err
            if process.poll() is not None:
                raise AssertionError(f"{process.name} exited ({process.returncode}):\n{err}")
            time.sleep(0.05)
        raise AssertionError(f"{process.name}: no {text!r} within {timeout} s:\n{self.err(process.name)}")

    def stop(self, process: subprocess.Popen, timeout: float = 10.0) -> Optional[int]:
        if process.poll() is None:
            os.kill(process.pid, signal.SIGTERM)
            try:
                process.wait(timeout)
            except subprocess.TimeoutExpired:
                os.kill(process.pid, signal.SIGKILL)
                process.wait()
        return process.returncode

    def stop_all(self) -> None:
        for process in reversed(self.started):
            self.stop(process)


def retalisc_env(extra: Optional[dict] = None) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.update(extra or {})
    return env


def retalisc_argv(python: str, *args: str) -> List[str]:
    return [python, "-m", "retalisc", *args]


this_python = sys.executable


def tf_message(store, stamp: int, x: float, child: str = "base"):
    """A tf2_msgs/TFMessage of one transform (odom -> child, translation x) of a ROS 2 rosbags store."""
    T = store.types
    return T["tf2_msgs/msg/TFMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=stamp, nanosec=0),
                                        frame_id="odom"),
        child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=0.0),
            rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))])


class RosDomain:
    """A ROS 2 domain id no other test uses meanwhile: ids from `first` to `last` are taken by
    an exclusive lock on a file named after them (released by `release`, or when the process
    ends), so concurrent test runs on one machine never share a domain."""

    def __init__(self, first: int = 120, last: int = 229):
        import fcntl
        import random

        folder = Path(os.environ.get("TMPDIR", "/tmp")) / "retalisc-ros2-domains"
        folder.mkdir(exist_ok=True)
        ids = list(range(first, last + 1))
        random.shuffle(ids)
        for domain in ids:
            handle = open(folder / f"{domain}.lock", "w")
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                handle.close()
                continue
            self.id, self._handle = domain, handle
            return
        raise RuntimeError(f"every ROS 2 domain from {first} to {last} is in use")

    def release(self) -> None:
        self._handle.close()
