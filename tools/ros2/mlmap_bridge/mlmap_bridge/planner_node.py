"""mlmap_plan: a ROS 2 planner example on mlmap_node's 2D grid.

In: /mlmap/grid (nav_msgs/OccupancyGrid, latched, the rolling grid of the local window),
pose (geometry_msgs/PoseStamped, the vehicle's pose, the topic mlmap_node reads it from) and
goal_pose (geometry_msgs/PoseStamped, RViz2's "2D Goal Pose"). Out: plan (nav_msgs/Path, in the
grid's frame), planned again with every grid and every goal. The path is grid_planner.plan():
the grid inflated by vehicle_radius_m, unknown cells free, 8-connected A*. Wiring only.
"""

from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid, Path
from rcl_interfaces.msg import ParameterDescriptor
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .grid_planner import plan

LATCHED_IN = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
OUT = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                 reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)


class MlmapPlanner(Node):
    """Plans a path on the latest grid from the latest pose to the latest goal."""

    def __init__(self):
        """Declare the parameters and wire the topics."""
        super().__init__('mlmap_plan')
        self.radius_m = self.declare_parameter(
            'vehicle_radius_m', 0.6,
            ParameterDescriptor(description='the path keeps this far from occupied cells [m]')
        ).value
        self.grid = None
        self.pose = None
        self.goal = None
        self.publisher = self.create_publisher(Path, 'plan', OUT)
        self.create_subscription(OccupancyGrid, '/mlmap/grid', self.on_grid, LATCHED_IN)
        self.create_subscription(PoseStamped, 'pose', self.on_pose, 10)
        self.create_subscription(PoseStamped, 'goal_pose', self.on_goal, 10)

    def on_grid(self, msg):
        """Keep the grid and plan."""
        self.grid = msg
        self.replan()

    def on_pose(self, msg):
        """Keep the vehicle's pose."""
        self.pose = msg

    def on_goal(self, msg):
        """Keep the goal and plan."""
        self.goal = msg
        self.replan()

    def replan(self):
        """Publish the path on the latest grid, if there is one."""
        if self.grid is None or self.pose is None or self.goal is None:
            return
        info = self.grid.info
        points = plan(self.grid.data, info.width, info.height, info.resolution,
                      (info.origin.position.x, info.origin.position.y),
                      (self.pose.pose.position.x, self.pose.pose.position.y),
                      (self.goal.pose.position.x, self.goal.pose.position.y), self.radius_m)
        if points is None:
            self.get_logger().warn('no path to the goal on the latest grid',
                                   throttle_duration_sec=5.0)
            return
        path = Path()
        path.header = self.grid.header
        for x, y in points:
            pose = PoseStamped()
            pose.header = self.grid.header
            pose.pose.position.x = x
            pose.pose.position.y = y
            pose.pose.position.z = self.pose.pose.position.z
            pose.pose.orientation.w = 1.0
            path.poses.append(pose)
        self.publisher.publish(path)


def main(args=None):
    """Run the planner until Ctrl-C."""
    rclpy.init(args=args)
    node = MlmapPlanner()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
