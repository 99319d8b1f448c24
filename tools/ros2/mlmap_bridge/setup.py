"""Install mlmap_bridge as a ROS 2 ament_python package (colcon build)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'mlmap_bridge'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/launch', glob('launch/*.launch.py')),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml')),
        ('share/' + PACKAGE + '/rviz', glob('rviz/*.rviz')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='mlmap dev',
    maintainer_email='dev@mlmap.dev',
    description="mlmap_node's layers as RViz2 markers, and the integration checker",
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'mlmap_bridge = mlmap_bridge.bridge_node:main',
            'mlmap_check = mlmap_bridge.checker_node:main',
            'mlmap_plan = mlmap_bridge.planner_node:main',
        ],
    },
)
