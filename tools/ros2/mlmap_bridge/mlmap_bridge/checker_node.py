"""ROS 2 program `mlmap_check`: the verdict of the container integration test.

Subscribes to every mlmap_node output and every bridge output (checks.EXPECTED_TOPICS) with
the type the topic must have, feeds each sample to its plausibility check (checks.py, unit
tested without ROS), waits until every topic passed or the time is up, then runs
`ros2 topic list -t` and checks that it lists each topic with its type. Prints one line per
topic and exits 0 when everything passed, 1 otherwise.
"""

import argparse
import subprocess
import sys
import time
from typing import List, Optional

import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args
from rosidl_runtime_py.utilities import get_message

from .checks import (bridge_topics, check_topic_list, Frames, node_topics, parse_topic_list,
                     TopicResult, verdict)
from .parameters import prefixed_frame

TOPIC_LIST_COMMAND = ['ros2', 'topic', 'list', '-t', '--no-daemon', '--spin-time', '5']


def _subscribe(node: Node, result: TopicResult, frames: Frames) -> None:
    """Subscribe to one expected topic; RELIABLE so large samples survive a lossy UDP path."""
    e = result.expectation
    qos = QoSProfile(
        depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if e.latched else DurabilityPolicy.VOLATILE)

    def on_sample(msg):
        result.record(e.check(msg, frames))

    node.create_subscription(get_message(e.type_name), e.topic, on_sample, qos)


def _topic_list_problems(expected) -> List[str]:
    """Run `ros2 topic list -t` and compare it with the expected topics and types."""
    try:
        listed = subprocess.run(TOPIC_LIST_COMMAND, capture_output=True, text=True,
                                timeout=60, check=True).stdout
    except (OSError, subprocess.SubprocessError) as error:
        return [f'`{" ".join(TOPIC_LIST_COMMAND)}` failed: {error}']
    print(listed, flush=True)
    return check_topic_list(parse_topic_list(listed), expected)


def main(argv: Optional[List[str]] = None) -> int:
    """Check every layer; return the exit code (0: all plausible).

    argv is the whole command line, program name first (default: sys.argv); ROS arguments
    (--ros-args ...) go to rclpy.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--timeout', type=float, default=150.0,
                        help='seconds to wait for a plausible sample on every topic')
    parser.add_argument('--node-only', action='store_true',
                        help='check mlmap_node outputs only (no bridge running)')
    parser.add_argument('--namespace', default='',
                        help="mlmap_node's dds.ns (and the bridge's namespace parameter)")
    parser.add_argument('--viz-prefix', default='/mlmap/viz',
                        help="the bridge's output_prefix parameter")
    parser.add_argument('--world-frame', default=Frames.world, help="mlmap_node's dds.world_frame")
    parser.add_argument('--body-frame', default=Frames.body, help="mlmap_node's dds.body_frame")
    parser.add_argument('--sensor-frame', default=Frames.sensor,
                        help="mlmap_node's dds.sensor_frame")
    parser.add_argument('--frame-prefix', default='',
                        help="mlmap_node's dds.frame_prefix (of the body and sensor frames)")
    args = parser.parse_args(remove_ros_args(sys.argv if argv is None else argv)[1:])
    expected = node_topics(args.namespace)
    if not args.node_only:
        expected += bridge_topics(args.namespace, args.viz_prefix)
    results = [TopicResult(e) for e in expected]
    frames = Frames(args.world_frame, prefixed_frame(args.frame_prefix, args.body_frame),
                    prefixed_frame(args.frame_prefix, args.sensor_frame))

    rclpy.init(args=sys.argv if argv is None else argv)
    node = Node('mlmap_check')
    for result in results:
        _subscribe(node, result, frames)
    deadline = time.monotonic() + args.timeout
    while rclpy.ok() and time.monotonic() < deadline and not all(r.passed for r in results):
        rclpy.spin_once(node, timeout_sec=0.2)
    node.destroy_node()
    rclpy.try_shutdown()

    passed, report = verdict(results, _topic_list_problems(expected))
    print(report, flush=True)
    return 0 if passed else 1


if __name__ == '__main__':
    sys.exit(main())
