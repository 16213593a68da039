"""Measured state of the biped, computed once per tick from the base state and joint angles.

Odometry (base_link pose in odom, twist in base_link; REP-105) is taken as is; from it and the
joint angles the estimator derives, in odom (REP-103: x forward, y left, z up):

* the whole-body centre of mass from the URDF mass model, and its velocity (finite
  difference of the CoM, low-passed; on the first tick, from the base twist);
* the divergent component of motion (DCM, capture point) xi = c + c_dot / omega;
* the pose (x, y, z, yaw) of both soles;
* a low-passed torso roll/pitch/yaw, which the legs are solved in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.gait.biped.leg_ik import LegFrames
from safe_legged_c3bf.gait.biped.model import BipedModel
from safe_legged_c3bf.gait.biped.params import FeedbackGains
from safe_legged_c3bf.gait.biped.side import SIDES, Side
from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.rotations import wrap_angle


@dataclass(frozen=True)
class BipedEstimate:
    """The measured state of one tick.

    Attributes:
        position: (3,) base_link origin in odom (m).
        rotation: (3, 3) base_link -> odom.
        rpy: (3,) measured roll, pitch, yaw of base_link (rad, ZYX).
        tilt: (3,) low-passed roll, pitch, yaw (rad).
        frames: per leg, its forward kinematics in base_link.
        com_local: (3,) whole-body CoM in base_link (m).
        com: (3,) whole-body CoM in odom (m).
        com_velocity: (3,) filtered CoM velocity in odom (m/s).
        dcm: (2,) horizontal DCM in odom (m).
        feet: per leg, (4,) sole pose (x, y, z, yaw) in odom (m, rad).

    """

    position: np.ndarray
    rotation: np.ndarray
    rpy: np.ndarray
    tilt: np.ndarray
    frames: dict[Side, LegFrames]
    com_local: np.ndarray
    com: np.ndarray
    com_velocity: np.ndarray
    dcm: np.ndarray
    feet: dict[Side, np.ndarray]


class StateEstimator:
    """Whole-body CoM, its velocity, the DCM, the soles and the filtered torso orientation."""

    def __init__(
        self, model: BipedModel, omega: float, feedback: FeedbackGains, tick: float
    ) -> None:
        """Estimate with the mass model ``model``.

        Args:
            model: kinematic and mass model of the biped.
            omega: LIPM natural frequency sqrt(g / z_c) (1/s).
            feedback: its com_velocity_filter and tilt_filter time constants (s) are used.
            tick: control period (s), the time step of the tilt filter.

        """
        self.model = model
        self.omega = omega
        self.feedback = feedback
        self.tick = tick
        self.reset()

    def reset(self) -> None:
        """Forget the filters' state."""
        self._com_prev: np.ndarray | None = None
        self._com_vel = np.zeros(3)
        self._tilt = np.zeros(3)

    def initialize(self, base: BaseState, q: np.ndarray) -> BipedEstimate:
        """Restart the filters from this measurement and return its estimate."""
        self.reset()
        self._tilt = base.rpy.copy()
        return self._measure(base, q, 0.0)

    def update(self, base: BaseState, q: np.ndarray, dt: float) -> BipedEstimate:
        """Estimate of ``base`` and the 12 joint angles ``q`` (rad), ``dt`` s after the last."""
        rpy = base.rpy
        tc = self.feedback.tilt_filter
        alpha = self.tick / (tc + self.tick) if tc > 0 else 1.0
        self._tilt[:2] += alpha * (rpy[:2] - self._tilt[:2])
        self._tilt[2] += alpha * wrap_angle(rpy[2] - self._tilt[2])
        return self._measure(base, q, dt, rpy)

    def _measure(
        self, base: BaseState, q: np.ndarray, dt: float, rpy: np.ndarray | None = None
    ) -> BipedEstimate:
        rot = base.rotation
        pos = base.position
        frames = {side: self.model.leg_frames(side, q[side.joints]) for side in SIDES}
        com_local = self.model.com_from_frames(frames)
        com = pos + rot @ com_local
        if self._com_prev is not None and dt > 0:
            raw = (com - self._com_prev) / dt
            tc = self.feedback.com_velocity_filter
            alpha = dt / (tc + dt) if tc > 0 else 1.0
            self._com_vel = self._com_vel + alpha * (raw - self._com_vel)
        elif self._com_prev is None:
            omega_w = base.angular_velocity_world
            self._com_vel = base.linear_velocity_world + np.cross(omega_w, rot @ com_local)
        self._com_prev = com.copy()
        feet = {}
        for side in SIDES:
            f = frames[side]
            p = pos + rot @ f.foot_position
            r = rot @ f.foot_rotation
            feet[side] = np.array([p[0], p[1], p[2], math.atan2(r[1, 0], r[0, 0])])
        return BipedEstimate(
            position=pos,
            rotation=rot,
            rpy=base.rpy if rpy is None else rpy,
            tilt=self._tilt.copy(),
            frames=frames,
            com_local=com_local,
            com=com,
            com_velocity=self._com_vel.copy(),
            dcm=com[:2] + self._com_vel[:2] / self.omega,
            feet=feet,
        )
