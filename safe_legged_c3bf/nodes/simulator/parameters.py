"""The simulator node's loop schedule: every rate as a whole number of physics steps.

The node's parameters are :class:`~safe_legged_c3bf.sim.node_params.SimulatorParams`
(declared by :class:`~safe_legged_c3bf.nodes.parameters.NodeParameters`);
:class:`LoopSettings` turns them into what the physics loop needs.
"""

from __future__ import annotations

from dataclasses import dataclass

from safe_legged_c3bf.sim.node_params import SimulatorParams
from safe_legged_c3bf.sim.scenario import PerceptionConfig


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
    detection_every: int  #: /obstacles/detections (0: not published, perception from sensors)
    scan_every: int  #: /scan (0: not published, oracle perception)
    points_every: int  #: /points (0: not published, oracle perception)
    real_time_factor: float  #: sim s per wall s; 0 = as fast as possible
    max_lag: float  #: wall s behind the schedule before pacing stops catching up
    lockstep: bool
    lockstep_timeout: float  #: wall s to wait for the command of the last state
    wait_for_first_command: bool

    @classmethod
    def from_parameters(cls, p: SimulatorParams, perception: PerceptionConfig) -> LoopSettings:
        """From the node's parameters and the scenario's perception (rates: Hz, sim time).

        Oracle perception publishes detections at the node's ``detection_rate`` (0: the
        scenario's); sensor perception publishes /scan and /points at the sensors' rates.
        """
        rate = float(p.physics_rate)
        state_rate = float(p.state_rate)
        detection_rate = float(p.detection_rate) or perception.rate
        state_every = max(1, round(rate / state_rate))
        sensors = perception.source == "sensors"

        def every(hz: float, on: bool) -> int:
            return max(1, round(rate / hz)) if on else 0

        return cls(
            physics_rate=rate,
            state_every=state_every,
            clock_every=max(state_every, state_every * round(state_rate / float(p.clock_rate))),
            odom_every=max(state_every, state_every * round(state_rate / float(p.odom_rate))),
            ground_truth_every=max(1, round(rate / float(p.ground_truth_rate))),
            detection_every=every(detection_rate, not sensors),
            scan_every=every(perception.lidar.rate, sensors),
            points_every=every(perception.depth.rate, sensors),
            real_time_factor=float(p.real_time_factor),
            max_lag=float(p.max_lag),
            lockstep=bool(p.lockstep),
            lockstep_timeout=float(p.lockstep_timeout),
            wait_for_first_command=bool(p.wait_for_first_command),
        )

    def describe(self) -> str:
        """The rates for the start-up log line: physics, state, /odom, /clock, sensors (Hz)."""
        rate = self.physics_rate
        text = (
            f"physics {rate:g} Hz, state every {self.state_every} steps "
            f"({rate / self.state_every:g} Hz; /odom {rate / self.odom_every:g} Hz, "
            f"/clock {rate / self.clock_every:g} Hz)"
        )
        if self.scan_every:
            text += (f", /scan {rate / self.scan_every:g} Hz, /points "
                     f"{rate / self.points_every:g} Hz")
        return text
