"""The parameter table, config/bridge.yaml and rviz/mlmap.rviz agree with each other."""

from pathlib import Path
import re

from mlmap_bridge import checks
from mlmap_bridge.parameters import (CLOUD_LAYERS, defaults, in_namespace, PARAMETERS,
                                     prefixed_frame)
import pytest
import yaml

PACKAGE = Path(__file__).resolve().parents[1]


def _yaml(relative: str):
    return yaml.safe_load((PACKAGE / relative).read_text())


def test_names_are_unique_and_described():
    """Every parameter has a ROS-valid name, once, and a description (ParameterDescriptor)."""
    names = [p.name for p in PARAMETERS]
    assert len(names) == len(set(names))
    for p in PARAMETERS:
        assert p.name.isidentifier() and p.name == p.name.lower()
        assert len(p.description) > 10, p.name


def test_bridge_yaml_lists_every_parameter_with_its_default_and_type():
    """The launch file's params file: same names, values and types (ROS parameters are typed:
    0 where the node declared 0.0 would be refused)."""
    listed = _yaml('config/bridge.yaml')['mlmap_bridge']['ros__parameters']
    assert list(listed) == [p.name for p in PARAMETERS]
    for name, default in defaults().items():
        assert type(listed[name]) is type(default) and listed[name] == default, name


def test_every_cloud_layer_has_its_parameters():
    """<name>_topic, <name>_max_rate_hz and a cube size for each layer; a grid and status too."""
    names = set(defaults())
    for layer in CLOUD_LAYERS:
        assert {f'{layer.name}_topic', f'{layer.name}_max_rate_hz',
                layer.cube_size_parameter} <= names
        assert layer.color_by in ('height', 'distance')
    assert {'grid_topic', 'grid_max_rate_hz', 'status_topic', 'output_prefix'} <= names


def test_checker_expects_the_bridge_outputs_under_the_default_prefix():
    """checks.BRIDGE_TOPICS are what the bridge publishes with its defaults."""
    prefix = defaults()['output_prefix']
    outputs = {f'{prefix}/{layer.name}' for layer in CLOUD_LAYERS}
    outputs |= {f'{prefix}/grid', f'{prefix}/status', f'{prefix}/status_text'}
    assert {e.topic for e in checks.BRIDGE_TOPICS} == outputs
    assert defaults()['body_frame'] == checks.Frames().body


def _displays():
    config = _yaml('rviz/mlmap.rviz')['Visualization Manager']
    return config, {d['Topic']['Value']: d for d in config['Displays'] if 'Topic' in d}


def test_rviz_shows_every_output_in_the_world_frame():
    """A display per marker topic and the grid, QoS the bridge serves, fixed frame = map."""
    config, displays = _displays()
    assert config['Global Options']['Fixed Frame'] == checks.Frames().world
    classes = {d['Class'] for d in config['Displays']}
    assert {'rviz_default_plugins/TF', 'rviz_default_plugins/Grid'} <= classes
    prefix = defaults()['output_prefix']
    expected = {f'{prefix}/{layer.name}': ('MarkerArray', layer.latched) for layer in CLOUD_LAYERS}
    expected[f'{prefix}/status'] = ('MarkerArray', False)
    expected[f'{prefix}/grid'] = ('Map', True)
    for topic, (kind, latched) in expected.items():
        display = displays[topic]
        assert display['Class'] == f'rviz_default_plugins/{kind}' and display['Enabled'], topic
        qos = display['Topic']
        assert qos['Reliability Policy'] == 'Reliable', topic
        # A TRANSIENT_LOCAL subscription to a VOLATILE publisher would never match.
        assert qos['Durability Policy'] == ('Transient Local' if latched else 'Volatile'), topic


def test_rviz_shows_the_node_topics_without_the_bridge():
    """The node's own grid and occupied voxels, each with the node writer's QoS."""
    _, displays = _displays()
    node = {e.topic: e for e in checks.NODE_TOPICS}
    expected = {'/mlmap/grid': 'Map', '/mlmap/global_map/occupied': 'PointCloud2',
                '/mlmap/local_map/occupied': 'PointCloud2'}
    for topic, kind in expected.items():
        display = displays[topic]
        assert display['Class'] == f'rviz_default_plugins/{kind}' and display['Enabled'], topic
        qos = display['Topic']
        assert qos['Reliability Policy'] == 'Reliable', topic
        assert qos['Durability Policy'] == ('Transient Local' if node[topic].latched
                                            else 'Volatile'), topic


@pytest.mark.parametrize('relative', ['launch/bridge.launch.py', 'launch/mlmap.launch.py',
                                      'config/bridge.yaml',
                                      'rviz/mlmap.rviz', 'resource/mlmap_bridge'])
def test_installed_files_exist(relative):
    """setup.py installs these by glob; a missing one would silently not be installed."""
    assert (PACKAGE / relative).is_file()


def test_namespace_and_frame_prefix_follow_mlmap_node():
    """dds.ns puts the node's topics (and the bridge's outputs) under /<ns>; tf stays absolute;
    dds.frame_prefix prefixes the body and sensor frames."""
    assert in_namespace('', '/mlmap/grid') == '/mlmap/grid'
    assert in_namespace('uav1', '/mlmap/grid') == '/uav1/mlmap/grid'
    assert in_namespace('/uav1/', 'mlmap/viz') == '/uav1/mlmap/viz'
    assert in_namespace('uav1', '') == '', 'a disabled topic stays disabled'
    assert prefixed_frame('', 'base_link') == 'base_link'
    assert prefixed_frame('uav1', 'base_link') == 'uav1/base_link'
    node = {e.topic for e in checks.node_topics('uav1')}
    assert '/uav1/mlmap/status' in node and '/tf' in node and '/tf_static' in node
    assert not any(t.startswith('/mlmap/') for t in node)
    default_outputs = (e.topic for e in checks.BRIDGE_TOPICS)
    assert {e.topic for e in checks.bridge_topics('uav1')} == {
        t.replace('/mlmap/viz', '/uav1/mlmap/viz') for t in default_outputs}
    assert checks.node_topics() == checks.NODE_TOPICS


def test_the_node_declares_every_parameter_read_only():
    """The bridge reads its parameters once at start, so it declares them read-only (a `ros2
    param set` is refused with the reason instead of being accepted and ignored). No rclpy
    runs here: the declaration in bridge_node.py is read as written."""
    source = (Path(__file__).resolve().parents[1] / 'mlmap_bridge' / 'bridge_node.py').read_text()
    declarations = re.findall(r'self\.declare_parameter\((.*?)\)\)', source, re.S)
    assert declarations, 'no parameter declaration found'
    assert all('read_only=True' in d for d in declarations), declarations
