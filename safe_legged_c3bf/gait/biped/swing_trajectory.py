"""Swing foot trajectory that can change its target during the swing.

Horizontal position and heading follow a quintic (minimum-jerk) curve that is re-solved every
tick from the current desired position, velocity and acceleration to the (possibly updated)
target, reached with zero velocity and acceleration at a fixed landing time. So a re-planned
or capture-point-adjusted footstep is absorbed smoothly. The height is a fixed bell
``h * 64 s^3 (1 - s)^3`` (zero velocity and acceleration at lift-off and touchdown) on top of a
minimum-jerk blend from the lift-off to the landing height.
"""

from __future__ import annotations

import numpy as np


def quintic_coefficients(p0, v0, a0, p1, duration: float) -> np.ndarray:
    """Coefficients (6, n) of the quintic from (p0, v0, a0) to (p1, 0, 0) in ``duration``."""
    p0, v0, a0, p1 = (np.asarray(v, dtype=float) for v in (p0, v0, a0, p1))
    T = float(duration)
    d = p1 - p0
    c3 = (20.0 * d - 12.0 * v0 * T - 3.0 * a0 * T * T) / (2.0 * T**3)
    c4 = (-30.0 * d + 16.0 * v0 * T + 3.0 * a0 * T * T) / (2.0 * T**4)
    c5 = (12.0 * d - 6.0 * v0 * T - a0 * T * T) / (2.0 * T**5)
    return np.array([p0, v0, 0.5 * a0, c3, c4, c5])


def quintic_eval(coeffs: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration of a quintic at time ``t``."""
    c = coeffs
    p = c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))))
    v = c[1] + t * (2 * c[2] + t * (3 * c[3] + t * (4 * c[4] + t * 5 * c[5])))
    a = 2 * c[2] + t * (6 * c[3] + t * (12 * c[4] + t * 20 * c[5]))
    return p, v, a


def min_jerk(s: float) -> tuple[float, float]:
    """Minimum-jerk blend 10 s^3 - 15 s^4 + 6 s^5 on [0, 1] and its derivative."""
    s = min(max(s, 0.0), 1.0)
    return s**3 * (10 - 15 * s + 6 * s * s), 30 * s * s * (1 - s) ** 2


class SwingTrajectory:
    """Swing of one foot from lift-off at ``t_start`` to touchdown ``duration`` later.

    The horizontal state is (x, y, yaw). Call :meth:`sample` with non-decreasing times.
    """

    def __init__(
        self,
        start: np.ndarray,
        t_start: float,
        duration: float,
        height: float,
        lift_fraction: float = 0.1,
        land_fraction: float = 0.85,
    ) -> None:
        """Start a swing from the pose ``start`` = (x, y, z, yaw)."""
        if duration <= 0 or height < 0 or not 0 <= lift_fraction < land_fraction <= 1:
            raise ValueError("invalid swing trajectory parameters")
        start = np.asarray(start, dtype=float)
        self.t_start = float(t_start)
        self.duration = float(duration)
        self.height = float(height)
        self.z0 = float(start[2])
        self.t_move = self.t_start + lift_fraction * self.duration
        self.t_land = self.t_start + land_fraction * self.duration
        self._pos = start[[0, 1, 3]].copy()
        self._vel = np.zeros(3)
        self._acc = np.zeros(3)
        self._t = self.t_start

    @property
    def t_end(self) -> float:
        """Touchdown time (s)."""
        return self.t_start + self.duration

    def sample(self, t: float, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Desired pose (x, y, z, yaw) and its rate at time ``t`` towards ``target``.

        ``target`` = (x, y, z, yaw) of the landing pose; its yaw is unwrapped next to the
        current heading so the foot turns the short way.
        """
        target = np.asarray(target, dtype=float)
        goal = target[[0, 1, 3]].copy()
        goal[2] = self._pos[2] + (goal[2] - self._pos[2] + np.pi) % (2 * np.pi) - np.pi
        t = float(t)
        if t > self._t and t > self.t_move:
            t_from = max(self._t, self.t_move)
            if t_from >= self.t_land - 1e-9:
                self._pos, self._vel, self._acc = goal, np.zeros(3), np.zeros(3)
            else:
                coeffs = quintic_coefficients(
                    self._pos, self._vel, self._acc, goal, self.t_land - t_from
                )
                tau = min(t, self.t_land) - t_from
                self._pos, self._vel, self._acc = quintic_eval(coeffs, tau)
                if t >= self.t_land:
                    self._pos, self._vel, self._acc = goal, np.zeros(3), np.zeros(3)
        self._t = max(self._t, t)
        s = (t - self.t_start) / self.duration
        s_c = min(max(s, 0.0), 1.0)
        blend, dblend = min_jerk(s_c)
        z = self.z0 + (float(target[2]) - self.z0) * blend
        z += self.height * 64.0 * s_c**3 * (1.0 - s_c) ** 3
        dz = (float(target[2]) - self.z0) * dblend
        dz += self.height * 64.0 * (3 * s_c**2 * (1 - s_c) ** 3 - 3 * s_c**3 * (1 - s_c) ** 2)
        dz /= self.duration
        pose = np.array([self._pos[0], self._pos[1], z, self._pos[2]])
        rate = np.array([self._vel[0], self._vel[1], dz, self._vel[2]])
        return pose, rate
