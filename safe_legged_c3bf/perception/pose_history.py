"""A short history of base poses from odometry, interpolated to sensor stamps (no ROS).

There is no tf2 here: the detector keeps the last ``duration`` seconds of ``/odom`` poses
(base_link in odom, REP-105) and looks up the pose at a scan's or cloud's stamp itself.
Positions are interpolated linearly and orientations by normalised linear interpolation of
the quaternions (the poses are 8-10 ms apart at the odometry rate, where nlerp and slerp
differ by far less than a millimetre). A stamp older than the oldest pose kept, or newer
than the newest by more than ``max_extrapolation``, has no pose: the caller drops the
measurement instead of guessing. Between the newest pose and ``max_extrapolation`` after
it the newest pose is held (sensor messages often arrive just before the odometry of the
same instant).
"""

from __future__ import annotations

import math
from enum import StrEnum

import numpy as np

__all__ = ["PoseHistory", "PoseLookup", "quaternions_to_matrices"]


class PoseLookup(StrEnum):
    """Why a stamp has no pose."""

    OK = "ok"
    NO_ODOM = "no_odom"  # no pose received yet
    BEFORE_HISTORY = "before_odom"  # older than the oldest pose kept
    AFTER_HISTORY = "after_odom"  # newer than the newest pose + max_extrapolation


def quaternions_to_matrices(quats: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations (body -> parent) of (n, 4) quaternions (x, y, z, w), normalised."""
    q = np.asarray(quats, dtype=float).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    out = np.empty((len(q), 3, 3))
    out[:, 0, 0] = 1 - 2 * (y * y + z * z)
    out[:, 0, 1] = 2 * (x * y - z * w)
    out[:, 0, 2] = 2 * (x * z + y * w)
    out[:, 1, 0] = 2 * (x * y + z * w)
    out[:, 1, 1] = 1 - 2 * (x * x + z * z)
    out[:, 1, 2] = 2 * (y * z - x * w)
    out[:, 2, 0] = 2 * (x * z - y * w)
    out[:, 2, 1] = 2 * (y * z + x * w)
    out[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return out


class PoseHistory:
    """The last ``duration`` s of base poses (odom frame), looked up by stamp.

    Attributes:
        duration: how long poses are kept, before the newest (s, > 0).
        max_extrapolation: how far after the newest pose a stamp still gets it (s, >= 0).
        capacity: most poses kept whatever their stamps (bounds memory on a flood).
        out_of_order: poses dropped because they were older than the newest one.

    """

    def __init__(
        self, duration: float = 1.0, max_extrapolation: float = 0.05, capacity: int = 1024
    ) -> None:
        """An empty history; ValueError for a bad bound."""
        if not (math.isfinite(duration) and duration > 0.0):
            raise ValueError(f"duration must be finite and > 0, got {duration!r}")
        if not (math.isfinite(max_extrapolation) and max_extrapolation >= 0.0):
            raise ValueError(
                f"max_extrapolation must be finite and >= 0, got {max_extrapolation!r}"
            )
        if capacity < 2:
            raise ValueError(f"capacity must be >= 2, got {capacity!r}")
        self.duration = float(duration)
        self.max_extrapolation = float(max_extrapolation)
        self.capacity = int(capacity)
        self._t = np.empty(0)
        self._p = np.empty((0, 3))
        self._q = np.empty((0, 4))
        self.out_of_order = 0

    def __len__(self) -> int:
        return int(self._t.size)

    @property
    def newest(self) -> float | None:
        """Stamp of the newest pose (s), None when empty."""
        return float(self._t[-1]) if self._t.size else None

    def clear(self) -> None:
        """Forget every pose (e.g. when the clock jumps back)."""
        self._t, self._p, self._q = np.empty(0), np.empty((0, 3)), np.empty((0, 4))

    def add(self, t: float, position: np.ndarray, quaternion: np.ndarray) -> bool:
        """Append the pose at ``t`` (s): position (3,) m, quaternion (x, y, z, w) in odom.

        Returns False (and keeps nothing) for a non-finite pose or a zero quaternion, or a
        stamp older than the newest pose (counted in ``out_of_order``); a repeated stamp
        replaces the pose.
        """
        p = np.asarray(position, dtype=float).reshape(3)
        q = np.asarray(quaternion, dtype=float).reshape(4)
        norm = float(np.linalg.norm(q))
        if not (math.isfinite(t) and np.all(np.isfinite(p)) and math.isfinite(norm)) or norm < 1e-6:
            return False
        q = q / norm
        if self._t.size and t < self._t[-1]:
            self.out_of_order += 1
            return False
        if self._t.size and t == self._t[-1]:
            self._p[-1], self._q[-1] = p, q
            return True
        if self._t.size and float(np.dot(q, self._q[-1])) < 0.0:
            q = -q  # same rotation; keeps neighbours in one hemisphere for interpolation
        keep = self._t >= t - self.duration
        keep[: max(0, self._t.size + 1 - self.capacity)] = False
        self._t = np.append(self._t[keep], t)
        self._p = np.vstack([self._p[keep], p])
        self._q = np.vstack([self._q[keep], q])
        return True

    def check(self, t: float) -> PoseLookup:
        """Whether a pose exists at ``t`` (s)."""
        if self._t.size == 0:
            return PoseLookup.NO_ODOM
        if not t >= self._t[0]:  # also NaN
            return PoseLookup.BEFORE_HISTORY
        if t > self._t[-1] + self.max_extrapolation:
            return PoseLookup.AFTER_HISTORY
        return PoseLookup.OK

    def interpolate(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Poses at ``times`` (n,) s: positions (n, 3) m and rotations (n, 3, 3) body -> odom.

        Every time must pass :meth:`check` (ValueError otherwise). Times after the newest pose
        get the newest pose.
        """
        ts = np.asarray(times, dtype=float).reshape(-1)
        for t in (float(ts.min()), float(ts.max())) if ts.size else ():
            verdict = self.check(t)
            if verdict is not PoseLookup.OK:
                raise ValueError(f"no pose at t = {t:.6f} s: {verdict.value}")
        if self._t.size == 1:
            n = ts.size
            return np.repeat(self._p, n, axis=0), quaternions_to_matrices(np.repeat(self._q, n, 0))
        clipped = np.minimum(ts, self._t[-1])
        hi = np.clip(np.searchsorted(self._t, clipped, side="right"), 1, self._t.size - 1)
        lo = hi - 1
        span = self._t[hi] - self._t[lo]
        w = np.clip((clipped - self._t[lo]) / span, 0.0, 1.0)[:, None]
        position = (1.0 - w) * self._p[lo] + w * self._p[hi]
        quat = (1.0 - w) * self._q[lo] + w * self._q[hi]
        return position, quaternions_to_matrices(quat)

    def pose_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Pose at one stamp ``t`` (s): position (3,) m and rotation (3, 3) body -> odom."""
        position, rotation = self.interpolate(np.array([t]))
        return position[0], rotation[0]
