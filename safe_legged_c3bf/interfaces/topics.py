"""The topic contract of the graph, written once.

Every node, the bringup, the echo tool and the recorder take topic names and types from here,
and a test checks the README's table against it.

Twist semantics for legged robots (base_link frame, REP-103): linear.x forward, linear.y left,
angular.z yaw rate, linear.z vertical velocity of the body (ducking and rising). Every node
runs on sim time from ``/clock``. Names can be remapped with standard ROS remapping
(``--ros-args -r /cmd_vel:=/my_cmd``) or the bringup's ``--remap`` option.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class Topic:
    """One topic of the contract.

    Attributes:
        name: fully qualified topic name.
        type: ROS interface type, 'package/msg/Type'.
        publisher: the node that publishes it.
        description: what it carries, with frame and units.
        reliable: reliable (True) or best-effort (False) QoS.
        depth: history depth of the QoS profile.

    """

    name: str
    type: str
    publisher: str
    description: str
    reliable: bool = True
    depth: int = 10

    def msg_class(self) -> type:
        """Import and return the message class of this topic."""
        package, _, name = self.type.split("/")
        return getattr(importlib.import_module(f"{package}.msg"), name)


CLOCK = Topic(
    "/clock", "rosgraph_msgs/msg/Clock", "simulator",
    "simulation time; every node uses sim time", depth=1,
)
ODOM = Topic(
    "/odom", "nav_msgs/msg/Odometry", "simulator",
    "base pose in odom, twist in base_link (REP-105 odom -> base_link), 125 Hz (A1) / 100 Hz "
    "(biped)", depth=5,
)
IMU = Topic(
    "/imu", "sensor_msgs/msg/Imu", "simulator",
    "base orientation, angular velocity and acceleration (base_link), at the control rate",
    depth=5,
)
JOINT_STATES = Topic(
    "/joint_states", "sensor_msgs/msg/JointState", "simulator",
    "joint positions (rad), velocities (rad/s) and torques (N m), at the control rate",
    depth=5,
)
JOINT_COMMANDS = Topic(
    "/joint_commands", "safe_legged_c3bf_msgs/msg/MotorCommand", "gait_controller",
    "per-joint q, dq, kp, kd, tau for the motor drivers", depth=5,
)
OBSTACLE_DETECTIONS = Topic(
    "/obstacles/detections", "safe_legged_c3bf_msgs/msg/ObstacleArray",
    "simulator (oracle perception) / obstacle_detector (sensors perception)",
    "what perception sees: positions and shapes in odom, no velocities, noisy, with drop-outs",
)
OBSTACLES = Topic(
    "/obstacles", "safe_legged_c3bf_msgs/msg/ObstacleArray", "obstacle_tracker",
    "tracked obstacles with velocities and covariances, predicted to the stamp",
)
OBSTACLE_MARKERS = Topic(
    "/obstacles/markers", "visualization_msgs/msg/MarkerArray", "obstacle_tracker",
    "tracked obstacles and their inflated circles, for RViz/Foxglove",
)
SCAN = Topic(
    "/scan", "sensor_msgs/msg/LaserScan", "simulator (sensors perception) / robot driver",
    "2-D LiDAR ranges in lidar_link (x forward, angles about z), best effort; read by the "
    "obstacle detector and, to clear ghost tracks, the tracker", reliable=False,
    depth=5,
)
POINTS = Topic(
    "/points", "sensor_msgs/msg/PointCloud2", "simulator (sensors perception) / robot driver",
    "forward 3-D sensor, float32 x y z in depth_link, best effort", reliable=False, depth=5,
)
GOAL_POSE = Topic(
    "/goal_pose", "geometry_msgs/msg/PoseStamped", "user / bringup",
    "navigation goal in odom", depth=1,
)
CMD_VEL = Topic(
    "/cmd_vel", "geometry_msgs/msg/Twist", "reference_planner",
    "the planner's reference command (base_link); knows nothing about obstacles",
)
CMD_VEL_SAFE = Topic(
    "/cmd_vel_safe", "geometry_msgs/msg/Twist", "safety_filter",
    "the filtered command the gait controller follows (base_link)",
)
FILTER_STATE = Topic(
    "/c3bf/state", "safe_legged_c3bf_msgs/msg/SafetyFilterState", "safety_filter",
    "filter status, reference and filtered command, barrier values, solve time",
)
DIAGNOSTICS = Topic(
    "/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", "every node",
    "health: stale inputs, rejected messages, driver mode, filter status",
)
GROUND_TRUTH_SAFETY = Topic(
    "/ground_truth/safety", "safe_legged_c3bf_msgs/msg/GroundTruthSafety", "simulator",
    "contacts and minimum robot-obstacle distance, for evaluation only",
)
GROUND_TRUTH_OBSTACLES = Topic(
    "/ground_truth/obstacles", "safe_legged_c3bf_msgs/msg/ObstacleArray", "simulator",
    "true obstacle states with measured velocities, for evaluation and tests",
)

CONTRACT: tuple[Topic, ...] = (
    CLOCK, ODOM, IMU, JOINT_STATES, JOINT_COMMANDS, SCAN, POINTS, OBSTACLE_DETECTIONS, OBSTACLES,
    OBSTACLE_MARKERS, GOAL_POSE, CMD_VEL, CMD_VEL_SAFE, FILTER_STATE, DIAGNOSTICS,
    GROUND_TRUTH_SAFETY, GROUND_TRUTH_OBSTACLES,
)

#: Frame names (REP-105).
ODOM_FRAME = "odom"
BASE_FRAME = "base_link"


def by_name(name: str) -> Topic:
    """Return the contract entry of a topic name, or raise KeyError."""
    for topic in CONTRACT:
        if topic.name == name:
            return topic
    raise KeyError(f"{name} is not in the topic contract")


def markdown_table() -> str:
    """The contract as a Markdown table (the README embeds exactly this)."""
    rows = ["| topic | type | published by | content |", "| --- | --- | --- | --- |"]
    for t in CONTRACT:
        rows.append(f"| `{t.name}` | `{t.type}` | {t.publisher} | {t.description} |")
    return "\n".join(rows)
