#!/usr/bin/env bash
# Install what retalisc needs on a fresh Debian machine: SWI-Prolog (apt), a virtualenv in
# .venv, and the package with its test, benchmark and live extras (pip). Then ROS 1 for the
# live node (`retalisc ros`, docs/ros.md): Debian's rospy and master (apt) and .venv-ros, a
# virtualenv of the system Python that sees them (--system-site-packages) with retalisc in
# it. Then ROS 2 for `retalisc ros2`: .venv-ros2 with ROS 2 Jazzy's rclpy from PyPI wheels and
# the interface packages with no wheel (the Retalis services, tf2_msgs) built with colcon into
# .ros2-build (ros/setup_ros2.sh, about 2 minutes the first time). RETALISC_ROS=0 skips both ROS
# steps. Safe to run again.
set -euo pipefail
cd "$(dirname "$0")"

SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
APT_UPDATED=""
apt_install() {
    if [ -z "$APT_UPDATED" ]; then
        $SUDO apt-get update -qq
        APT_UPDATED=1
    fi
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "$@" >/dev/null
}

if ! command -v swipl >/dev/null 2>&1; then
    echo "setup: installing SWI-Prolog (apt-get install swi-prolog-nox)" >&2
    apt_install swi-prolog-nox
fi

if [ ! -x .venv/bin/python ]; then
    echo "setup: creating .venv" >&2
    python3 -m venv .venv
fi
.venv/bin/python -m pip install -q --disable-pip-version-check -e '.[test,bench,live]'
# An editable install leaves the package's bytecode unwritten, and with PYTHONDONTWRITEBYTECODE
# set every `retalisc` start would compile its modules again: compile them once here (a
# module edited later is compiled afresh when its bytecode is out of date).
.venv/bin/python -m compileall -q retalisc >/dev/null || true
bash prolog_runtime/c/build.sh        # the C helpers (with a C compiler) and the .qlf files

if [ "${RETALISC_ROS:-1}" != "0" ]; then
    ROS_PACKAGES="python3-rospy python3-rosmaster python3-roslaunch python3-rostopic python3-rosservice
                  python3-tf2-msgs python3-geometry-msgs python3-std-msgs python3-venv"
    if ! /usr/bin/python3 -c "import rospy, rosmaster, roslaunch, tf2_msgs.msg" >/dev/null 2>&1 \
            || ! command -v rosmaster >/dev/null 2>&1; then
        echo "setup: installing ROS 1 from Debian (apt-get install python3-rospy python3-rosmaster ...)" >&2
        # shellcheck disable=SC2086
        apt_install $ROS_PACKAGES || echo "setup: warning: ROS 1 is not installable here; retalisc ros and its tests are skipped" >&2
    fi
    # tf2's BufferCore (Python binding and C++ library): the oracle of the tf library's tests
    # and the peer of benchmarks/tf_lookup.py
    if ! /usr/bin/python3 -c "import tf2_py" >/dev/null 2>&1 || [ ! -f /usr/include/tf2/buffer_core.h ]; then
        echo "setup: installing tf2 from Debian (apt-get install python3-tf2 libtf2-dev)" >&2
        apt_install python3-tf2 libtf2-dev || echo "setup: warning: tf2 is not installable here; the tf oracle tests are skipped" >&2
    fi
    if /usr/bin/python3 -c "import rospy" >/dev/null 2>&1; then
        if [ ! -x .venv-ros/bin/python ]; then
            echo "setup: creating .venv-ros (the system Python with ROS 1, for retalisc ros)" >&2
            /usr/bin/python3 -m venv --system-site-packages .venv-ros
        fi
        .venv-ros/bin/python -m pip install -q --disable-pip-version-check -e '.[ros1]'
    fi
    # ROS 2 Jazzy's wheels are built for Python 3.10 to 3.13
    if /usr/bin/python3 -c "import sys, venv; sys.exit(not (3, 10) <= sys.version_info[:2] <= (3, 13))" 2>/dev/null; then
        started=$SECONDS
        bash ros/setup_ros2.sh .venv-ros2 .ros2-build \
            || echo "setup: warning: the ROS 2 environment could not be made; retalisc ros2 and its tests are skipped" >&2
        echo "setup: ROS 2 step $((SECONDS - started)) s" >&2
    else
        echo "setup: warning: ROS 2 Jazzy's wheels need Python 3.10-3.13 with venv; retalisc ros2 is skipped" >&2
    fi
fi
echo "setup: ready ($(swipl --version), $(.venv/bin/python --version)$([ -x .venv-ros/bin/python ] && echo ", ROS 1 in .venv-ros")$([ -f .ros2-build/.retalisc-build-stamp ] && echo ", ROS 2 in .venv-ros2"))" >&2
