"""ROS 2 node `mlmap_bridge`: mlmap_node's layers in, what RViz2 shows well out.

Wiring only: topics, QoS, parameters and throttling. What is computed lives in
conversions.py and markers.py, which the unit tests run without ROS.

In (mlmap_node's defaults; QoS as idl/README.md lists the writers):
  PointCloud2 awareness / local map / ESDF slice  BEST_EFFORT, KEEP_LAST 1: a lossy radio link
                                                  never makes the vehicle resend map data
  PointCloud2 global map, OccupancyGrid grid      RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1: the
                                                  node latches them; a late ground station
                                                  still gets the last one
  mlmap_msgs/Status                               RELIABLE, KEEP_LAST 10 (small, 1 Hz)
  PointCloud2 fleet map (mlmap_fleet, optional)   RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1
Out (under output_prefix, RELIABLE so RViz's default subscriptions match):
  <layer> MarkerArray cube lists (heights / distances as colours; serialised from numpy
  arrays, no Python object per voxel), grid (passed through, latched like the input),
  status (a text above the vehicle), status_text (String), and with fleet_map_topic set
  fleet_map (cubes in the colour of the vehicle that saw them, latched) and fleet_paths (each
  vehicle's path from /tf, a line strip in its colour).
"""

from functools import partial
import time
from typing import Any, Dict, List, Optional

from geometry_msgs.msg import Point
from mlmap_msgs.msg import FleetStatus, Status
from nav_msgs.msg import OccupancyGrid
from rcl_interfaces.msg import ParameterDescriptor
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header, String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from .conversions import CloudLayoutError, LatestThrottle, status_text
from .fleet_paths import FleetPaths
from .markers import cloud_layer_markers, fleet_map_markers, marker_array, MessageTypes
from .markers import text_marker
from .parameters import CLOUD_LAYERS, CloudLayer, in_namespace, PARAMETERS, prefixed_frame

TYPES = MessageTypes(Marker=Marker, MarkerArray=MarkerArray, Header=Header, Point=Point)


def _qos(depth: int, reliable: bool, latched: bool) -> QoSProfile:
    """Make a KEEP_LAST profile."""
    return QoSProfile(
        depth=depth, history=HistoryPolicy.KEEP_LAST,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


HEAVY_IN = _qos(1, reliable=False, latched=False)
LATCHED_IN = _qos(1, reliable=True, latched=True)
STATUS_IN = _qos(10, reliable=True, latched=False)
OUT = _qos(1, reliable=True, latched=False)
LATCHED_OUT = _qos(1, reliable=True, latched=True)
POLL_PERIOD_S = 0.1  # how often throttled samples that had to wait are looked at


class MlmapBridge(Node):
    """Subscribes to mlmap's layers and republishes them as RViz2 markers."""

    def __init__(self):
        """Declare the parameters and create every enabled subscription and publisher."""
        super().__init__('mlmap_bridge')
        for p in PARAMETERS:  # read once here: read-only, so `ros2 param set` says so
            self.declare_parameter(p.name, p.default,
                                   ParameterDescriptor(description=p.description, read_only=True))
        self.settings: Dict[str, Any] = {
            p.name: self.get_parameter(p.name).value for p in PARAMETERS}
        namespace = self.settings['namespace']
        for name in self.settings:  # mlmap_node's topics and the outputs under its namespace
            if name in ('fleet_map_topic', 'fleet_status_topic'):  # the merger's: absolute
                continue
            if name.endswith('_topic') or name == 'output_prefix':
                self.settings[name] = in_namespace(namespace, self.settings[name])
        self._body_frame = prefixed_frame(self.settings['frame_prefix'],
                                          self.settings['body_frame'])
        self._output_prefix = self.settings['output_prefix'].rstrip('/')
        self._throttled: List[tuple] = []  # (throttle, handler) pairs the timer polls
        self._previous_status: Optional[Status] = None
        for layer in CLOUD_LAYERS:
            self._wire_cloud_layer(layer)
        self._wire_grid()
        self._wire_status()
        self._wire_fleet_map()
        self.create_timer(POLL_PERIOD_S, self._poll)

    def _throttle(self, rate_parameter: str, handler):
        """Return a callback that passes samples to handler at most at the parameter's rate."""
        throttle = LatestThrottle(float(self.settings[rate_parameter]))
        self._throttled.append((throttle, handler))

        def callback(msg):
            ready = throttle.offer(msg, time.monotonic())
            if ready is not None:
                handler(ready)
        return callback

    def _poll(self) -> None:
        """Hand on the samples that waited for their rate limit."""
        now = time.monotonic()
        for throttle, handler in self._throttled:
            ready = throttle.poll(now)
            if ready is not None:
                handler(ready)

    def _wire_cloud_layer(self, layer: CloudLayer) -> None:
        """Subscribe to a cloud layer and publish its markers (unless its topic is "")."""
        topic = self.settings[f'{layer.name}_topic']
        if not topic:
            return
        output = f'{self._output_prefix}/{layer.name}'
        publisher = self.create_publisher(MarkerArray, output,
                                          LATCHED_OUT if layer.latched else OUT)
        handler = partial(self._publish_cloud_layer, layer, publisher)
        self.create_subscription(PointCloud2, topic,
                                 self._throttle(f'{layer.name}_max_rate_hz', handler),
                                 LATCHED_IN if layer.latched else HEAVY_IN)
        self.get_logger().info(f'{topic} -> {output}')

    def _publish_cloud_layer(self, layer: CloudLayer, publisher, cloud: PointCloud2) -> None:
        """Convert one cloud into markers; a malformed cloud is logged, not shown.

        The markers come serialised (no Python object per voxel); rclpy publishes bytes as is.
        """
        try:
            markers = cloud_layer_markers(layer, cloud, self.settings)
        except (CloudLayoutError, ValueError) as error:
            self.get_logger().warning(f'{layer.name}: {error}', throttle_duration_sec=5.0)
            return
        publisher.publish(markers)

    def _wire_grid(self) -> None:
        """Pass the latched 2D grid through, latched too (unless its topic is "")."""
        topic = self.settings['grid_topic']
        if not topic:
            return
        output = f'{self._output_prefix}/grid'
        publisher = self.create_publisher(OccupancyGrid, output, LATCHED_OUT)
        self.create_subscription(OccupancyGrid, topic,
                                 self._throttle('grid_max_rate_hz', publisher.publish),
                                 LATCHED_IN)
        self.get_logger().info(f'{topic} -> {output}')

    def _wire_fleet_map(self) -> None:
        """Subscribe to mlmap_fleet's merged map and publish it coloured by vehicle (if set)."""
        topic = self.settings['fleet_map_topic']
        if not topic:
            return
        output = f'{self._output_prefix}/fleet_map'
        publisher = self.create_publisher(MarkerArray, output, LATCHED_OUT)

        def handler(cloud: PointCloud2) -> None:
            try:
                publisher.publish(fleet_map_markers(cloud, self.settings))
            except (CloudLayoutError, ValueError) as error:
                self.get_logger().warning(f'fleet_map: {error}', throttle_duration_sec=5.0)
        self.create_subscription(PointCloud2, topic,
                                 self._throttle('fleet_map_max_rate_hz', handler), LATCHED_IN)
        self.get_logger().info(f'{topic} -> {output}')
        self._wire_fleet_paths()

    def _wire_fleet_paths(self) -> None:
        """Each vehicle's path from /tf, in the colour mlmap_fleet's status gives it."""
        self._fleet_paths = FleetPaths(self.settings['body_frame'])
        self._paths_world_frame = 'map'
        self._paths_changed = False
        output = f'{self._output_prefix}/fleet_paths'
        self._paths_publisher = self.create_publisher(MarkerArray, output, OUT)
        self.create_subscription(TFMessage, '/tf', self._on_fleet_tf, _qos(100, True, False))
        status_topic = self.settings['fleet_status_topic']
        if status_topic:
            self.create_subscription(FleetStatus, status_topic, self._on_fleet_status, STATUS_IN)
        self.create_timer(1.0, self._publish_fleet_paths)
        self.get_logger().info(f'/tf, {status_topic or "(no status)"} -> {output}')

    def _on_fleet_tf(self, message: TFMessage) -> None:
        """Add the vehicles' body positions of one /tf message to their paths."""
        for t in message.transforms:
            p = t.transform.translation
            if self._fleet_paths.add(t.child_frame_id, p.x, p.y, p.z):
                self._paths_world_frame = t.header.frame_id or self._paths_world_frame
                self._paths_changed = True

    def _on_fleet_status(self, status: FleetStatus) -> None:
        """Colour the paths in the merger's vehicle order."""
        self._fleet_paths.set_vehicles(list(status.vehicles))

    def _publish_fleet_paths(self) -> None:
        """Publish the paths once a second when they grew."""
        if not self._paths_changed:
            return
        self._paths_changed = False
        self._paths_publisher.publish(self._fleet_paths.markers(TYPES, self._paths_world_frame))

    def _wire_status(self) -> None:
        """Subscribe to the status and publish it as a text marker and a string."""
        topic = self.settings['status_topic']
        if not topic:
            return
        self._status_markers = self.create_publisher(
            MarkerArray, f'{self._output_prefix}/status', OUT)
        self._status_text = self.create_publisher(String, f'{self._output_prefix}/status_text',
                                                  _qos(10, reliable=True, latched=False))
        self.create_subscription(Status, topic, self._on_status, STATUS_IN)
        self.get_logger().info(f'{topic} -> {self._output_prefix}/status, status_text')

    def _on_status(self, status: Status) -> None:
        """Publish the overlay text of one Status."""
        text = status_text(status, self._previous_status)
        self._previous_status = status
        self._status_markers.publish(marker_array(TYPES, text_marker(
            TYPES, self._body_frame, 'status', text,
            float(self.settings['text_height_m']), float(self.settings['text_offset_z_m']))))
        self._status_text.publish(String(data=text))


def main(args=None):
    """Run the bridge until Ctrl-C."""
    rclpy.init(args=args)
    node = MlmapBridge()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
