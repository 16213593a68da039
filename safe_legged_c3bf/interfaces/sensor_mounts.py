"""Where the simulated range sensors sit on each robot, and their frames (REP-103, REP-105).

One place for the mounting poses: the simulator casts its rays from them and the obstacle
detector turns the sensors' points into odom with them (base_link -> sensor is static; odom ->
base_link comes from ``/odom``). On a real robot the detector's parameters take the mounts of
the real sensors instead (doc/deploy.md).

Sensor frames follow REP-103 body conventions (x forward, y left, z up), not the optical
convention: ``LaserScan`` angles are about the sensor's z axis from its x axis, and
``PointCloud2`` points are x/y/z in the sensor frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.interfaces.rotations import rpy_to_matrix

#: Frame of the 2-D LiDAR (``/scan``).
LIDAR_FRAME = "lidar_link"
#: Frame of the forward 3-D sensor (``/points``).
DEPTH_FRAME = "depth_link"


@dataclass(frozen=True)
class SensorMount:
    """A sensor's pose in base_link.

    Attributes:
        frame_id: the sensor's frame name, as in its messages' ``header.frame_id``.
        xyz: (3,) position of the sensor origin in base_link (m).
        rpy: (3,) roll, pitch, yaw of the sensor frame in base_link (rad, fixed axes x-y-z).

    """

    frame_id: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def rotation(self) -> np.ndarray:
        """(3, 3) rotation taking sensor-frame vectors into base_link."""
        return rpy_to_matrix(*self.rpy)

    def matrix(self) -> np.ndarray:
        """(4, 4) homogeneous transform base_link <- sensor."""
        out = np.eye(4)
        out[:3, :3] = self.rotation()
        out[:3, 3] = self.xyz
        return out


# A1: trunk collision box 0.267 x 0.194 x 0.114 m about the base origin (top at +0.057 m).
# The LiDAR sits on the trunk's top near its front, 4 cm above it (its plane is above the legs
# and the trunk itself); the 3-D sensor looks forward, level, from a head ahead of the front
# hips: their collision cylinders span x 0.137-0.229 m, |y| 0.027-0.067 m, |z| < 0.046 m, and
# a sensor on the trunk's front face (x = 0.145 m) between them had half its rays blocked.
_A1_MOUNTS = (
    SensorMount(LIDAR_FRAME, (0.10, 0.0, 0.097)),
    SensorMount(DEPTH_FRAME, (0.24, 0.0, 0.03)),
)
# Biped: torso box 0.3 m high centred 0.08 m above the base origin (top at +0.23 m). The
# LiDAR on the torso top, the 3-D sensor on the chest looking forward and 20 deg down so
# that the ground ahead of the feet and bars above the head are both in view.
_BIPED_MOUNTS = (
    SensorMount(LIDAR_FRAME, (0.05, 0.0, 0.27)),
    SensorMount(DEPTH_FRAME, (0.10, 0.0, 0.15), (0.0, math.radians(20.0), 0.0)),
)


def default_mounts(robot_kind: str) -> dict[str, SensorMount]:
    """The simulated sensors' mounts of a robot ('quadruped' or 'biped'), by frame name."""
    table = {"quadruped": _A1_MOUNTS, "biped": _BIPED_MOUNTS}
    if robot_kind not in table:
        raise ValueError(f"no sensor mounts for robot kind {robot_kind!r}")
    return {m.frame_id: m for m in table[robot_kind]}


def resolve_mount(
    robot_kind: str, frame: str, frame_id: str,
    xyz: tuple[float, float, float], rpy: tuple[float, float, float],
) -> SensorMount:
    """The robot kind's mount of ``frame`` named ``frame_id``; a vector not NaN replaces its part.

    ``xyz`` (m) and ``rpy`` (rad) in base_link are three numbers or three NaN (the kind's).
    """
    base = default_mounts(robot_kind)[frame]
    return SensorMount(
        frame_id,
        base.xyz if math.isnan(xyz[0]) else tuple(float(v) for v in xyz),
        base.rpy if math.isnan(rpy[0]) else tuple(float(v) for v in rpy),
    )
