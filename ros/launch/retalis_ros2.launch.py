"""A ROS 2 launch file for a Retalis component (`retalisc ros2`, docs/ros.md):

    ros2 launch ros/launch/retalis_ros2.launch.py program:=/path/to/program.rtl config:=/path/to/pub_sub.xml

launch_ros starts `retalisc` (found on PATH: the `retalisc` of the Python that has rclpy,
e.g. .venv-ros2/bin or a virtualenv made on your sourced ROS 2 installation) with
`--ros-args -r __node:=NAME -r __ns:=NAMESPACE --params-file ...`: the node's name, its
namespace and use_sim_time come from here; the node's parameters program, config, name,
max_delay and state_dir (read-only) then say what it runs (`ros2 param dump /NAMESPACE/NAME`).
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue


def generate_launch_description():
    arguments = [
        DeclareLaunchArgument("program", description="the Retalis program (.rtl)"),
        DeclareLaunchArgument("config", description="its pub_sub.xml: topics, types, QoS"),
        DeclareLaunchArgument("name", default_value="retalis", description="the node's name"),
        DeclareLaunchArgument("namespace", default_value="", description="the node's namespace"),
        DeclareLaunchArgument("use_sim_time", default_value="false", description="the clock of /clock"),
        DeclareLaunchArgument("max_delay", default_value="1.0", description="seconds (retalisc run --max-delay)"),
    ]
    retalis = Node(
        executable="retalisc",
        arguments=["ros2", LaunchConfiguration("program"), "--config", LaunchConfiguration("config"),
                   "--max-delay", LaunchConfiguration("max_delay")],
        name=LaunchConfiguration("name"),
        namespace=LaunchConfiguration("namespace"),
        parameters=[{"use_sim_time": ParameterValue(LaunchConfiguration("use_sim_time"), value_type=bool)}],
        output="screen",
    )
    return LaunchDescription(arguments + [retalis])
