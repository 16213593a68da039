"""ament_python package safe_legged_c3bf; installable with pip (ROS 2 from PyPI) or colcon."""

import os
from glob import glob

from setuptools import find_packages, setup

PACKAGE = "safe_legged_c3bf"

# With a full ROS 2 install (ROS_DISTRO set by its setup script) the ROS packages come from
# there; otherwise pip takes them from the ros-jazzy-* wheels on PyPI.
ROS_WHEELS = [
    "ros-jazzy-rclpy[fastrtps]",
    "ros-jazzy-common-interfaces",
    "ros-jazzy-std-msgs",
    "ros-jazzy-geometry-msgs",
    "ros-jazzy-nav-msgs",
    "ros-jazzy-sensor-msgs",
    "ros-jazzy-visualization-msgs",
    "ros-jazzy-diagnostic-msgs",
    "ros-jazzy-rosgraph-msgs",
    "ros-jazzy-ament-index-python",
    # The interfaces package beside this one: pip install ./safe_legged_c3bf_msgs first or in
    # the same command (colcon builds it from source in a ROS workspace).
    "safe-legged-c3bf-msgs",
]
PYTHON_DEPS = [
    "numpy>=1.26",
    "scipy>=1.11",
    "osqp>=1.0",
    "daqp>=0.11",
    "pybullet>=3.2.6",
    "PyYAML>=6",
    "matplotlib>=3.8",
    "imageio>=2.30",
    "imageio-ffmpeg>=0.5",
    "mcap-ros2-support>=0.5",
    "pydantic>=2",
]


def _data_files():
    files = [
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
    ]
    config = glob("config/**/*.yaml", recursive=True) + glob("config/**/*.xml", recursive=True)
    for directory in sorted({os.path.dirname(p) for p in config}):
        files.append((f"share/{PACKAGE}/{directory}",
                      sorted(p for p in config if os.path.dirname(p) == directory)))
    return files


NODES = {
    "simulator": "simulator_node",
    "obstacle_tracker": "obstacle_tracker_node",
    "obstacle_detector": "obstacle_detector_node",
    "reference_planner": "reference_planner_node",
    "safety_filter": "safety_filter_node",
    "gait_controller": "gait_controller_node",
}

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "benchmarks"]),
    package_data={PACKAGE: ["description/*.urdf", "description/**/*"]},
    data_files=_data_files(),
    python_requires=">=3.11",
    install_requires=PYTHON_DEPS + ([] if os.environ.get("ROS_DISTRO") else ROS_WHEELS),
    extras_require={
        # The test extra includes Ray: the two-node campaign test runs in CI, never skipped.
        "test": ["pytest>=8", "hypothesis>=6.100", "ruff>=0.6", "pytest-timeout", "pytest-xdist>=3",
                 "ray>=2.9"],
        # Peers of benchmarks/peer_comparison.py (pulls JAX).
        "bench": ["cbfpy==0.1.0", "elastiqp[jax]>=0.2"],
        # evaluate --ray: campaigns as Ray tasks. Ray core is enough to start a local Ray,
        # join a cluster and run tasks; ray[default] (dashboard, ~40 more packages) is the
        # cluster operator's choice on the head node.
        "cluster": ["ray>=2.9"],
    },
    zip_safe=False,
    maintainer="safe_legged_c3bf maintainers",
    maintainer_email="maintainers@safe-legged-c3bf.invalid",
    description="Collision Cone CBF safety filter for legged robots: a ROS 2 Jazzy node graph",
    license="BSD-3-Clause",
    entry_points={
        "console_scripts": [f"{name} = {PACKAGE}.nodes.{mod}:main" for name, mod in NODES.items()]
        + [
            f"bringup = {PACKAGE}.bringup:main",
            f"echo = {PACKAGE}.echo:main",
            f"evaluate = {PACKAGE}.evaluate:main",
        ],
    },
)
