"""The simulator node's parameters (no ROS); ``config/simulator.yaml``.

All are read when the node starts (the world, its rates and the physics thread are built from
them), so every one is fixed at start-up: a read-only parameter of the node.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from safe_legged_c3bf.interfaces.typed_params import (
    FLAG,
    INTEGER,
    NON_EMPTY,
    NON_NEGATIVE,
    POSITIVE,
    TEXT,
    Rule,
    TypedParams,
    param,
)
from safe_legged_c3bf.sim.video import SUFFIXES

#: A video file name: '' (no video) or a path ending in .gif or .mp4.
VIDEO_FILE = Rule(
    "'' or a path ending in " + " or ".join(SUFFIXES),
    lambda v: isinstance(v, str) and (v == "" or Path(v).suffix.lower() in SUFFIXES),
    "video.avi",
)


def _fixed(default: object, unit: str, description: str, rule: Rule) -> object:
    return param(default, unit, description, rule, fixed=True)


@dataclass(frozen=True)
class SimulatorParams(TypedParams):
    """Simulator node parameters (all fixed at start-up; floats refuse integers)."""

    int_for_float = False  # the node always typed its doubles strictly

    scenario: str = _fixed(
        "quadruped_default", "-",
        "scenario name (config/scenarios/<name>.yaml) or path (unitless)", NON_EMPTY,
    )
    seed: int = _fixed(-1, "-", "random seed (an integer); -1 = the scenario's seed", INTEGER)
    gui: bool = _fixed(
        False, "-", "open the PyBullet GUI instead of running headless (DIRECT) (flag)", FLAG
    )
    physics_rate: float = _fixed(1000.0, "Hz", "physics steps per sim second", POSITIVE)
    state_rate: float = _fixed(
        250.0, "Hz", "/imu and /joint_states rate (sim time): the control rate and the "
        "lockstep period; at most physics_rate", POSITIVE,
    )
    odom_rate: float = _fixed(
        100.0, "Hz", "/odom rate (sim time, at most state_rate; rounded to a whole number of "
        "state periods): navigation nodes need no more, and each subscriber pays per message",
        POSITIVE,
    )
    clock_rate: float = _fixed(
        100.0, "Hz", "/clock rate (sim time, at most state_rate; rounded like odom_rate): the "
        "resolution of the other nodes' sim-time clocks", POSITIVE,
    )
    ground_truth_rate: float = _fixed(
        50.0, "Hz", "/ground_truth/* rate (sim time)", POSITIVE
    )
    detection_rate: float = _fixed(
        0.0, "Hz", "/obstacles/detections rate (sim time); 0 = the scenario's perception rate",
        NON_NEGATIVE,
    )
    strip_detection_ids: bool = _fixed(
        False, "-", "publish detections with empty ids (flag)", FLAG
    )
    real_time_factor: float = _fixed(
        1.0, "-", "sim seconds per wall second (a ratio); 0 = as fast as possible",
        NON_NEGATIVE,
    )
    max_lag: float = _fixed(
        0.05, "s", "wall time physics may fall behind the real-time schedule before it stops "
        "catching up (it then runs slower than real time)", POSITIVE,
    )
    wait_for_first_command: bool = _fixed(
        True, "-", "hold physics at t = 0 until the first MotorCommand (flag)", FLAG
    )
    command_timeout: float = _fixed(
        0.1, "s", "sim time without a command before the motor drivers damp", POSITIVE
    )
    damping_kd: float = _fixed(
        1.0, "N m s/rad", "damping gain of the drivers' damping mode", NON_NEGATIVE
    )
    lockstep: bool = _fixed(
        False, "-", "advance one state period only after a command for the last state (flag)",
        FLAG,
    )
    lockstep_timeout: float = _fixed(
        1.0, "s", "wall time to wait for that command before advancing anyway", POSITIVE
    )
    summary_path: str = _fixed(
        "", "-", "write the run summary JSON here at the end / at shutdown (a path); '' = not",
        TEXT,
    )
    diagnostics_period: float = _fixed(1.0, "s", "wall period of /diagnostics", POSITIVE)
    exit_on_finish: bool = _fixed(
        False, "-", "shut the ROS context down when the scenario ends (standalone) (flag)",
        FLAG,
    )
    video_path: str = _fixed(
        "", "-", "write the follow camera's video here (a path, .gif or .mp4); '' = none",
        VIDEO_FILE,
    )
    video_fps: float = _fixed(
        10.0, "Hz", "video frames per sim second (each costs a 20-60 ms render)", POSITIVE
    )

    def check_together(self) -> None:
        """The state rate cannot exceed the physics rate."""
        if self.state_rate > self.physics_rate:
            raise ValueError(
                f"state_rate: must not exceed physics_rate ({self.physics_rate!r}), got "
                f"{self.state_rate!r}"
            )
