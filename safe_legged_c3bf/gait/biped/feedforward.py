"""Feed-forward joint torques of both legs.

Every leg carries its own weight; the stance legs carry the ground reaction the LIPM needs for
the commanded ZMP, F = M (omega^2 (c - zmp), g), applied at that ZMP (split between the feet
in double support) -- which is what makes the compliant stance ankles produce it; the swing
leg gets its inertia times the desired joint acceleration. Torques in N m, joint order of the
controller (left leg first); positions in odom, forces mapped into base_link (REP-103).
"""

from __future__ import annotations

import numpy as np

from safe_legged_c3bf.gait.biped.footstep_planner import Footstep, FootstepPlanner, clamp
from safe_legged_c3bf.gait.biped.gait_schedule import LegPhase
from safe_legged_c3bf.gait.biped.leg_ik import static_torques
from safe_legged_c3bf.gait.biped.lipm_preview import GRAVITY
from safe_legged_c3bf.gait.biped.model import BipedModel, FootGeometry
from safe_legged_c3bf.gait.biped.params import BipedParams
from safe_legged_c3bf.gait.biped.side import SIDES, Side
from safe_legged_c3bf.gait.biped.state_estimate import BipedEstimate


class FeedforwardTorques:
    """Gravity, swing inertia and stance ground-reaction torques."""

    def __init__(
        self, model: BipedModel, params: BipedParams, planner: FootstepPlanner, omega: float
    ) -> None:
        """Torques for ``model`` with the gains of ``params``; ``omega`` is the LIPM's (1/s)."""
        self.model = model
        self.gains = params.gains
        self.margin = params.feedback.support_margin
        self.planner = planner
        self.omega = omega

    def torques(
        self,
        estimate: BipedEstimate,
        phases: dict[Side, LegPhase],
        feet: dict[Side, np.ndarray],
        zmp: np.ndarray,
        ddq_des: np.ndarray,
    ) -> np.ndarray:
        """Feed-forward torques (12,).

        Args:
            estimate: the measured state.
            phases: stance or swing per leg.
            feet: per leg, desired (4,) sole pose (x, y, z, yaw) in odom.
            zmp: (2,) commanded ZMP in odom (m).
            ddq_des: (12,) desired joint accelerations (rad/s^2).

        """
        tau = np.zeros(12)
        scale = self.gains.feedforward
        if scale == 0.0:
            return tau
        rot, pos = estimate.rotation, estimate.position
        gravity_local = rot.T @ np.array([0.0, 0.0, -GRAVITY])
        for side in SIDES:
            frames = estimate.frames[side]
            tau[side.joints] = self.model.leg_gravity_torques(side, frames, gravity_local)
            if phases[side] is LegPhase.SWING and self.gains.inertia_feedforward > 0.0:
                inertia = self.model.leg_mass_matrix(side, frames)
                tau[side.joints] += self.gains.inertia_feedforward * inertia @ ddq_des[side.joints]
        horizontal = self.omega**2 * (estimate.com[:2] - zmp)
        force = self.model.total_mass * np.array([horizontal[0], horizontal[1], GRAVITY])
        stance = [s for s in SIDES if phases[s] is LegPhase.STANCE]
        for side, (cop_xy, share) in self._centres_of_pressure(stance, feet, zmp).items():
            cop = np.array([cop_xy[0], cop_xy[1], feet[side][2]])
            f_local = rot.T @ (share * force)
            cop_local = rot.T @ (cop - pos)
            tau[side.joints] += static_torques(estimate.frames[side], f_local, cop_local)
        return scale * tau

    def _centres_of_pressure(
        self, stance: list[Side], feet: dict[Side, np.ndarray], zmp: np.ndarray
    ) -> dict[Side, tuple[np.ndarray, float]]:
        """Per stance foot: its centre of pressure (2,) and its share of the load.

        In double support the ZMP is split along the segment between the feet's ZMP points;
        what lies off that segment is added to both feet's points, clipped to each sole.
        """
        if len(stance) == 1:
            return {stance[0]: (zmp, 1.0)}
        left = Footstep.from_pose(Side.LEFT, feet[Side.LEFT])
        right = Footstep.from_pose(Side.RIGHT, feet[Side.RIGHT])
        pl = self.planner.zmp_point(left)
        pr = self.planner.zmp_point(right)
        seg = pr - pl
        alpha = clamp(float((zmp - pl) @ seg) / max(float(seg @ seg), 1e-9), 0.0, 1.0)
        residual = zmp - (pl + alpha * seg)
        foot = self.model.foot
        return {
            Side.LEFT: (clip_to_sole(left, pl + residual, foot, self.margin), 1.0 - alpha),
            Side.RIGHT: (clip_to_sole(right, pr + residual, foot, self.margin), alpha),
        }


def clip_to_sole(
    step: Footstep, point: np.ndarray, foot: FootGeometry, margin: float
) -> np.ndarray:
    """The point (2,) of the sole of ``step`` (shrunk by ``margin``, m) nearest ``point``."""
    local = step.to_local(point)
    hx = max(foot.length / 2 - margin, 0.0)
    hy = max(foot.width / 2 - margin, 0.0)
    local[0] = clamp(local[0], foot.center[0] - hx, foot.center[0] + hx)
    local[1] = clamp(local[1], foot.center[1] - hy, foot.center[1] + hy)
    return step.to_world(local)
