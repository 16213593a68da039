"""The simulator node's parameters: declared from :data:`PARAMETERS`, checked, and the schedule.

:data:`PARAMETERS` is the one list of the node's parameters (``config/simulator.yaml`` mirrors
it, a test checks). :func:`declare_parameters` declares them on the node and returns their
values, checked; :class:`LoopSettings` turns them into what the physics loop needs: every rate
as a whole number of physics steps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

#: Node parameters: name -> (default, description with units). config/simulator.yaml mirrors it.
PARAMETERS: dict[str, tuple[Any, str]] = {
    "scenario": ("quadruped_default", "scenario name (config/scenarios/<name>.yaml) or path"),
    "seed": (-1, "random seed; -1 = the scenario's seed"),
    "gui": (False, "open the PyBullet GUI instead of running headless (DIRECT)"),
    "physics_rate": (1000.0, "physics steps per sim second (Hz)"),
    "state_rate": (250.0, "/imu and /joint_states rate (Hz, sim time): the control rate and "
                   "the lockstep period"),
    "odom_rate": (100.0, "/odom rate (Hz, sim time, at most state_rate; rounded to a whole "
                  "number of state periods): navigation nodes "
                  "need no more, and each subscriber pays per message"),
    "clock_rate": (100.0, "/clock rate (Hz, sim time, at most state_rate; rounded like "
                   "odom_rate): the resolution of "
                   "the other nodes' sim-time clocks"),
    "ground_truth_rate": (50.0, "/ground_truth/* rate (Hz, sim time)"),
    "detection_rate": (0.0, "/obstacles/detections rate (Hz, sim time); 0 = scenario's rate"),
    "strip_detection_ids": (False, "publish detections with empty ids"),
    "real_time_factor": (1.0, "sim seconds per wall second; 0 = as fast as possible"),
    "max_lag": (0.05, "wall time (s) physics may fall behind the real-time schedule before "
                "it stops catching up (it then runs slower than real time)"),
    "wait_for_first_command": (True, "hold physics at t = 0 until the first MotorCommand"),
    "command_timeout": (0.1, "sim time without a command before the drivers damp (s)"),
    "damping_kd": (1.0, "damping gain of the drivers' damping mode (N m s/rad)"),
    "lockstep": (False, "advance one state period only after a command for the last state"),
    "lockstep_timeout": (1.0, "wall time to wait for that command before advancing (s)"),
    "summary_path": ("", "write the run summary JSON here at the end / at shutdown"),
    "diagnostics_period": (1.0, "wall period of /diagnostics (s)"),
    "exit_on_finish": (False, "shut the ROS context down when the scenario ends (standalone)"),
    "video_path": ("", "write the follow camera's video here (.gif or .mp4; '' = none)"),
    "video_fps": (10.0, "video frames per sim second (each costs a 20-60 ms render)"),
}


def declare_parameters(node: Node) -> dict[str, Any]:
    """Declare :data:`PARAMETERS` on ``node``; their values, checked (ValueError if invalid)."""
    for name, (default, description) in PARAMETERS.items():
        node.declare_parameter(name, default, ParameterDescriptor(description=description))
    p = {name: node.get_parameter(name).value for name in PARAMETERS}
    check_parameters(p)
    return p


def check_parameters(p: dict[str, Any]) -> None:
    """Raise ValueError for a rate, period or gain out of range, or a bad video path."""
    positive = ("physics_rate", "state_rate", "odom_rate", "clock_rate", "ground_truth_rate",
                "max_lag", "command_timeout", "lockstep_timeout", "diagnostics_period")
    for name in positive:
        if not float(p[name]) > 0:
            raise ValueError(f"parameter {name} must be > 0, got {p[name]!r}")
    for name in ("detection_rate", "real_time_factor", "damping_kd"):
        if not float(p[name]) >= 0:
            raise ValueError(f"parameter {name} must be >= 0, got {p[name]!r}")
    if p["video_path"]:
        from safe_legged_c3bf.sim.video import check_video_path

        check_video_path(str(p["video_path"]))
        if not float(p["video_fps"]) > 0:
            raise ValueError(f"parameter video_fps must be > 0, got {p['video_fps']!r}")
    if float(p["state_rate"]) > float(p["physics_rate"]):
        raise ValueError("parameter state_rate must not exceed physics_rate")


@dataclass(frozen=True)
class LoopSettings:
    """How the physics loop runs; every ``*_every`` is a number of physics steps.

    /clock and /odom go out every whole number of state periods, so their rates are rounded:
    125 Hz for the requested 100 Hz at the A1's 250 Hz state rate, 100 Hz at the biped's
    200 Hz.
    """

    physics_rate: float  #: physics steps per sim second (Hz)
    state_every: int  #: one state period: /imu, /joint_states, the lockstep period
    clock_every: int  #: /clock (a multiple of state_every)
    odom_every: int  #: /odom (a multiple of state_every)
    ground_truth_every: int  #: /ground_truth/*
    detection_every: int  #: /obstacles/detections
    real_time_factor: float  #: sim s per wall s; 0 = as fast as possible
    max_lag: float  #: wall s behind the schedule before pacing stops catching up
    lockstep: bool
    lockstep_timeout: float  #: wall s to wait for the command of the last state
    wait_for_first_command: bool

    @classmethod
    def from_parameters(cls, p: dict[str, Any], perception_rate: float) -> LoopSettings:
        """From checked parameter values; ``perception_rate``: the scenario's (Hz, sim time)."""
        rate = float(p["physics_rate"])
        state_rate = float(p["state_rate"])
        detection_rate = float(p["detection_rate"]) or perception_rate
        state_every = max(1, round(rate / state_rate))
        return cls(
            physics_rate=rate,
            state_every=state_every,
            clock_every=max(state_every, state_every * round(state_rate / float(p["clock_rate"]))),
            odom_every=max(state_every, state_every * round(state_rate / float(p["odom_rate"]))),
            ground_truth_every=max(1, round(rate / float(p["ground_truth_rate"]))),
            detection_every=max(1, round(rate / detection_rate)),
            real_time_factor=float(p["real_time_factor"]),
            max_lag=float(p["max_lag"]),
            lockstep=bool(p["lockstep"]),
            lockstep_timeout=float(p["lockstep_timeout"]),
            wait_for_first_command=bool(p["wait_for_first_command"]),
        )

    def describe(self) -> str:
        """The rates for the start-up log line: physics, state, /odom and /clock (Hz)."""
        rate = self.physics_rate
        return (
            f"physics {rate:g} Hz, state every {self.state_every} steps "
            f"({rate / self.state_every:g} Hz; /odom {rate / self.odom_every:g} Hz, "
            f"/clock {rate / self.clock_every:g} Hz)"
        )
