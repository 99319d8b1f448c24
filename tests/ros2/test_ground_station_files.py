"""The ROS 2 packages, containers and docs agree with mlmap and with each other.

No ROS 2 and no Docker engine run on the project's machines, so these files cannot be run here.
This test checks what can be checked without them: the package manifests (catkin_pkg, colcon's
own discovery, a colcon install of the bridge), the bridge's and checker's topics and frames
against mlmap_node's documented defaults, and the containers' files against the commands the
rest of the test suite runs (tools/demo.sh's build, mlmap_node's configuration parser, the
programs' --help). Set MLMAP_BIN_DIR to the folder holding mlmap_node (ctest does) to check the
compose commands against the real programs.
"""

import ast
import os
from pathlib import Path
import re
import shlex
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

from catkin_pkg.package import parse_package
from mlmap_bridge import checks, launch_support
from mlmap_bridge.parameters import defaults
import pytest
import yaml

REPO = Path(__file__).resolve().parents[2]
ROS2 = REPO / 'tools' / 'ros2'
BRIDGE = ROS2 / 'mlmap_bridge'
DOCKER = REPO / 'docker'
SYSTEM_PYTHON = '/usr/bin/python3'


def _yaml(path: Path):
    return yaml.safe_load(path.read_text())


# ---- Package manifests --------------------------------------------------------------------------

def _package(path: Path):
    warnings = []
    package = parse_package(str(path), warnings=warnings)
    package.validate(warnings=warnings)
    assert warnings == [], warnings
    return package


def test_manifests_are_valid_format_3_with_their_build_types():
    """Each package.xml parses and validates; build types as colcon must see them."""
    expected = {REPO: ('mlmap', 'cmake'), ROS2 / 'mlmap_msgs': ('mlmap_msgs', 'ament_cmake'),
                BRIDGE: ('mlmap_bridge', 'ament_python')}
    for path, (name, build_type) in expected.items():
        package = _package(path)
        assert (package.name, package.get_build_type(), package.package_format) == \
            (name, build_type, 3)
    assert 'rosidl_interface_packages' in [
        g.name for g in _package(ROS2 / 'mlmap_msgs').member_of_groups]


def test_versions_agree():
    """The root package.xml has CMake's project version; setup.py has the bridge's."""
    cmake_version = re.search(r'project\(mlmap VERSION ([\d.]+)',
                              (REPO / 'CMakeLists.txt').read_text()).group(1)
    assert _package(REPO).version == cmake_version
    setup_version = re.search(r"version='([\d.]+)'", (BRIDGE / 'setup.py').read_text()).group(1)
    assert _package(BRIDGE).version == setup_version


# What each find_package() of CMakeLists.txt is called in rosdep (None: nothing to install).
ROSDEP_KEYS = {'Eigen3': 'eigen', 'Threads': None, 'yaml-cpp': 'yaml-cpp',
               'OpenCVLite': 'libopencv-dev', 'CLI11': 'cli11', 'spdlog': 'spdlog',
               'fastcdr': 'fastcdr', 'fastrtps': 'fastrtps', 'GTest': 'gtest',
               'octomap': 'octomap', 'nlohmann_json': 'nlohmann-json-dev',
               'PkgConfig': 'pkg-config', 'SQLite3': 'libsqlite3-dev',
               'dynamicEDT3D': 'dynamic_edt_3d', 'PNG': 'libpng-dev', 'Python3': 'python3'}


def test_root_manifest_depends_on_everything_cmake_finds():
    """A new find_package() must get its rosdep key in package.xml (and here)."""
    found = set()
    for cmake in [REPO / 'CMakeLists.txt', REPO / 'tests' / 'CMakeLists.txt',
                  *sorted((REPO / 'src').rglob('CMakeLists.txt'))]:
        code = re.sub(r'#.*', '', cmake.read_text())
        found |= set(re.findall(r'find_package\(([\w-]+)', code))
    unknown = found - set(ROSDEP_KEYS)
    assert not unknown, f'add the rosdep keys of {unknown} to package.xml and ROSDEP_KEYS'
    package = _package(REPO)
    declared = {d.name for d in package.build_depends + package.test_depends}
    for name in found:
        assert ROSDEP_KEYS[name] is None or ROSDEP_KEYS[name] in declared, name


def _imports(path: Path):
    """Top-level names of the modules a Python file imports (relative imports excluded)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name.split('.')[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module.split('.')[0])
    return names


PYTHON_KEYS = {'numpy': 'python3-numpy', 'pytest': 'python3-pytest', 'yaml': 'python3-yaml'}
TEST_HELPERS = {'cloud_helpers', 'fake_msgs', 'marker_reader', 'mlmap_bridge'}


def test_bridge_manifest_declares_every_import():
    """Every module the bridge imports is an exec_depend, every test import a test_depend."""
    package = _package(BRIDGE)
    exec_depends = {d.name for d in package.exec_depends}
    test_depends = {d.name for d in package.test_depends} | exec_depends
    sources = list((BRIDGE / 'mlmap_bridge').glob('*.py')) + list((BRIDGE / 'launch').glob('*.py'))
    for files, declared in ((sources, exec_depends),
                            (list((BRIDGE / 'test').glob('*.py')), test_depends)):
        for path in files:
            for name in _imports(path) - set(sys.stdlib_module_names) - TEST_HELPERS:
                assert PYTHON_KEYS.get(name, name) in declared, f'{path.name} imports {name}'


def _colcon(*args, cwd=REPO):
    return subprocess.run(['colcon', '--log-base', os.devnull, *args], cwd=cwd, check=True,
                          capture_output=True, text=True).stdout


def test_colcon_sees_mlmap_as_cmake_and_the_ros2_packages_from_their_path():
    """colcon stops at the root package, so docs/ground-station.md builds tools/ros2 from its own
    path."""
    def listed(path):
        rows = [line.split('\t') for line in _colcon('list', '--base-paths', path).splitlines()]
        return sorted(f'{name} {kind}' for name, _, kind in rows)
    assert listed(str(REPO)) == ['mlmap (ros.cmake)']
    assert listed(str(ROS2)) == ['mlmap_bridge (ros.ament_python)', 'mlmap_msgs (ros.ament_cmake)']


def test_colcon_installs_the_bridge_where_ros2_finds_it(tmp_path):
    """A colcon build (no ROS needed for an ament_python package) installs the executables
    where `ros2 run` looks, the launch, parameter and RViz files, and importable modules."""
    _colcon('build', '--base-paths', str(BRIDGE), '--build-base', str(tmp_path / 'build'),
            '--install-base', str(tmp_path / 'install'), cwd=tmp_path)
    prefix = tmp_path / 'install' / 'mlmap_bridge'
    for relative in ('lib/mlmap_bridge/mlmap_bridge', 'lib/mlmap_bridge/mlmap_check',
                     'share/ament_index/resource_index/packages/mlmap_bridge',
                     'share/mlmap_bridge/package.xml', 'share/mlmap_bridge/config/bridge.yaml',
                     'share/mlmap_bridge/launch/bridge.launch.py',
                     'share/mlmap_bridge/launch/mlmap.launch.py',
                     'share/mlmap_bridge/rviz/mlmap.rviz'):
        assert (prefix / relative).is_file(), relative
    site = next(prefix.glob('lib/python3*/site-packages'))
    probe = ('from mlmap_bridge import checks, conversions, launch_support, markers, parameters; '
             'print(conversions.__file__)')
    out = subprocess.run([SYSTEM_PYTHON, '-c', probe], env={'PYTHONPATH': str(site)},
                         check=True, capture_output=True, text=True).stdout
    assert out.startswith(str(site))


@pytest.mark.skipif(not os.environ.get('MLMAP_BIN_DIR'),
                    reason='MLMAP_BIN_DIR (the build) not given')
def test_the_launch_finds_the_installed_node_configuration(tmp_path):
    """mlmap.launch.py's default node_config is the one `cmake --install` (colcon) puts under a
    prefix of the workspace's environment, and the node runs with its defaults when none is."""
    # The programs land at the top of the build tree, so MLMAP_BIN_DIR is the build tree.
    subprocess.run(['cmake', '--install', os.environ['MLMAP_BIN_DIR'],
                    '--prefix', str(tmp_path / 'mlmap')], check=True, capture_output=True)
    installed = tmp_path / 'mlmap' / launch_support.NODE_CONFIG
    assert installed.read_text() == (REPO / 'config' / 'mlmap_node.yaml').read_text()
    assert (tmp_path / 'mlmap' / 'bin' / 'mlmap_node').is_file()
    environ = {'CMAKE_PREFIX_PATH': os.pathsep.join(['/nonexistent', str(tmp_path / 'mlmap')])}
    assert launch_support.installed_node_config(environ) == str(installed)
    assert launch_support.installed_node_config({}) == ''
    assert launch_support.node_command('mlmap_node', str(installed)) == \
        ['mlmap_node', '--config', str(installed)]
    assert launch_support.node_command('mlmap_node', '') == ['mlmap_node']
    launch = (BRIDGE / 'launch' / 'mlmap.launch.py').read_text()
    for argument in ('node_config', 'node_executable', 'node', 'bridge', 'params_file', 'rviz'):
        assert f"DeclareLaunchArgument(\n            '{argument}'" in launch, argument


# ---- Topics, types and frames against mlmap_node -------------------------------------------

def test_bridge_defaults_are_the_node_defaults():
    """Topic names, body frame and ESDF clamp distance of config/mlmap_node.yaml / mlmap.yaml."""
    dds = _yaml(REPO / 'config' / 'mlmap_node.yaml')['dds']
    params = defaults()
    for name in ('awareness', 'local_map', 'global_map', 'esdf_slice', 'grid', 'status'):
        assert params[f'{name}_topic'] == '/' + dds['topics'][name], name
    assert params['body_frame'] == dds['body_frame']
    assert checks.Frames() == checks.Frames(dds['world_frame'], dds['body_frame'],
                                            dds['sensor_frame'])
    esdf = _yaml(REPO / 'config' / 'mlmap.yaml')['esdf']
    assert params['esdf_max_distance_m'] == esdf['max_distance_m']


def _documented_outputs():
    """(topic, type, latched) of each output row of idl/README.md's topic table."""
    rows = []
    for line in (REPO / 'idl' / 'README.md').read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if len(cells) == 5 and cells[0].startswith('/') and not cells[3].startswith('reader'):
            package, name = cells[2].split()[0].split('/')
            rows.append((cells[0], f'{package}/msg/{name}', 'TRANSIENT_LOCAL' in cells[3]))
    return rows


def test_checker_expects_every_documented_output_with_its_type_and_durability():
    """checks.NODE_TOPICS is idl/README.md's output table: topics, types, latching."""
    documented = _documented_outputs()
    assert len(documented) == 10
    expected = [(e.topic, e.type_name, e.latched) for e in checks.NODE_TOPICS]
    assert sorted(expected) == sorted(documented)


def test_checker_rates_are_the_node_default_rates():
    """Each rate the checker holds the node to is that topic's rates.* in mlmap_node.yaml."""
    dds = _yaml(REPO / 'config' / 'mlmap_node.yaml')['dds']
    rate_of = {'awareness': 'awareness_hz', 'local_map': 'local_map_hz', 'grid': 'grid_hz',
               'esdf_slice': 'esdf_hz', 'esdf_block': 'esdf_hz', 'status': 'status_hz'}
    expected = {'/' + dds['topics'][topic]: dds['rates'][rate] for topic, rate in rate_of.items()}
    checked = {e.topic: e.nominal_hz for e in checks.NODE_TOPICS if e.nominal_hz > 0}
    assert checked == expected


def test_nav2_costmaps_read_the_node_grids_with_matching_qos():
    """config/nav2/costmaps.yaml: a static layer on each of the node's grids, TRANSIENT_LOCAL
    subscriptions (the grids are latched), the node's frames and resolution."""
    costmaps = _yaml(REPO / 'config' / 'nav2' / 'costmaps.yaml')
    node = {e.topic: e for e in checks.NODE_TOPICS}
    dds = _yaml(REPO / 'config' / 'mlmap_node.yaml')['dds']
    resolution = _yaml(REPO / 'config' / 'mlmap.yaml')['local_map']['resolution_m']
    expected = {'global_costmap': ('/' + dds['topics']['map_grid'], False),
                'local_costmap': ('/' + dds['topics']['grid'], True)}
    for name, (topic, rolling) in expected.items():
        params = costmaps[name][name]['ros__parameters']
        assert params['rolling_window'] is rolling, name
        assert params['global_frame'] == dds['world_frame'], name
        assert params['robot_base_frame'] == dds['body_frame'], name
        assert params['resolution'] == resolution, name
        static = params[params['plugins'][0]]
        assert static['plugin'] == 'nav2_costmap_2d::StaticLayer', name
        assert static['map_topic'] == topic, name
        assert node[topic].type_name == 'nav_msgs/msg/OccupancyGrid' and node[topic].latched
        assert static['map_subscribe_transient_local'] is True, name


# ---- Containers ---------------------------------------------------------------------------------

def _compose():
    return _yaml(DOCKER / 'compose.yaml')


def _dockerfile(name: str):
    """Instructions of a Dockerfile as (KEYWORD, arguments) with continuation lines joined."""
    text = re.sub(r'\\\n', ' ', (DOCKER / name).read_text())
    lines = [line.strip() for line in text.splitlines()]
    return [tuple(line.split(None, 1)) for line in lines if line and not line.startswith('#')]


def test_compose_services_share_one_dds_setup():
    """Four services, one domain, UDP only through the same profile file in both images."""
    services = _compose()['services']
    assert set(services) == {'node', 'publisher', 'bridge', 'checker'}
    environments = [s['environment'] for s in services.values()]
    assert all(env == environments[0] for env in environments)
    env = environments[0]
    assert env['ROS_DOMAIN_ID'] == '${ROS_DOMAIN_ID:-0}'
    assert env['RMW_IMPLEMENTATION'] == 'rmw_fastrtps_cpp'
    assert env['FASTRTPS_DEFAULT_PROFILES_FILE'] == '/opt/mlmap/config/dds/udp_only.xml'
    for service in services.values():
        assert (REPO / 'docker' / service['build']['context'] /
                service['build']['dockerfile']).is_file()
    assert services['checker']['profiles'] == ['test']


def test_the_profile_is_udp_only_and_in_both_images_at_the_same_path():
    """No shared memory between containers: the default profile has UDPv4 alone."""
    ns = {'f': 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'}
    root = ElementTree.parse(REPO / 'config' / 'dds' / 'udp_only.xml').getroot()
    kinds = [t.find('f:type', ns).text for t in root.iterfind('.//f:transport_descriptor', ns)]
    assert kinds == ['UDPv4']
    participant = root.find('.//f:participant', ns)
    assert participant.get('is_default_profile') == 'true'
    assert participant.find('.//f:useBuiltinTransports', ns).text == 'false'
    ground = _dockerfile('ground.Dockerfile')
    for image in ('onboard.Dockerfile', 'sim.Dockerfile'):
        mlmap = _dockerfile(image)
        assert ('WORKDIR', '/opt/mlmap') in mlmap and ('COPY', 'config ./config') in mlmap, image
    assert ('COPY', 'config/dds/udp_only.xml /opt/mlmap/config/dds/udp_only.xml') in ground


def _stages(instructions):
    """The stages of a Dockerfile: lists of instructions, each starting with its FROM."""
    stages = []
    for instruction in instructions:
        if instruction[0] == 'FROM':
            stages.append([])
        stages[-1].append(instruction)
    return stages


def test_every_image_of_mlmap_starts_from_the_local_debian_base():
    """Every FROM is debian:12 (a stage's name aside), the base tools/container_images.sh makes
    without a registry: no other image is pulled."""
    for image in ('onboard.Dockerfile', 'sim.Dockerfile'):
        for stage in _stages(_dockerfile(image)):
            assert stage[0][1].split()[0] == 'debian:12', image


def test_sim_image_builds_like_tools_demo_sh():
    """Debian 12, Debian packages through install_deps.sh, and demo.sh's configure (with the
    programs on again, after the onboard build stage it starts with) and its targets."""
    sim = _dockerfile('sim.Dockerfile')
    runs = ' && '.join(args for keyword, args in sim if keyword == 'RUN')
    assert 'bash tools/install_deps.sh --programs' in runs
    assert '--programs)' in (REPO / 'tools' / 'install_deps.sh').read_text()
    demo = (REPO / 'tools' / 'demo.sh').read_text()
    configure = re.search(r'cmake -S \. -B build[^\n>]*', demo).group(0).split()
    in_image = re.findall(r'cmake -S \. -B build[^&\n]*', runs)[-1].split()
    assert in_image == configure + ['-DMLMAP_BUILD_APPS=ON']
    targets = re.search(r'cmake --build build[^\n>]*', demo).group(0).split()
    in_image = re.findall(r'cmake --build build[^&\n]*', runs)[-1].split()
    assert in_image == targets + ['mlmap_map_tool']


def test_sim_image_starts_with_the_onboard_build_stage():
    """The onboard image's build stage, instruction for instruction, so that a builder with a
    layer cache compiles mlmap_node's libraries once for both images."""
    build_stage = _stages(_dockerfile('onboard.Dockerfile'))[0]
    assert build_stage[0] == ('FROM', 'debian:12 AS build')
    common = [i for i in build_stage[1:] if 'runtime_packages' not in i[1]]
    sim = _dockerfile('sim.Dockerfile')
    assert sim[:len(common) + 1] == [('FROM', 'debian:12')] + common


def test_onboard_image_builds_mlmap_node_alone_without_opencv_or_octomap():
    """The onboard image builds only what mlmap_node needs, and holds only what it loads."""
    build, image = _stages(_dockerfile('onboard.Dockerfile'))
    runs = ' && '.join(args for keyword, args in build if keyword == 'RUN')
    assert 'bash tools/install_deps.sh --onboard' in runs
    assert '-DMLMAP_BUILD_APPS=OFF' in runs and '-DMLMAP_BUILD_TESTS=OFF' in runs
    assert re.search(r'cmake --build build -j2 --target mlmap_node\b', runs)
    assert 'bash docker/runtime_packages.sh build/mlmap_node > build/runtime_packages.txt' in runs
    # The image: the runtime packages, the program and the configurations; no install_deps.sh.
    image_runs = ' && '.join(args for keyword, args in image if keyword == 'RUN')
    assert 'install_deps' not in image_runs and '/tmp/runtime_packages.txt' in image_runs
    copied = [args for keyword, args in image if keyword == 'COPY']
    assert copied == [
        '--from=build /opt/mlmap/build/runtime_packages.txt /tmp/runtime_packages.txt',
        '--from=build /opt/mlmap/build/mlmap_node bin/mlmap_node', 'config ./config']
    assert ('ENV', 'PATH=/opt/mlmap/bin:$PATH') in image
    assert dict(image)['CMD'].startswith('["mlmap_node"')
    # What --onboard installs: bash's own expansion of the script's lists, not a copy of them.
    script = (REPO / 'tools' / 'install_deps.sh').read_text()
    listing = script[:script.index('missing=()')] + 'printf "%s\\n" "${packages[@]}"\n'
    onboard_packages = subprocess.run(['bash', '-c', listing, 'install_deps', '--onboard'],
                                      check=True, capture_output=True, text=True).stdout.split()
    everything = subprocess.run(['bash', '-c', listing, 'install_deps'], check=True,
                                capture_output=True, text=True).stdout.split()
    assert 'libfastrtps-dev' in onboard_packages and 'libyaml-cpp-dev' in onboard_packages
    assert not [p for p in onboard_packages if 'opencv' in p or 'octomap' in p]
    assert set(onboard_packages) < set(everything)


def _cmake_reads():
    """Top-level folders that the CMakeLists.txt files read (src/, idl, cmake, ...), and the
    files of tools/ they run."""
    used = set()
    for cmake in [REPO / 'CMakeLists.txt', *REPO.glob('src/**/CMakeLists.txt')]:
        text = cmake.read_text()
        pattern = r'(?:PROJECT_SOURCE_DIR\}/|[\s(])(cmake|idl|include|src|tests)\b[/)]'
        used |= set(re.findall(pattern, text))
        used |= set(re.findall(r'PROJECT_SOURCE_DIR\}/(tools/[\w.]+)', text))
    return used


def test_images_copy_everything_cmake_reads():
    """Each top-level folder the CMakeLists.txt files name, and each tools/ script the build
    runs, is copied into both mlmap images; of tests/, the images (built without the tests)
    need tests/benchmarks alone, built with the programs, and only where they are built."""
    used = _cmake_reads()
    assert {'cmake', 'idl', 'include', 'src', 'tests', 'tools/idl_type_hashes.py'} <= used
    top = (REPO / 'CMakeLists.txt').read_text()
    assert 'add_subdirectory(tests/benchmarks)' in top and 'add_subdirectory(tests)' in top
    benchmarks = (REPO / 'tests' / 'benchmarks' / 'CMakeLists.txt').read_text()
    assert 'CMAKE_CURRENT_SOURCE_DIR}/..' not in benchmarks
    assert 'PROJECT_SOURCE_DIR}/tests' not in benchmarks
    programs = (used - {'tests'}) | {'tests/benchmarks'}
    for image, needed in (('onboard.Dockerfile', used - {'tests'}), ('sim.Dockerfile', programs)):
        copied = {source for keyword, args in _dockerfile(image) if keyword == 'COPY'
                  and not args.startswith('--from') for source in args.split()[:-1]}
        assert needed | {'CMakeLists.txt', 'config'} <= copied, image


def test_ground_image_builds_tests_and_runs_the_bridge():
    """ros:jazzy, tools/ros2 built and tested with colcon, the bridge as in compose."""
    ground = _dockerfile('ground.Dockerfile')
    assert ground[0] == ('FROM', 'ros:jazzy')
    assert ('COPY', 'tools/ros2 src/mlmap_ros2') in ground
    assert ('WORKDIR', '/opt/mlmap_ws') in ground
    runs = ' '.join(args for keyword, args in ground if keyword == 'RUN')
    for step in ('rosdep install --from-paths src', 'colcon build', 'colcon test',
                 'colcon test-result'):
        assert step in runs, step
    entrypoint = (DOCKER / 'ground_entrypoint.sh').read_text()
    assert 'source /opt/ros/jazzy/setup.bash --' in entrypoint
    assert 'source /opt/mlmap_ws/install/setup.bash --' in entrypoint
    assert 'exec "$@"' in entrypoint
    assert os.access(DOCKER / 'ground_entrypoint.sh', os.X_OK)
    cmd = dict(ground)['CMD']
    assert ast.literal_eval(cmd) == _compose()['services']['bridge']['command']


def _command(service: str):
    """A service's command as a list of words (a `sh -c` script split like a shell would)."""
    command = _compose()['services'][service]['command']
    if command[:2] == ['sh', '-c']:
        return shlex.split(command[2])
    return command


def test_commands_name_the_programs_and_files_the_images_hold():
    """Node and camera use one existing config; the programs are built, the checker's and the
    launch file's options exist."""
    node, publisher = _command('node'), _command('publisher')
    assert node[0] == 'mlmap_node' and 'mlmap_sensor_publisher' in publisher
    config = node[node.index('--config') + 1]
    assert publisher[publisher.index('--config') + 1] == config
    assert (REPO / config).is_file() and config.startswith('config/')
    assert '--mode' in publisher and publisher[publisher.index('--mode') + 1] == 'depth'
    assert 'mlmap_node' in (REPO / 'tools' / 'demo.sh').read_text()
    checker = _command('checker')
    assert checker[:4] == ['ros2', 'run', 'mlmap_bridge', 'mlmap_check']
    source = (BRIDGE / 'mlmap_bridge' / 'checker_node.py').read_text()
    for option in (w for w in checker if w.startswith('--')):
        assert f"'{option}'" in source, option
    assert "'mlmap_check = mlmap_bridge.checker_node:main'" in (BRIDGE / 'setup.py').read_text()
    bridge = _command('bridge')
    launch = (BRIDGE / 'launch' / 'bridge.launch.py').read_text()
    for argument in (w.split(':=')[0] for w in bridge if ':=' in w):
        assert f"DeclareLaunchArgument(\n            '{argument}'" in launch, argument
    script = (DOCKER / 'run_integration_test.sh').read_text()
    assert 'run --rm checker' in script and 'exit "$verdict"' in script


def test_the_podman_test_runs_the_images_as_compose_does():
    """tests/integration/containers_podman.sh: compose's DDS environment with a domain of its
    own, the node's compose configuration, the camera in depth mode, and the images of
    tools/container_images.sh run in the test's own network namespaces."""
    script = (REPO / 'tests' / 'integration' / 'containers_podman.sh').read_text()
    env = dict(re.findall(r'-e "?(\w+)=([^"\s)]+)', script))
    compose_env = dict(_compose()['services']['node']['environment'])
    assert env.pop('ROS_DOMAIN_ID') == '$domain' and compose_env.pop('ROS_DOMAIN_ID')
    assert env == compose_env
    assert re.search(r'^domain=211 ', script, re.MULTILINE)
    node = _command('node')
    assert f'cat {node[node.index("--config") + 1]}' in script
    assert '--mode depth' in script
    assert 'bash tools/container_images.sh --env' in script
    assert '--network "ns:/proc/$ns/ns/net"' in script
    # The test command's last part; CI runs exactly the test command.
    test_command = (REPO / 'tools' / 'test.sh').read_text()
    assert 'bash tests/integration/containers_podman.sh' in test_command
    assert (REPO / '.ci' / 'run').read_text().rstrip().endswith('bash tools/test.sh')


BIN_DIR = os.environ.get('MLMAP_BIN_DIR')
needs_binaries = pytest.mark.skipif(not BIN_DIR, reason='MLMAP_BIN_DIR (mlmap_node) not given')


@needs_binaries
@pytest.mark.parametrize('service', ['node', 'publisher'])
def test_compose_options_exist_in_the_programs(service):
    """Every --option of the compose commands is one the program lists in --help."""
    words = _command(service)
    program = next(w for w in words if w.startswith('mlmap_'))
    helptext = subprocess.run([str(Path(BIN_DIR) / program), '--help'], check=True,
                              capture_output=True, text=True).stdout
    for option in (w for w in words if w.startswith('--')):
        assert re.search(rf'(^|[\s,]){re.escape(option)}\b', helptext), f'{program} {option}'


@needs_binaries
def test_mlmap_node_accepts_the_compose_configuration():
    """mlmap_node's own strict parser reads the file (unknown keys and bad values fail)."""
    node = _command('node')
    config = node[node.index('--config') + 1]
    printed = subprocess.run([str(Path(BIN_DIR) / 'mlmap_node'), '--config', config,
                              '--print-config'], cwd=REPO, check=True, capture_output=True,
                             text=True).stdout
    topics = yaml.safe_load(printed)['dds']['topics']
    assert topics['cloud'] == '' and topics['depth_image'] and topics['camera_info']


# ---- Docs ----------------------------------------------------------------------------------

def test_readme_gives_the_ground_station_commands():
    """The newcomer's commands are in the ground-station page the README links to, name real
    services, and it says what CI does not run."""
    assert '(docs/ground-station.md)' in (REPO / 'README.md').read_text()
    section = (REPO / 'docs' / 'ground-station.md').read_text()
    assert section.startswith('# Ground station (ROS 2 Jazzy)\n')
    for command in ('ln -s "$PWD/tools/ros2" ~/mlmap_ws/src/', 'colcon build',
                    'source ~/mlmap_ws/install/setup.bash',
                    'ros2 launch mlmap_bridge bridge.launch.py',
                    'rviz2 -d tools/ros2/mlmap_bridge/rviz/mlmap.rviz',
                    'bash docker/run_integration_test.sh', '-DBUILD_TESTING=OFF'):
        assert command in section, command
    assert (REPO / 'tools/ros2/mlmap_bridge/rviz/mlmap.rviz').is_file()
    started = re.search(r'docker compose -f docker/compose.yaml up -d ([\w ]+)', section)
    assert set(started.group(1).split()) == {'node', 'publisher'}
    assert set(started.group(1).split()) <= set(_compose()['services'])
    assert 'No Docker engine runs on the CI machines' in section


def test_the_bridge_colours_vehicles_as_the_merger_does():
    """fleet_paths.FLEET_PALETTE is fleet::vehicleColourRgb's palette (src/fleet/fleet_map.cpp)."""
    from mlmap_bridge.fleet_paths import FLEET_PALETTE
    source = (REPO / 'src' / 'fleet' / 'fleet_map.cpp').read_text()
    palette = re.search(r'kPalette\[\] = \{([^}]*)\}', source).group(1)
    assert tuple(int(v, 16) for v in re.findall(r'0x[0-9a-fA-F]+', palette)) == FLEET_PALETTE
