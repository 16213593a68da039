"""Fault catalogue: what an untrusted input or a failing node does to a running graph.

Each :class:`Fault` is one way a real deployment goes wrong: a second publisher on an input
topic with stamps from another clock, NaN/Inf, a flood, a gigantic message; a node killed
(SIGKILL) or frozen (SIGSTOP) mid-run. ``expect`` says what the graph must do, as a user can
check it from ground truth:

* ``continue``: the poisoned messages are rejected (counted in /diagnostics) and the run goes
  on as without them: goal reached, no collision.
* ``safe``: the poisoned messages are believable and change what the robot is asked to do
  (a second reference publisher flooding ``/cmd_vel``): the filter keeps every command safe,
  no collision; reaching the goal is not expected (the reference no longer leads there).
* ``stop``: the input cannot be trusted any more (which of two publishers is the real one
  cannot be told, a node is gone): the robot stops and stands, no collision.
* ``end``: the run ends with a message naming the dead or frozen node, no collision and no
  process left behind (the robot stops first where the simulator keeps running).

The message faults are published by :class:`~safe_legged_c3bf.evaluation.fault_injector.
FaultInjector`; :mod:`~safe_legged_c3bf.evaluation.fault_runner` runs a bringup under one.
Times: sim seconds.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Graph nodes a process fault can hit (bringup node names).
NODES = ("simulator", "obstacle_tracker", "reference_planner", "safety_filter",
         "gait_controller")
#: Nodes that run only with sensor perception (``--perception sensors``).
SENSOR_NODES = ("obstacle_detector",)


@dataclass(frozen=True)
class Fault:
    """One injected fault.

    Attributes:
        name: identifier (``detections_wall_clock``, ``kill_safety_filter``...).
        topic: the topic a message fault publishes on ('' for a process fault).
        payload: what each message carries (see ``fault_injector.PAYLOADS``).
        stamp: how each message is stamped: ``sim`` (the right clock), ``wall`` (a
            publisher not on sim time), ``future`` (+100 s), ``past`` (-5 s).
        rate: messages per wall second (Hz).
        node: the node a process fault signals ('' for a message fault).
        signal: ``SIGKILL`` or ``SIGSTOP`` for a process fault.
        expect: ``continue``, ``safe``, ``stop`` or ``end`` (see the module docstring).
        also: a second fault injected at the same time (a combination).
        frame: the poisoned messages' header.frame_id (the sensor's own for /scan, /points).
        perception: the run's obstacle perception, ``oracle`` or ``sensors`` (the faults on
            /scan, /points and the obstacle detector need the sensor graph).

    """

    name: str
    expect: str
    topic: str = ""
    payload: str = ""
    stamp: str = "sim"
    rate: float = 20.0
    node: str = ""
    signal: str = ""
    also: str = ""
    frame: str = "odom"
    perception: str = "oracle"

    @property
    def is_process(self) -> bool:
        """True for a node kill/freeze."""
        return bool(self.node)


def _message_faults() -> list[Fault]:
    det, obs = "/obstacles/detections", "/obstacles"
    return [
        Fault("detections_wall_clock", "continue", det, "empty", "wall"),
        Fault("detections_future", "continue", det, "empty", "future"),
        Fault("detections_past", "continue", det, "empty", "past"),
        Fault("detections_nan", "continue", det, "nan_obstacle"),
        Fault("detections_flood_1khz", "continue", det, "far_obstacle", rate=1000.0),
        Fault("detections_10000_obstacles", "continue", det, "many_obstacles", rate=2.0),
        Fault("obstacles_second_publisher", "stop", obs, "empty", rate=30.0),
        Fault("obstacles_future", "stop", obs, "empty", "future", rate=30.0),
        Fault("odom_future", "stop", "/odom", "odom_elsewhere", "future", rate=100.0),
        Fault("odom_nan", "stop", "/odom", "odom_nan", rate=100.0),
        Fault("cmd_vel_nan", "continue", "/cmd_vel", "twist_nan", rate=50.0),
        Fault("cmd_vel_nan_and_wall_clock_detections", "continue", "/cmd_vel", "twist_nan",
              rate=50.0, also="detections_wall_clock"),
        Fault("cmd_vel_flood_full_speed", "safe", "/cmd_vel", "twist_full_speed",
              rate=1000.0),
        Fault("cmd_vel_safe_second_publisher", "stop", "/cmd_vel_safe", "twist_full_speed",
              rate=50.0),
        Fault("imu_future", "continue", "/imu", "imu_level", "future", rate=100.0),
        Fault("joint_states_wall_clock", "continue", "/joint_states", "joints_zero", "wall",
              rate=100.0),
        *_sensor_faults(),
    ]


def _sensor_faults() -> list[Fault]:
    """A second sensor on /scan or /points: a phantom wall, no returns, a broken cloud."""
    lidar = {"frame": "lidar_link", "perception": "sensors", "rate": 10.0}
    cloud = {"frame": "depth_link", "perception": "sensors", "rate": 10.0}
    return [
        Fault("scan_wall_clock", "continue", "/scan", "scan_phantom", "wall", **lidar),
        Fault("scan_future", "continue", "/scan", "scan_phantom", "future", **lidar),
        Fault("scan_no_returns", "continue", "/scan", "scan_no_returns", **lidar),
        Fault("points_future", "continue", "/points", "points_phantom", "future", **cloud),
        Fault("points_truncated", "continue", "/points", "points_truncated", **cloud),
    ]


def _process_faults() -> list[Fault]:
    out = []
    for sig, verb in (("SIGKILL", "kill"), ("SIGSTOP", "freeze")):
        for node in NODES:
            out.append(Fault(f"{verb}_{node}", "end", node=node, signal=sig))
        for node in SENSOR_NODES:
            out.append(Fault(f"{verb}_{node}", "end", node=node, signal=sig,
                             perception="sensors"))
    return out


#: Every fault, by name, in table order.
FAULTS: dict[str, Fault] = {f.name: f for f in (*_message_faults(), *_process_faults())}
