"""The NAO application live (issue 39, 2): examples/nao/nao.rtl as a ROS 1 node (`retalisc
ros`) and examples/nao/nao_ros2.rtl as the ROS 2 node (`retalisc ros2`), each fed a recording of
examples/nao/make_bag.py (1,896 transforms/s, markers, faces) at real time by an independent
publisher process (tests/ros1_client.py `bag` with rospy, tests/ros2_client.py `--bag` with
rclpy), on loopback. The figure is the CPU share of the component's process over the
recording's playing (CPU time from /proc/PID/stat over the recording's length), beside the replay's share
measured in the same run: `retalisc run nao.rtl --bag` of the same recording as fast as it
goes, its CPU time (start-up included) over the recording's length. Target: the live node
below 5% of a core.

Usage: python benchmarks/nao_live.py [--seconds 20] [--kinds ros1,ros2] [--out-dir DIR]
Writes DIR/nao_live.json (DIR defaults to benchmarks/results, not in git).
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import resource
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "nao"
TARGET_SHARE = 0.05
CLK_TCK = os.sysconf("SC_CLK_TCK")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cpu_seconds(pid: int) -> float:
    """utime + stime of a process (all its threads), seconds."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def _wait_for(path: Path, text: str, process: subprocess.Popen, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if text in path.read_text(errors="replace"):
            return
        if process.poll() is not None:
            break
        time.sleep(0.1)
    raise RuntimeError(f"the node did not start:\n{path.read_text(errors='replace')[-2000:]}")


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def _make_bag(folder: Path, seconds: float):
    spec = importlib.util.spec_from_file_location("nao_make_bag", EXAMPLE / "make_bag.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.write(folder / "nao.bag", seconds=seconds, seed=7)


def replay_share(bag: Path, seconds: float, env: dict) -> dict:
    """`retalisc run nao.rtl --bag` as fast as it goes: its CPU over the recording's length."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "retalisc", "run", str(EXAMPLE / "nao.rtl"), "--bag", str(bag)],
                   env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"cpu_s": cpu, "wall_s": wall, "share": cpu / seconds}


def live_share(kind: str, bag: Path, seconds: float, truth: int, folder: Path, env: dict) -> dict:
    """The node of `kind` fed the recording at real time by an independent publisher."""
    processes = []
    err = folder / f"{kind}.err"
    try:
        if kind == "ros1":
            python = os.environ.get("RETALISC_ROS_PYTHON") or str(ROOT / ".venv-ros" / "bin" / "python")
            if not Path(python).exists() or shutil.which("rosmaster") is None:
                return {"skipped": "ROS 1 is not set up (bash setup.sh makes .venv-ros)"}
            port = _free_port()
            env = dict(env, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_IP="127.0.0.1", ROS_HOSTNAME="127.0.0.1",
                       ROS_HOME=str(folder / "home"), ROS_LOG_DIR=str(folder / "log"))
            processes.append(subprocess.Popen([shutil.which("rosmaster"), "--core", "-p", str(port)], env=env,
                                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
            time.sleep(2.0)
            program, banner = EXAMPLE / "nao.rtl", "ros: node /retalis"
            player = [python, str(ROOT / "tests" / "ros1_client.py"), "bag"]
        else:
            python = os.environ.get("RETALISC_ROS2_PYTHON") or str(ROOT / ".venv-ros2" / "bin" / "python")
            if not Path(python).exists():
                return {"skipped": "ROS 2 is not set up (bash setup.sh makes .venv-ros2)"}
            env = dict(env, ROS_DOMAIN_ID=str(100 + os.getpid() % 100))
            program, banner = EXAMPLE / "nao_ros2.rtl", "ros2: node /retalis"
            player = [python, str(ROOT / "tests" / "ros2_client.py"), "--bag"]
        with open(err, "w") as stream:
            node = subprocess.Popen([python, "-m", "retalisc", kind.replace("ros1", "ros"), str(program), "--config",
                                     str(EXAMPLE / "pub_sub.xml")], env=env, stdout=subprocess.DEVNULL, stderr=stream)
        processes.append(node)
        _wait_for(err, banner, node)
        time.sleep(1.0)
        cpu0, wall0 = _cpu_seconds(node.pid), time.perf_counter()
        played = subprocess.run(player + [str(bag), "1.0", "/tf,/ar_pose_marker", str(truth),
                                          ",".join(f"/marker{k}" for k in range(1, 9))],
                                env=env, capture_output=True, text=True, timeout=600)
        cpu1, wall1 = _cpu_seconds(node.pid), time.perf_counter()
        if played.returncode != 0:
            return {"skipped": f"the publisher failed: {played.stderr.strip()[-300:]}"}
        received = len(json.loads(played.stdout.strip().splitlines()[-1]).get("received", []))
        # over the recording's length (the publisher's own start-up is part of the wall time)
        return {"cpu_s": cpu1 - cpu0, "wall_s": wall1 - wall0, "share": (cpu1 - cpu0) / seconds,
                "detections": truth, "received": received}
    finally:
        for process in reversed(processes):
            _stop(process)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="the recording's length")
    parser.add_argument("--kinds", default="ros1,ros2", help="ros1, ros2 (comma-separated)")
    parser.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--code", type=Path, default=ROOT,
                        help="the retalisc checkout (built) the component and the replay run: another one's "
                             "figures beside this one's")
    args = parser.parse_args()
    env = dict(os.environ, PYTHONPATH=str(args.code) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    results = {"seconds": args.seconds}
    with tempfile.TemporaryDirectory(prefix="nao_live_") as name:
        folder = Path(name)
        bag, truth_path = _make_bag(folder, args.seconds)
        truth = len(truth_path.read_text().splitlines())
        results["replay"] = replay_share(bag, args.seconds, env)
        for kind in args.kinds.split(","):
            results[kind] = live_share(kind, bag, args.seconds, truth, folder, env)
    replay = results["replay"]
    print(f"replay (retalisc run nao.rtl --bag, as fast as it goes): {replay['cpu_s']:.2f} s CPU in "
          f"{replay['wall_s']:.2f} s = {replay['share']:.1%} of a core over the {args.seconds:.0f} s recording")
    status = 0
    for kind in args.kinds.split(","):
        r = results[kind]
        if "skipped" in r:
            print(f"{kind}: skipped: {r['skipped']}")
            continue
        met = r["share"] < TARGET_SHARE and r["received"] == r["detections"]
        print(f"{kind}: {r['cpu_s']:.2f} s CPU while playing ({r['wall_s']:.1f} s with the publisher's start-up) = "
              f"{r['share']:.1%} of a core over the {args.seconds:.0f} s recording "
              f"({r['share'] / replay['share']:.1f}x the replay's); {r['received']}/{r['detections']} detections; "
              f"target below {TARGET_SHARE:.0%}: {'met' if met else 'MISSED'}")
    args.out_dir.mkdir(parents=True, exist_ok=True)
    (args.out_dir / "nao_live.json").write_text(json.dumps(results, indent=2))
    return status


if __name__ == "__main__":
    sys.exit(main())
