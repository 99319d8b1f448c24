"""Lets the tests import mlmap_bridge from the source tree (no colcon install needed)."""

from pathlib import Path
import sys

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
