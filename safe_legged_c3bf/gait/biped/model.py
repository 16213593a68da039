"""Kinematic and mass model of the biped, read from its URDF.

The gait controller needs the legs' dimensions (for :mod:`leg_ik`), the foot sole size (for
the support polygon) and every link's mass and centre of mass (for the whole-body centre of
mass). They are read from ``description/biped.urdf`` so the controller and the simulated robot
cannot disagree; the URDF is checked to have the leg structure the analytic IK assumes.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.gait.biped.leg_ik import (
    LEG_AXES,
    LegFrames,
    LegGeometry,
    cross,
    leg_forward,
    leg_ik,
)
from safe_legged_c3bf.gait.biped.side import SIDES, Side

URDF_PATH = os.path.join(
    os.path.dirname(os.path.dirname(os.path.dirname(__file__))), "description", "biped.urdf"
)
LEG_JOINTS = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
#: the 12 actuated joints in controller order: left leg then right leg, hip to ankle.
JOINT_NAMES = [f"{s}_{j}" for s in SIDES for j in LEG_JOINTS]


def _floats(text: str | None, n: int = 3) -> np.ndarray:
    if text is None:
        return np.zeros(n)
    return np.array([float(v) for v in text.split()])


def _inertial(link: ET.Element) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass (kg), CoM (3,) in the link frame and inertia tensor (3, 3, kg m^2) of a link."""
    inertial = link.find("inertial")
    i_el = inertial.find("inertia")
    ixx, ixy, ixz, iyy, iyz, izz = (
        float(i_el.get(k, 0.0)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    )
    return (
        float(inertial.find("mass").get("value")),
        _floats(inertial.find("origin").get("xyz")),
        np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]),
    )


@dataclass(frozen=True)
class FootGeometry:
    """Sole rectangle in the foot frame (m).

    Attributes:
        center: (2,) x, y of the sole centre relative to the point below the ankle.
        length: sole length along x.
        width: sole width along y.

    """

    center: tuple[float, float]
    length: float
    width: float

    @property
    def half_size(self) -> np.ndarray:
        """(2,) half the sole's length and width (m)."""
        return np.array([self.length / 2, self.width / 2])


class BipedModel:
    """Leg geometry, joint limits and mass distribution of the biped."""

    def __init__(self, urdf_path: str = URDF_PATH) -> None:
        """Parse ``urdf_path`` and check its structure."""
        root = ET.parse(urdf_path).getroot()
        links = {link.get("name"): link for link in root.findall("link")}
        joints = {joint.get("name"): joint for joint in root.findall("joint")}
        missing = [n for n in JOINT_NAMES if n not in joints]
        if missing:
            raise ValueError(f"URDF lacks joints {missing}")
        self.joint_names = list(JOINT_NAMES)
        self.lower = np.zeros(12)
        self.upper = np.zeros(12)
        self.effort = np.zeros(12)
        self.legs: dict[Side, LegGeometry] = {}
        #: per side: (6,) masses of the child links of the six joints
        self.link_mass: dict[Side, np.ndarray] = {}
        #: per side: (6, 3) centre of mass of each child link in its own frame
        self.link_com: dict[Side, np.ndarray] = {}
        #: per side: (6, 3, 3) inertia tensor of each child link about its CoM, link axes
        self.link_inertia: dict[Side, np.ndarray] = {}
        base = None
        for side in SIDES:
            origins, masses, coms, inertias = [], [], [], []
            for k, jname in enumerate(LEG_JOINTS):
                joint = joints[f"{side}_{jname}"]
                i = JOINT_NAMES.index(f"{side}_{jname}")
                limit = joint.find("limit")
                self.lower[i] = float(limit.get("lower"))
                self.upper[i] = float(limit.get("upper"))
                self.effort[i] = float(limit.get("effort"))
                origin = joint.find("origin")
                origins.append(_floats(origin.get("xyz") if origin is not None else None))
                rpy = _floats(origin.get("rpy") if origin is not None else None)
                axis = _floats(joint.find("axis").get("xyz"))
                if np.any(np.abs(rpy) > 1e-9) or not np.allclose(axis, LEG_AXES[k]):
                    raise ValueError(f"joint {side}_{jname} does not match the IK's leg structure")
                if k == 0:
                    parent = joint.find("parent").get("link")
                    base = parent if base is None else base
                mass, com, inertia = _inertial(links[joint.find("child").get("link")])
                masses.append(mass)
                coms.append(com)
                inertias.append(inertia)
            origins = np.array(origins)
            zero = [1, 2, 5]  # roll/pitch at the hip, roll at the ankle coincide with the previous
            if np.any(np.abs(origins[zero]) > 1e-9) or np.any(np.abs(origins[3:5, :2]) > 1e-9):
                raise ValueError(f"{side} leg joints are not arranged as the analytic IK assumes")
            foot = links[joints[f"{side}_ankle_roll"].find("child").get("link")]
            box = foot.find("collision")
            size = _floats(box.find("geometry").find("box").get("size"))
            center = _floats(box.find("origin").get("xyz"))
            ankle_height = -(center[2] - size[2] / 2.0)
            self.legs[side] = LegGeometry(
                tuple(float(v) for v in origins[0]),
                float(-origins[3, 2]),
                float(-origins[4, 2]),
                float(ankle_height),
            )
            self.link_mass[side] = np.array(masses)
            self.link_com[side] = np.array(coms)
            self.link_inertia[side] = np.array(inertias)
            self.foot = FootGeometry(
                (float(center[0]), float(center[1])), float(size[0]), float(size[1])
            )
        torso = links[base].find("inertial")
        self.base_link = base
        self.torso_mass = float(torso.find("mass").get("value"))
        self.torso_com = _floats(torso.find("origin").get("xyz"))
        self.total_mass = self.torso_mass + sum(float(m.sum()) for m in self.link_mass.values())
        #: per side: (6,) mass moved by each joint (its link and all distal ones)
        self._distal_mass = {
            side: np.cumsum(m[::-1])[::-1].copy() for side, m in self.link_mass.items()
        }
        #: _upper[k, j] = 1 when joint k moves link j (k <= j)
        self._upper = np.triu(np.ones((6, 6)))
        #: _pair_mask_j[j, k, l] = 1 when joints k and l both move link j
        self._pair_mask_j = (self._upper[:, None, :] * self._upper[None, :, :]).transpose(2, 0, 1)

    def leg_frames(self, side: Side, q_leg: np.ndarray) -> LegFrames:
        """Forward kinematics of one leg (torso frame)."""
        return leg_forward(self.legs[side], q_leg)

    def leg_ik(
        self, side: Side, foot_position: np.ndarray, foot_rotation: np.ndarray
    ) -> np.ndarray:
        """Joint angles (6,) of one leg for a foot pose in the torso frame."""
        return leg_ik(self.legs[side], foot_position, foot_rotation, min_knee=0.05)

    def com_from_frames(self, frames: dict[Side, LegFrames]) -> np.ndarray:
        """Whole-body centre of mass (3,) in the torso frame, given both legs' frames."""
        total = self.torso_mass * self.torso_com
        for side in SIDES:
            f = frames[side]
            # link k's frame: origin at joint k, orientation rotations[k]
            coms = f.positions + np.einsum("kij,kj->ki", f.rotations, self.link_com[side])
            total = total + self.link_mass[side] @ coms
        return total / self.total_mass

    def com(self, q: np.ndarray) -> np.ndarray:
        """Whole-body centre of mass (3,) in the torso frame for the 12 joint angles ``q``."""
        return self.com_from_frames(
            {side: self.leg_frames(side, q[6 * i : 6 * i + 6]) for i, side in enumerate(SIDES)}
        )

    def link_coms(self, side: Side, frames: LegFrames) -> np.ndarray:
        """(6, 3) centres of mass of one leg's links in the torso frame."""
        return frames.positions + np.einsum("kij,kj->ki", frames.rotations, self.link_com[side])

    def leg_gravity_torques(self, side: Side, frames: LegFrames, gravity: np.ndarray) -> np.ndarray:
        """Joint torques (6,) that hold one leg's own weight (torso frame fixed).

        ``gravity`` (3,) is the gravity vector in the torso frame (m/s^2).
        """
        coms = self.link_coms(side, frames)
        mass = self.link_mass[side]
        # all link weights are parallel: sum_{j>=k} (c_j - p_k) x m_j g = (S_k - M_k p_k) x g
        # with S_k = sum_{j>=k} m_j c_j and M_k = sum_{j>=k} m_j
        s_k = np.cumsum((mass[:, None] * coms)[::-1], axis=0)[::-1]
        m_k = self._distal_mass[side]
        lever = s_k - m_k[:, None] * frames.positions
        return -np.einsum("ij,ij->i", frames.axes, cross(lever, gravity))

    def leg_mass_matrix(self, side: Side, frames: LegFrames) -> np.ndarray:
        """(6, 6) joint-space inertia of one leg with the torso held fixed."""
        coms = self.link_coms(side, frames)
        axes, pos, rot = frames.axes, frames.positions, frames.rotations
        # jv[k, j] = a_k x (c_j - p_k): velocity of link j's CoM per unit rate of joint k <= j
        jv = cross(axes[:, None, :], coms[None, :, :] - pos[:, None, :]) * self._upper[:, :, None]
        weighted = jv * self.link_mass[side][None, :, None]
        linear = weighted.reshape(6, 18) @ jv.reshape(6, 18).T
        # angular: sum over links j >= max(k, l) of a_k^T R_j I_j R_j^T a_l
        local = np.matmul(rot.transpose(0, 2, 1), axes.T[None, :, :])  # (j, 3, k)
        quad = np.matmul(local.transpose(0, 2, 1), np.matmul(self.link_inertia[side], local))
        return linear + (quad * self._pair_mask_j).sum(axis=0)

    def clip_to_limits(self, q: np.ndarray, margin: float = 0.02) -> np.ndarray:
        """Return ``q`` clipped inside the URDF joint limits (minus ``margin`` rad)."""
        return np.clip(q, self.lower + margin, self.upper - margin)
