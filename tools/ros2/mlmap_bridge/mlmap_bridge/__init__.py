"""mlmap ground-station bridge: mlmap_node's layers as RViz2 markers, and the integration checker.

conversions, markers, parameters and checks are plain Python + numpy (unit-tested without
ROS); bridge_node and checker_node wire them to rclpy.
"""
