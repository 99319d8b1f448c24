"""Lets these tests import the bridge's ROS-free modules from the source tree."""

from pathlib import Path
import sys

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / 'tools' / 'ros2' / 'mlmap_bridge'))
