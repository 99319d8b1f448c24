"""What mlmap.launch.py computes: where the installed node configuration is, and the command line.

Kept apart from the launch file so that it can be tested without ROS 2.
"""

import os
from pathlib import Path

# Where colcon (or cmake --install) puts the node's configurations, under an install prefix.
NODE_CONFIG = Path('share') / 'mlmap' / 'config' / 'mlmap_node.yaml'


def installed_node_config(environ=os.environ) -> str:
    """Find the node configuration installed under the first prefix of the environment.

    colcon lists a plain CMake package's prefix in CMAKE_PREFIX_PATH, an ament one's in
    AMENT_PREFIX_PATH; '' when no prefix holds it (mlmap_node then runs with its defaults).
    """
    for variable in ('CMAKE_PREFIX_PATH', 'AMENT_PREFIX_PATH'):
        for prefix in environ.get(variable, '').split(os.pathsep):
            if prefix and (Path(prefix) / NODE_CONFIG).is_file():
                return str(Path(prefix) / NODE_CONFIG)
    return ''


def node_command(executable: str, config: str) -> list:
    """Make mlmap_node's command line: the configuration only when one is given."""
    return [executable, '--config', config] if config else [executable]
