"""Joint targets of both legs: analytic IK from the torso pose, uprighting, rates, PD gains.

Both legs are solved in the torso's low-passed measured orientation, so the feet stay flat
and the swing foot lands where planned however the torso leans. The stance hips are anchored
where the pelvis really is (the CoM moves by the ankle torques, not by position servoing) at
the LIPM height; the swing leg hangs from a low-passed pelvis so it does not react to its own
reaction torques. Stance-hip offsets then turn the torso upright and to the heading between
the feet. Positions in odom, IK in base_link (REP-103); angles in rad.
"""

from __future__ import annotations

import math

import numpy as np

from safe_legged_c3bf.gait.biped.gait_schedule import LegPhase
from safe_legged_c3bf.gait.biped.leg_ik import rot_z
from safe_legged_c3bf.gait.biped.model import BipedModel
from safe_legged_c3bf.gait.biped.params import BipedParams, JointGains
from safe_legged_c3bf.gait.biped.side import SIDES, Side
from safe_legged_c3bf.gait.biped.state_estimate import BipedEstimate
from safe_legged_c3bf.interfaces.rotations import rpy_to_matrix, wrap_angle

#: limits of the finite-difference joint rates (rad/s) and accelerations (rad/s^2)
_MAX_RATE = 8.0
_MAX_ACCELERATION = 80.0
_HORIZONTAL = np.array([1.0, 1.0, 0.0])


def torso_yaw(feet: dict[Side, np.ndarray]) -> float:
    """Heading (rad) midway between the two soles' yaw; ``feet`` are (x, y, z, yaw) poses."""
    a, b = float(feet[Side.LEFT][3]), float(feet[Side.RIGHT][3])
    return wrap_angle(a + 0.5 * wrap_angle(b - a))


class JointTargets:
    """Joint position, rate and acceleration targets (12,) of both legs."""

    def __init__(self, model: BipedModel, params: BipedParams) -> None:
        """Targets for ``model``; uses the gait's CoM height and the torso feedback gains."""
        self.model = model
        self.com_height = params.gait.com_height
        self.tick = params.gait.control_period
        self.feedback = params.feedback
        hips = np.array([model.legs[side].hip_offset for side in SIDES])
        #: (3,) midpoint of the hips in base_link (m)
        self.pelvis_offset = hips.mean(axis=0)
        self.reset()

    def reset(self) -> None:
        """Forget the previous targets and the swing leg's pelvis filter."""
        #: (12,) joint targets of the last tick, None before the first
        self.last: np.ndarray | None = None
        self._dq_prev = np.zeros(12)
        self._pelvis_filtered: np.ndarray | None = None

    def solve(
        self,
        estimate: BipedEstimate,
        feet: dict[Side, np.ndarray],
        phases: dict[Side, LegPhase],
        weights: dict[Side, float],
        ground_z: float,
        elapsed: float,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Targets q (rad), dq (rad/s), ddq (rad/s^2), each (12,), for this tick.

        Args:
            estimate: the measured state.
            feet: per leg, desired sole pose (x, y, z, yaw) in odom.
            phases: stance or swing per leg.
            weights: per leg, stance weight in [0, 1] (scales the torso uprighting).
            ground_z: ground height in odom (m).
            elapsed: time since the last tick (s).

        """
        r_ik = rpy_to_matrix(estimate.tilt[0], estimate.tilt[1], estimate.tilt[2])
        p_stance, p_swing = self._torso_positions(estimate, r_ik, ground_z, elapsed)
        q_des = np.zeros(12)
        for side in SIDES:
            origin = p_swing if phases[side] is LegPhase.SWING else p_stance
            foot_pos = r_ik.T @ (feet[side][:3] - origin)
            foot_rot = r_ik.T @ rot_z(feet[side][3])
            q_des[side.joints] = self.model.leg_ik(side, foot_pos, foot_rot)
        rpy = estimate.rpy
        self._torso_correction(q_des, weights, rpy, wrap_angle(rpy[2] - torso_yaw(feet)))
        q_des = self.model.clip_to_limits(q_des)
        if self.last is None:
            dq_des = np.zeros(12)
        else:
            dq_des = np.clip((q_des - self.last) / elapsed, -_MAX_RATE, _MAX_RATE)
        ddq_des = np.clip((dq_des - self._dq_prev) / elapsed, -_MAX_ACCELERATION, _MAX_ACCELERATION)
        self.last = q_des.copy()
        self._dq_prev = dq_des.copy()
        return q_des, dq_des, ddq_des

    def _torso_positions(
        self, estimate: BipedEstimate, r_ik: np.ndarray, ground_z: float, elapsed: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Torso (base_link) positions in odom the stance and the swing legs hang from."""
        fb, dt = self.feedback, self.tick
        pelvis = estimate.position + estimate.rotation @ self.pelvis_offset
        pelvis[:2] += 0.5 * elapsed * estimate.com_velocity[:2]
        if self._pelvis_filtered is None:
            self._pelvis_filtered = pelvis.copy()
        a = dt / (fb.swing_anchor_filter + dt) if fb.swing_anchor_filter > 0 else 1.0
        self._pelvis_filtered += elapsed * estimate.com_velocity * _HORIZONTAL
        self._pelvis_filtered += a * (pelvis - self._pelvis_filtered)
        z_torso = ground_z + self.com_height - (r_ik @ estimate.com_local)[2]
        p_stance = pelvis - r_ik @ self.pelvis_offset
        p_stance[2] = z_torso
        p_swing = self._pelvis_filtered - r_ik @ self.pelvis_offset
        p_swing[2] = z_torso
        return p_stance, p_swing

    def _torso_correction(
        self, q_des: np.ndarray, weights: dict[Side, float], rpy: np.ndarray, yaw_err: float
    ) -> None:
        """Add the stance-hip offsets that turn the torso upright and to the desired heading.

        The legs are solved in the torso's measured orientation, which by itself would accept
        any lean; rotating the stance hips by gain x (measured roll, pitch, heading error)
        pushes the torso back. Roll/pitch offsets are projected on each hip's yawed axes;
        each leg's offsets are scaled by its stance weight (0 in swing, ramps at touchdown).
        """
        fb = self.feedback
        err = np.array([fb.torso_roll_gain * rpy[0], fb.torso_pitch_gain * rpy[1]])
        for side in SIDES:
            w = weights[side]
            if w <= 0.0:
                continue
            leg = q_des[side.joints]
            c, s = math.cos(leg[0]), math.sin(leg[0])
            leg[0] += w * fb.torso_yaw_gain * yaw_err
            leg[1] += w * (c * err[0] + s * err[1])
            leg[2] += w * (-s * err[0] + c * err[1])


class LegGains:
    """Motor PD gains of both legs, blended between swing and stance by the stance weight."""

    def __init__(self, gains: JointGains) -> None:
        """Use the (6,) stance and swing tables of ``gains``."""
        self.stance_kp = gains.leg_array("stance_kp")
        self.stance_kd = gains.leg_array("stance_kd")
        self.swing_kp = gains.leg_array("swing_kp")
        self.swing_kd = gains.leg_array("swing_kd")

    def blend(self, weights: dict[Side, float]) -> tuple[np.ndarray, np.ndarray]:
        """Kp (N m/rad) and kd (N m s/rad), each (12,), for per-leg stance ``weights``."""
        kp, kd = np.zeros(12), np.zeros(12)
        for side in SIDES:
            w = weights[side]
            kp[side.joints] = self.swing_kp + w * (self.stance_kp - self.swing_kp)
            kd[side.joints] = self.swing_kd + w * (self.stance_kd - self.swing_kd)
        return kp, kd

    def stance(self) -> tuple[np.ndarray, np.ndarray]:
        """Kp and kd (12,) with both legs in stance."""
        return np.concatenate([self.stance_kp] * 2), np.concatenate([self.stance_kd] * 2)
