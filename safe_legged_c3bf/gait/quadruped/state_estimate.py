"""What the controller needs to know about the body, computed once per tick from BaseState.

Odometry is ground truth in the simulation, so this is a change of representation rather
than a filter: rotation matrix, roll/pitch/yaw, velocities in odom axes, and the centre of
mass (the MPC's point) rather than the base_link origin. The ground height under the robot
is estimated from the feet that are planned to be in stance (flat-ground assumption), with a
first-order low-pass filter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.interfaces.base_state import BaseState


@dataclass
class BodyEstimate:
    """Body state in odom axes.

    Attributes:
        position: (3,) base_link origin (m).
        rotation: (3, 3) base_link -> odom.
        rpy: (3,) roll, pitch, yaw (rad, ZYX).
        velocity: (3,) velocity of the base_link origin (m/s).
        angular_velocity: (3,) angular velocity (rad/s).
        com: (3,) centre of mass (m).
        com_velocity: (3,) velocity of the centre of mass (m/s).

    """

    position: np.ndarray
    rotation: np.ndarray
    rpy: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    com: np.ndarray
    com_velocity: np.ndarray

    @property
    def yaw(self) -> float:
        """Heading (rad)."""
        return float(self.rpy[2])


def estimate_body(base: BaseState, com_offset: np.ndarray) -> BodyEstimate:
    """Convert ``base`` (pose in odom, twist in base_link) into a :class:`BodyEstimate`.

    Args:
        base: the measured base state.
        com_offset: (3,) centre of mass in base_link (m).

    """
    x, y, z, w = base.orientation.tolist()
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    r20 = 2 * (x * z - y * w)
    r21 = 2 * (y * z + x * w)
    r22 = 1 - 2 * (x * x + y * y)
    r00 = 1 - 2 * (y * y + z * z)
    r10 = 2 * (x * y + z * w)
    rot = np.array(
        [
            [r00, 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [r10, 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [r20, r21, r22],
        ]
    )
    rpy = np.array(
        [
            math.atan2(r21, r22),
            math.asin(min(1.0, max(-1.0, -r20))),
            math.atan2(r10, r00),
        ]
    )
    velocity = rot @ base.linear_velocity
    omega = rot @ base.angular_velocity
    lever = rot @ com_offset
    return BodyEstimate(
        position=base.position.copy(),
        rotation=rot,
        rpy=rpy,
        velocity=velocity,
        angular_velocity=omega,
        com=base.position + lever,
        com_velocity=velocity + cross3(omega, lever),
    )


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of two 3-vectors (much cheaper than ``np.cross`` for one pair)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


class GroundHeightFilter:
    """Low-pass estimate of the ground height (m, odom z) from the stance feet."""

    def __init__(self, time_constant: float, foot_radius: float) -> None:
        """Create the filter; ``time_constant`` in s, ``foot_radius`` in m."""
        self.time_constant = float(time_constant)
        self.foot_radius = float(foot_radius)
        self.height: float | None = None

    def reset(self) -> None:
        """Forget the estimate."""
        self.height = None

    def update(self, feet_world: np.ndarray, stance: np.ndarray, dt: float) -> float:
        """Fold in the feet (4, 3, odom) planned in stance and return the estimate."""
        n = int(stance.sum())
        if n == 0:
            return self.height if self.height is not None else 0.0
        measured = float(feet_world[stance, 2].sum()) / n - self.foot_radius
        if self.height is None:
            self.height = float(np.min(feet_world[:, 2])) - self.foot_radius
        alpha = min(1.0, dt / self.time_constant) if self.time_constant > 0 else 1.0
        self.height += alpha * (measured - self.height)
        return self.height
