"""`retalisc ros` as roslaunch starts it (ros/retalis/scripts/retalisc_node): the node's
name comes from roslaunch's `__name:=NAME`, the other ROS arguments (`__log:=`, remappings)
are left to rospy; the rest are the arguments of `retalisc ros`."""
from __future__ import annotations

import sys

from ..cli import main as cli_main


def main(argv=None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    name = None
    rest = []
    for arg in argv:
        if arg.startswith("__name:="):
            name = arg.split(":=", 1)[1]
        elif ":=" not in arg:
            rest.append(arg)
    if name is not None and "--name" not in rest:
        rest += ["--name", name]
    cli_main(["ros", *rest], prog_name="retalisc")


if __name__ == "__main__":
    main()
