"""ROS 2 program `mlmap_check`: the verdict of the container integration test.

Subscribes to every mlmap_node output and every bridge output (checks.EXPECTED_TOPICS) with
the type the topic must have (BEST_EFFORT where the bridge reads so, RELIABLE elsewhere), feeds
each sample to its plausibility check and notes its arrival time and stamp (checks.py, unit
tested without ROS). It waits until every topic passed and the rates were observed for
--rate-window seconds, or the time is up; then it asks the ROS graph: `ros2 topic list -t`
lists each topic with its type, `ros2 node list` lists mlmap_node once, and
`ros2 topic info -v` shows mlmap_node's publisher of each of its topics with the type hash and
QoS. Prints one line per topic and exits 0 when everything passed, 1 otherwise.
"""

import argparse
import subprocess
import sys
import time
from typing import List, Optional, Tuple

import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args
from rosidl_runtime_py.utilities import get_message

from .checks import (bridge_topics, check_node_list, check_topic_info, check_topic_list,
                     Expectation, Frames, MAX_AGE_S, node_topics, parse_node_list,
                     parse_topic_list, RATE_FRACTION, sample_stamp_s, TopicResult, verdict)
from .parameters import prefixed_frame

DIRECT = ['--no-daemon', '--spin-time', '5']  # each command discovers the graph itself


def _subscribe(node: Node, result: TopicResult, frames: Frames) -> None:
    """Subscribe to one expected topic with the bridge's reliability, noting each arrival."""
    e = result.expectation
    qos = QoSProfile(
        depth=1, history=HistoryPolicy.KEEP_LAST,
        reliability=ReliabilityPolicy.RELIABLE if e.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if e.latched else DurabilityPolicy.VOLATILE)

    def on_sample(msg):
        result.record(e.check(msg, frames), time.time(), sample_stamp_s(msg))

    node.create_subscription(get_message(e.type_name), e.topic, on_sample, qos)


def _run(command: List[str]) -> Tuple[Optional[str], List[str]]:
    """Run a ros2 command; return its output, or None and why it failed."""
    try:
        output = subprocess.run(command, capture_output=True, text=True, timeout=60,
                                check=True).stdout
    except (OSError, subprocess.SubprocessError) as error:
        return None, [f'`{" ".join(command)}` failed: {error}']
    print(f'$ {" ".join(command)}\n{output}', flush=True)
    return output, []


def _graph_problems(expected: List[Expectation], node_topics_: List[Expectation],
                    namespace: str) -> List[str]:
    """Ask the ROS graph about the topics, the node and the node's publishers."""
    listed, problems = _run(['ros2', 'topic', 'list', '-t'] + DIRECT)
    if listed is not None:
        problems += check_topic_list(parse_topic_list(listed), expected)
    nodes, failed = _run(['ros2', 'node', 'list'] + DIRECT)
    problems += failed if nodes is None else check_node_list(parse_node_list(nodes), namespace)
    for e in (e for e in node_topics_ if e.by_node):  # tf may come from the robot instead
        info, failed = _run(['ros2', 'topic', 'info', '-v', e.topic] + DIRECT)
        problems += failed if info is None else check_topic_info(info, e, namespace)
    return problems


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
    parser.add_argument('--no-tf-static', action='store_true',
                        help='nobody publishes /tf_static (the node without publish_sensor_tf '
                             'and no robot_state_publisher): do not expect it')
    parser.add_argument('--rate-window', type=float, default=10.0,
                        help='seconds to observe the rates for, from the first sample')
    parser.add_argument('--rate-fraction', type=float, default=RATE_FRACTION,
                        help="least share of mlmap_node's default rate a topic must keep "
                             '(0: rates not checked)')
    parser.add_argument('--max-age', type=float, default=MAX_AGE_S,
                        help='seconds a sample may arrive after its stamp (the youngest one)')
    args = parser.parse_args(remove_ros_args(sys.argv if argv is None else argv)[1:])
    own = tuple(e for e in node_topics(args.namespace)
                if not (args.no_tf_static and e.topic == '/tf_static'))
    expected = own
    if not args.node_only:
        expected += bridge_topics(args.namespace, args.viz_prefix)
    results = [TopicResult(e) for e in expected]
    frames = Frames(args.world_frame, prefixed_frame(args.frame_prefix, args.body_frame),
                    prefixed_frame(args.frame_prefix, args.sensor_frame))

    rclpy.init(args=sys.argv if argv is None else argv)
    node = Node('mlmap_check')
    for result in results:
        _subscribe(node, result, frames)
    start = time.monotonic()
    deadline = start + args.timeout
    while rclpy.ok() and time.monotonic() < deadline and not (
            all(r.passed for r in results) and time.monotonic() - start >= args.rate_window):
        rclpy.spin_once(node, timeout_sec=0.2)
    node.destroy_node()
    rclpy.try_shutdown()

    passed, report = verdict(results, _graph_problems(expected, own, args.namespace),
                             args.rate_fraction, args.max_age)
    print(report, flush=True)
    return 0 if passed else 1


if __name__ == '__main__':
    sys.exit(main())
