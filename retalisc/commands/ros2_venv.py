"""Handing a command line over to the Python that has ROS 2's rclpy (`retalisc ros2`,
`retalisc robapl run` with ROS 2 actions)."""
import sys


def hand_over_to_ros2_venv() -> None:
    """Without rclpy here: run the same command line in .venv-ros2's Python (setup.sh), or in
    $RETALISC_ROS2_PYTHON, when there is one and this is the `retalisc` program itself."""
    import os
    from pathlib import Path

    python = (os.environ.get("RETALISC_ROS2_PYTHON")
              or str(Path(__file__).resolve().parents[2] / ".venv-ros2" / "bin" / "python"))
    command_line = os.path.basename(sys.argv[0]) in ("retalisc", "__main__.py")
    if not command_line or os.environ.get("_RETALISC_ROS2_HANDED_OVER") or not os.access(python, os.X_OK):
        return
    sys.stdout.flush()
    sys.stderr.flush()
    os.execve(python, [python, "-m", "retalisc", *sys.argv[1:]], dict(os.environ, _RETALISC_ROS2_HANDED_OVER="1"))
