"""Start mlmap_node with a configuration, the bridge, and RViz2 together (one machine).

ros2 launch mlmap_bridge mlmap.launch.py                                  # node + bridge + RViz2
ros2 launch mlmap_bridge mlmap.launch.py node_config:=/path/to/robot.yaml
ros2 launch mlmap_bridge mlmap.launch.py rviz:=false bridge:=false        # the node alone

mlmap_node is not a ROS 2 package executable: it is a plain program (no ROS libraries) that
colcon installs to the workspace's bin/ when the workspace holds the mlmap repository (or that
`cmake --install` puts anywhere on PATH). This file starts it as a process; `node_executable`
names another path. On a vehicle without ROS, start the node alone with no launch at all:

    mlmap_node --config /path/to/robot.yaml

and on the ground station `ros2 launch mlmap_bridge bridge.launch.py` (the bridge and RViz2).
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare
from mlmap_bridge.launch_support import installed_node_config, node_command


def start_node(context):
    """Start mlmap_node as a process, its command made from the launch arguments' values."""
    if context.perform_substitution(LaunchConfiguration('node')).lower() != 'true':
        return []
    command = node_command(context.perform_substitution(LaunchConfiguration('node_executable')),
                           context.perform_substitution(LaunchConfiguration('node_config')))
    return [ExecuteProcess(cmd=command, name='mlmap_node', output='screen',
                           sigterm_timeout='10')]


def generate_launch_description() -> LaunchDescription:
    """Describe mlmap_node, the bridge and RViz2, each switchable."""
    share = FindPackageShare('mlmap_bridge')
    return LaunchDescription([
        DeclareLaunchArgument(
            'node_config', default_value=installed_node_config(),
            description='mlmap_node configuration (YAML; default: the installed '
                        'share/mlmap/config/mlmap_node.yaml)'),
        DeclareLaunchArgument(
            'node_executable', default_value='mlmap_node',
            description='mlmap_node program (a name on PATH, or a path)'),
        DeclareLaunchArgument(
            'node', default_value='true', description='start mlmap_node'),
        DeclareLaunchArgument(
            'bridge', default_value='true', description='start the bridge (RViz2 markers)'),
        DeclareLaunchArgument(
            'params_file', default_value=PathJoinSubstitution([share, 'config', 'bridge.yaml']),
            description='bridge parameters (every one is listed in config/bridge.yaml)'),
        DeclareLaunchArgument(
            'rviz', default_value='true', description='start RViz2 with rviz/mlmap.rviz'),
        OpaqueFunction(function=start_node),
        Node(package='mlmap_bridge', executable='mlmap_bridge', name='mlmap_bridge',
             parameters=[LaunchConfiguration('params_file')], output='screen',
             condition=IfCondition(LaunchConfiguration('bridge'))),
        Node(package='rviz2', executable='rviz2', name='rviz2', output='screen',
             arguments=['-d', PathJoinSubstitution([share, 'rviz', 'mlmap.rviz'])],
             condition=IfCondition(LaunchConfiguration('rviz'))),
    ])
