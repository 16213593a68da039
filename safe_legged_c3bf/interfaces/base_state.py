"""Floating-base state of a legged robot, as carried by ``/odom`` (REP-105).

Position and orientation are of base_link in the odom frame; the twist is expressed in
base_link, as nav_msgs/Odometry specifies. Units: m, m/s, rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from safe_legged_c3bf.interfaces.rotations import (  # noqa: F401 - re-exported for existing importers
    quaternion_to_matrix,
    quaternion_to_rpy,
    yaw_to_quaternion,
)


@dataclass
class BaseState:
    """Pose of base_link in odom and its twist in base_link.

    Attributes:
        position: (3,) base_link origin in odom (m).
        orientation: (4,) quaternion (x, y, z, w), base_link -> odom.
        linear_velocity: (3,) velocity of the base origin expressed in base_link (m/s).
        angular_velocity: (3,) angular velocity expressed in base_link (rad/s).
        stamp: time of the state (s, sim time).

    """

    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    orientation: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))
    linear_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    stamp: float = 0.0

    def __post_init__(self) -> None:
        self.position = np.asarray(self.position, dtype=float).reshape(3)
        self.orientation = np.asarray(self.orientation, dtype=float).reshape(4)
        self.linear_velocity = np.asarray(self.linear_velocity, dtype=float).reshape(3)
        self.angular_velocity = np.asarray(self.angular_velocity, dtype=float).reshape(3)

    @property
    def rotation(self) -> np.ndarray:
        """Rotation matrix base_link -> odom."""
        return quaternion_to_matrix(self.orientation)

    @property
    def rpy(self) -> np.ndarray:
        """Roll, pitch, yaw in rad."""
        return quaternion_to_rpy(self.orientation)

    @property
    def yaw(self) -> float:
        """Heading in rad, from the quaternion."""
        return float(self.rpy[2])

    @property
    def linear_velocity_world(self) -> np.ndarray:
        """Velocity of the base origin expressed in odom (m/s)."""
        return self.rotation @ self.linear_velocity

    @property
    def angular_velocity_world(self) -> np.ndarray:
        """Angular velocity expressed in odom (rad/s)."""
        return self.rotation @ self.angular_velocity

    def is_finite(self) -> bool:
        """Return True when every number in the state is finite."""
        return bool(
            np.all(np.isfinite(self.position))
            and np.all(np.isfinite(self.orientation))
            and np.all(np.isfinite(self.linear_velocity))
            and np.all(np.isfinite(self.angular_velocity))
            and np.isfinite(self.stamp)
        )
