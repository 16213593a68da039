"""Trot gait schedule: which feet are on the ground now and over the MPC horizon.

A gait cycle of ``period`` seconds has a global phase in [0, 1). Leg ``i`` has phase
``(phase + offset_i) mod 1`` and is in stance while that phase is below ``duty``; it touches
down when its phase wraps to 0 and lifts off at ``duty``. In a trot the diagonal pairs
FR+RL and FL+RR are half a cycle apart.

The schedule has two modes. In STAND all four feet are in stance and the phase is frozen.
A motion request switches to TROT at once, starting at phase 0 (the FL+RR pair lifts off
first). When motion has not been requested for ``stand_delay`` seconds the schedule keeps
trotting until the next instant at which a pair touches down while the other pair is still
on the ground (global phase crossing 0 or 0.5), and stands there: no foot is left in the air.
"""

from __future__ import annotations

import enum
import math

import numpy as np

#: phase offsets of FR, FL, RR, RL in a trot
TROT_OFFSETS = np.array([0.0, 0.5, 0.5, 0.0])
_ALL_STANCE = np.ones(4, dtype=bool)
_ALL_STANCE.flags.writeable = False
_ZEROS4 = np.zeros(4)
_ZEROS4.flags.writeable = False


class GaitMode(enum.Enum):
    """What the legs are doing."""

    STAND = "stand"
    TROT = "trot"


class TrotSchedule:
    """Phase clock and contact plan of a trot with a standing mode."""

    def __init__(self, period: float, duty: float, stand_delay: float) -> None:
        """Create a schedule standing still.

        Args:
            period: duration of a gait cycle (s).
            duty: fraction of the cycle a leg is in stance, in [0.5, 1).
            stand_delay: seconds without motion request before the robot stands.

        """
        if period <= 0 or not 0.5 <= duty < 1.0 or stand_delay < 0:
            raise ValueError("TrotSchedule needs period > 0, duty in [0.5, 1), stand_delay >= 0")
        self.period = float(period)
        self.duty = float(duty)
        self.stand_delay = float(stand_delay)
        self.offsets = TROT_OFFSETS.copy()
        self.reset()

    def reset(self) -> None:
        """Stand, with the phase at 0."""
        self.mode = GaitMode.STAND
        self.phase = 0.0
        self._t_prev: float | None = None
        self._last_motion_request: float | None = None

    @property
    def stance_duration(self) -> float:
        """Duration of a leg's stance (s)."""
        return self.period * self.duty

    @property
    def swing_duration(self) -> float:
        """Duration of a leg's swing (s)."""
        return self.period * (1.0 - self.duty)

    def update(self, t: float, motion_requested: bool) -> None:
        """Advance the clock to time ``t`` (s) and switch modes as described above."""
        dt = 0.0 if self._t_prev is None else max(0.0, t - self._t_prev)
        self._t_prev = t
        if motion_requested:
            self._last_motion_request = t
        if self.mode is GaitMode.STAND:
            if motion_requested:
                self.mode = GaitMode.TROT
                self.phase = 0.0
            return
        old = self.phase
        new = old + dt / self.period
        self.phase = new % 1.0
        stop = (
            self._last_motion_request is None or t - self._last_motion_request >= self.stand_delay
        )
        crossed = math.floor(2.0 * new) > math.floor(2.0 * old)  # phase passed 0 or 0.5
        if stop and crossed:
            self.mode = GaitMode.STAND
            self.phase = 0.0

    def leg_phases(self) -> np.ndarray:
        """Phase (4,) of each leg in [0, 1): stance below ``duty``, swing above."""
        return (self.phase + self.offsets) % 1.0

    def contacts(self) -> np.ndarray:
        """Planned contact (4,) bool of FR, FL, RR, RL at the current time."""
        if self.mode is GaitMode.STAND:
            return np.ones(4, dtype=bool)
        return self.leg_phases() < self.duty

    def swing_progress(self) -> np.ndarray:
        """Fraction (4,) of the swing done, in [0, 1]; 0 for stance legs."""
        if self.mode is GaitMode.STAND:
            return np.zeros(4)
        phases = self.leg_phases()
        return np.where(phases >= self.duty, (phases - self.duty) / (1.0 - self.duty), 0.0)

    def time_to_touchdown(self) -> np.ndarray:
        """Seconds (4,) until each swing leg touches down; 0 for stance legs."""
        if self.mode is GaitMode.STAND:
            return np.zeros(4)
        phases = self.leg_phases()
        return np.where(phases >= self.duty, (1.0 - phases) * self.period, 0.0)

    def snapshot(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (contacts, swing_progress, time_to_touchdown) at once (cheaper)."""
        if self.mode is GaitMode.STAND:
            return _ALL_STANCE, _ZEROS4, _ZEROS4
        phases = (self.phase + self.offsets) % 1.0
        swing = phases >= self.duty
        progress = (phases - self.duty) * (1.0 / (1.0 - self.duty))
        progress[~swing] = 0.0
        to_touchdown = (1.0 - phases) * self.period
        to_touchdown[~swing] = 0.0
        return ~swing, progress, to_touchdown

    def plan(self, horizon: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Contact plan over the MPC horizon, starting now.

        Returns:
            contacts: (horizon, 4) bool, contact of each leg at t + k dt.
            touchdowns: (horizon, 4) int, how many touch-downs each leg makes between now
                and t + k dt (0: the foot now on the ground is still there; 1 for a leg now
                in swing: its next foothold; ...).

        """
        if self.mode is GaitMode.STAND:
            return np.ones((horizon, 4), dtype=bool), np.zeros((horizon, 4), dtype=int)
        ahead = self.leg_phases()[None, :] + (np.arange(horizon) * dt / self.period)[:, None]
        contacts = (ahead % 1.0) < self.duty
        touchdowns = np.floor(ahead).astype(int)
        return contacts, touchdowns
