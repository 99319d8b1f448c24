"""Start the mlmap bridge and, unless rviz:=false, RViz2 with mlmap's view.

ros2 launch mlmap_bridge bridge.launch.py                 # bridge + RViz2
ros2 launch mlmap_bridge bridge.launch.py rviz:=false     # bridge only (headless ground box)
ros2 launch mlmap_bridge bridge.launch.py params_file:=/path/to/my_bridge.yaml
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    """Describe the bridge node and the optional RViz2."""
    share = FindPackageShare('mlmap_bridge')
    return LaunchDescription([
        DeclareLaunchArgument(
            'params_file', default_value=PathJoinSubstitution([share, 'config', 'bridge.yaml']),
            description='bridge parameters (every one is listed in config/bridge.yaml)'),
        DeclareLaunchArgument(
            'rviz', default_value='true', description='start RViz2 with rviz/mlmap.rviz'),
        Node(package='mlmap_bridge', executable='mlmap_bridge', name='mlmap_bridge',
             parameters=[LaunchConfiguration('params_file')], output='screen'),
        Node(package='rviz2', executable='rviz2', name='rviz2', output='screen',
             arguments=['-d', PathJoinSubstitution([share, 'rviz', 'mlmap.rviz'])],
             condition=IfCondition(LaunchConfiguration('rviz'))),
    ])
