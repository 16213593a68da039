"""Analytic inverse and forward kinematics of the biped's 6-DoF legs.

Each leg is hip yaw (z) -> hip roll (x) -> hip pitch (y) at one point, a thigh of length
``thigh`` straight down to the knee pitch (y), a shin of length ``shin`` straight down to the
ankle pitch (y) and ankle roll (x) at one point, and a sole ``ankle_height`` below the ankle.
All joint angles are zero with the leg straight and the foot flat; positive pitch swings the
distal link backwards (so a bent knee is positive), as the right-hand rule about +y gives.

The *foot frame* has its origin on the sole, straight below the ankle, with the foot's axes.
Poses are expressed in the torso (base_link) frame unless stated otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (3,) of broadcastable arrays (faster than np.cross)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def rot_x(a: float) -> np.ndarray:
    """Rotation matrix about x by ``a`` rad."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> np.ndarray:
    """Rotation matrix about y by ``a`` rad."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> np.ndarray:
    """Rotation matrix about z by ``a`` rad."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


#: joint axes of one leg in the order hip yaw, hip roll, hip pitch, knee, ankle pitch, ankle roll.
LEG_AXES = np.array(
    [
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
    ]
)


@dataclass(frozen=True)
class LegGeometry:
    """Dimensions of one leg (m).

    Attributes:
        hip_offset: (3,) hip joint centre in the torso frame.
        thigh: hip to knee length.
        shin: knee to ankle length.
        ankle_height: ankle to sole distance.

    """

    hip_offset: tuple[float, float, float]
    thigh: float
    shin: float
    ankle_height: float

    def __post_init__(self) -> None:
        if min(self.thigh, self.shin, self.ankle_height) <= 0.0:
            raise ValueError("leg lengths must be positive")

    @property
    def max_reach(self) -> float:
        """Hip-to-ankle distance with the knee straight."""
        return self.thigh + self.shin


@dataclass
class LegFrames:
    """Forward kinematics of one leg: joint positions/axes and the link frames.

    Attributes:
        positions: (6, 3) joint centres in the torso frame.
        axes: (6, 3) joint axes in the torso frame.
        rotations: (6, 3, 3) orientation of each joint's child link.
        foot_position: (3,) foot frame origin (sole below the ankle).
        foot_rotation: (3, 3) foot orientation.

    """

    positions: np.ndarray
    axes: np.ndarray
    rotations: np.ndarray
    foot_position: np.ndarray
    foot_rotation: np.ndarray


def leg_forward(geom: LegGeometry, q: np.ndarray) -> LegFrames:
    """Forward kinematics of a leg for joint angles ``q`` (6,)."""
    hip = np.asarray(geom.hip_offset, dtype=float)
    r1 = rot_z(q[0])
    r2 = r1 @ rot_x(q[1])
    r3 = r2 @ rot_y(q[2])
    knee = hip - r3[:, 2] * geom.thigh
    r4 = r3 @ rot_y(q[3])
    ankle = knee - r4[:, 2] * geom.shin
    r5 = r4 @ rot_y(q[4])
    r6 = r5 @ rot_x(q[5])
    positions = np.array([hip, hip, hip, knee, ankle, ankle])
    rotations = np.array([r1, r2, r3, r4, r5, r6])
    axes = np.array([r1[:, 2], r2[:, 0], r3[:, 1], r4[:, 1], r5[:, 1], r6[:, 0]])
    foot = ankle - r6[:, 2] * geom.ankle_height
    return LegFrames(positions, axes, rotations, foot, r6)


def leg_fk(geom: LegGeometry, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Foot position (3,) and orientation (3, 3) in the torso frame for joint angles ``q``."""
    frames = leg_forward(geom, q)
    return frames.foot_position, frames.foot_rotation


def leg_ik(
    geom: LegGeometry,
    foot_position: np.ndarray,
    foot_rotation: np.ndarray,
    min_knee: float = 0.0,
) -> np.ndarray:
    """Joint angles (6,) that put the foot frame at the given pose (torso frame).

    Closed form: the knee from the hip-to-ankle distance (law of cosines), the ankle pitch and
    roll from that vector seen in the foot frame, then the hip yaw/roll/pitch from the thigh
    orientation. Unreachable targets are handled by stretching the leg to its limit (knee at
    ``min_knee``), so the result is always finite.
    """
    rf = np.asarray(foot_rotation, dtype=float)
    ankle = np.asarray(foot_position, dtype=float) + rf[:, 2] * geom.ankle_height
    r = rf.T @ (np.asarray(geom.hip_offset, dtype=float) - ankle)
    a, b = geom.thigh, geom.shin
    rx, ry, rz = float(r[0]), float(r[1]), float(r[2])
    c_knee = (rx * rx + ry * ry + rz * rz - a * a - b * b) / (2.0 * a * b)
    knee = math.acos(min(max(c_knee, -1.0), math.cos(min_knee)))
    roll = math.atan2(ry, rz)
    # v = hip - ankle in the shin frame; w = the same vector in the frame after the ankle pitch.
    v_angle = math.atan2(-a * math.sin(knee), a * math.cos(knee) + b)
    w_angle = math.atan2(rx, math.sqrt(ry * ry + rz * rz))
    pitch = v_angle - w_angle
    # Thigh orientation R3 = Rf Rx(-roll) Ry(-(knee + pitch)) = Rz(q1) Rx(q2) Ry(q3).
    r3 = rf @ rot_x(-roll) @ rot_y(-(knee + pitch))
    q1 = math.atan2(-r3[0, 1], r3[1, 1])
    q2 = math.atan2(r3[2, 1], math.hypot(r3[0, 1], r3[1, 1]))
    q3 = math.atan2(-r3[2, 0], r3[2, 2])
    return np.array([q1, q2, q3, knee, pitch, roll])


def leg_jacobian(frames: LegFrames, point: np.ndarray | None = None) -> np.ndarray:
    """Geometric Jacobian (6, 6) of ``point`` on the foot (default: foot frame origin).

    Rows 0-2 map joint rates to the point's linear velocity, rows 3-5 to the foot's angular
    velocity, both in the torso frame.
    """
    p = frames.foot_position if point is None else np.asarray(point, dtype=float)
    lin = cross(frames.axes, p - frames.positions)
    return np.vstack([lin.T, frames.axes.T])


def static_torques(frames: LegFrames, force: np.ndarray, cop: np.ndarray) -> np.ndarray:
    """Joint torques (6,) that hold the ground reaction ``force`` acting at ``cop``.

    ``force`` (3,) is the force the ground exerts on the foot and ``cop`` (3,) its point of
    application (the centre of pressure), both in the torso frame. The joints must apply
    tau = -J(cop)^T [force; 0] to keep the leg static under that load.
    """
    lever = np.asarray(cop, dtype=float) - frames.positions
    return -np.einsum("ij,ij->i", frames.axes, cross(lever, np.asarray(force, dtype=float)))
