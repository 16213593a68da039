"""The swing foot: where it lands (re-planned, capture-point adjusted) and how it gets there.

Until ``replan_until`` of the swing the target is re-planned every tick from the support foot
and the command. During the swing the stepping strategy adds a capture-point adjustment: the
footstep plan predicts the capture point now, xi_nom = z + (xi_td - z) e^(-omega T) (z:
support sole centre, xi_td: planned capture point at touchdown in T s). Per axis of the
support foot the ankles can still remove an error up to ``room``, the distance from the sole
centre to its edge (minus the margin); the part beyond it grows as (error - room) e^(omega T)
until touchdown, and the target moves by ``step_adjust_gain`` times that predicted excess, so
the next support takes it over. The foot follows a :class:`SwingTrajectory` towards the
(moving) target. Poses are (x, y, z, yaw) in odom (REP-103; m, rad).
"""

from __future__ import annotations

import math

import numpy as np

from safe_legged_c3bf.gait.biped.command_filter import CommandFilter
from safe_legged_c3bf.gait.biped.footstep_planner import FootstepPlanner
from safe_legged_c3bf.gait.biped.gait_schedule import Step
from safe_legged_c3bf.gait.biped.model import FootGeometry
from safe_legged_c3bf.gait.biped.params import FeedbackGains, GaitParams
from safe_legged_c3bf.gait.biped.swing_trajectory import SwingTrajectory
from safe_legged_c3bf.gait.biped.zmp_reference import nominal_dcm_at_touchdown


class SwingPlanner:
    """Swing target and swing foot pose of the current step."""

    def __init__(
        self,
        planner: FootstepPlanner,
        gait: GaitParams,
        feedback: FeedbackGains,
        omega: float,
        foot: FootGeometry,
    ) -> None:
        """Plan swings with ``planner`` for soles of size ``foot`` (LIPM frequency ``omega``)."""
        self.planner = planner
        self.gait = gait
        self.feedback = feedback
        self.omega = omega
        self.sole_half = foot.half_size

    def update_target(
        self, step: Step | None, t: float, dcm: np.ndarray, command: CommandFilter
    ) -> np.ndarray:
        """Re-plan ``step.target`` at ``t`` (s) for the measured ``dcm`` (2,, odom, m).

        Returns:
            (2,) capture-point adjustment of the target (m, odom), zero when none.

        """
        adjustment = np.zeros(2)
        if step is None or step.frozen:
            return adjustment
        gait, fb = self.gait, self.feedback
        nominal = self.planner.next_target(step.support, command.velocity, command.moving)
        target = nominal
        if t >= step.t_lift and fb.step_adjust_gain > 0:
            remaining = max(step.t_end - t, 0.0)
            support = step.support
            z = self.planner.zmp_point(support)
            xi_td = nominal_dcm_at_touchdown(
                self.planner, command, self.omega, gait.step_period, support, nominal
            )
            xi_nom = z + (xi_td - z) * math.exp(-self.omega * remaining)
            c, s_ = math.cos(support.yaw), math.sin(support.yaw)
            d = dcm - xi_nom
            err = np.array([c * d[0] + s_ * d[1], -s_ * d[0] + c * d[1]])
            room = np.maximum(self.sole_half - fb.support_margin, 0.0)
            excess = np.sign(err) * np.maximum(np.abs(err) - room, 0.0)
            local = fb.step_adjust_gain * excess * math.exp(self.omega * remaining)
            adjust = np.array([c * local[0] - s_ * local[1], s_ * local[0] + c * local[1]])
            norm = math.hypot(adjust[0], adjust[1])
            if norm > fb.max_step_adjust:
                adjust *= fb.max_step_adjust / norm
            target = self.planner.clamp(step.support, nominal.moved(adjust))
            adjustment = target.xy - nominal.xy
        step.target = target
        if t >= step.t_lift + gait.replan_until * step.single_support:
            step.frozen = True
        return adjustment

    def foot_pose(self, step: Step, t: float, ground_z: float) -> np.ndarray:
        """Desired (4,) pose of the swing foot at ``t`` (s), landing at height ``ground_z``."""
        gait = self.gait
        if step.trajectory is None:
            step.trajectory = SwingTrajectory(
                step.swing_start,
                step.t_lift,
                step.single_support,
                gait.step_height,
                gait.swing_lift_fraction,
                gait.swing_land_fraction,
            )
        target = np.array([step.target.x, step.target.y, ground_z, step.target.yaw])
        pose, _ = step.trajectory.sample(t, target)
        return pose
