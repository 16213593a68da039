"""ZMP preview walking controller of the biped, closed around the measured base state.

:class:`BipedZmpController` composes the parts below; per tick (``control_period``, 5 ms by
default) :meth:`BipedZmpController.update`:

1. filters the velocity command: clipped to the limits, acceleration-limited
   (:mod:`command_filter`);
2. estimates the whole-body CoM, its velocity, the divergent component of motion (DCM,
   capture point) and the sole poses from the base pose/twist and the joint angles
   (:mod:`state_estimate`);
3. advances the gait: stand, or steps of double support (the ZMP moves onto the new support
   foot) then single support (the other foot swings); stance feet are taken where they are
   *measured*, so the plan never drifts away from the real feet (:mod:`gait_schedule`);
4. builds the ZMP reference over the preview horizon from the footsteps the planner gives for
   the command (:mod:`zmp_reference`, :mod:`footstep_planner`) and runs the ZMP preview
   controller (Kajita 2003), which gives the reference CoM, ZMP and DCM (:mod:`balance`);
5. DCM tracking (ankle strategy): desired ZMP = preview ZMP + (1 + k/omega) (DCM error),
   clipped to the support polygon (:mod:`balance`); the compliant stance ankles get the
   feed-forward torques of the LIPM ground reaction at that ZMP, so they *produce* it
   (:mod:`feedforward`);
6. re-plans the swing target until it is frozen and, when the DCM error exceeds what the
   ZMP can still correct inside the sole, adds the excess predicted at touchdown to it
   (stepping strategy); the swing foot follows a re-targetable min-jerk trajectory
   (:mod:`swing`);
7. solves both legs by analytic IK from the filtered torso orientation, with stance-hip
   offsets that turn the torso upright and to the heading between the feet, and blends the
   stance/swing PD gains (:mod:`joint_targets`).

The output is a JointCommand of position targets, their rates, per-leg PD gains (ramped at
touchdown/lift-off) and feed-forward torques. No ROS dependency. Frames follow REP-103/105:
positions in odom, the base twist in base_link; units m, s, rad, N m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.gait.biped.balance import Balance
from safe_legged_c3bf.gait.biped.command_filter import CommandFilter
from safe_legged_c3bf.gait.biped.feedforward import FeedforwardTorques
from safe_legged_c3bf.gait.biped.footstep_planner import FootstepPlanner, clamp
from safe_legged_c3bf.gait.biped.gait_schedule import GaitMode, GaitSchedule, LegPhase
from safe_legged_c3bf.gait.biped.joint_targets import JointTargets, LegGains
from safe_legged_c3bf.gait.biped.model import BipedModel
from safe_legged_c3bf.gait.biped.params import BipedParams
from safe_legged_c3bf.gait.biped.side import SIDES, Side
from safe_legged_c3bf.gait.biped.state_estimate import StateEstimator
from safe_legged_c3bf.gait.biped.swing import SwingPlanner
from safe_legged_c3bf.gait.biped.zmp_reference import zmp_reference
from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.interfaces.joint_command import JointCommand

#: parameter file loaded by :meth:`BipedZmpController.from_config` by default
DEFAULT_CONFIG = "biped_controller.yaml"


@dataclass
class ControllerStatus:
    """Diagnostics of the last tick (for logging and tests).

    Attributes:
        mode: standing or walking.
        support: the support foot while walking (None when standing).
        com_measured: (3,) CoM in odom.
        com_reference: (2,) preview CoM.
        zmp_reference: (2,) preview ZMP reference at this tick.
        zmp_desired: (2,) desired ZMP after the DCM feedback.
        dcm_error: (2,) measured minus reference DCM (m).
        step_adjustment: (2,) capture-point correction of the swing target (m).
        steps_taken: number of completed steps.

    """

    mode: GaitMode = GaitMode.STAND
    support: Side | None = None
    com_measured: np.ndarray | None = None
    com_reference: np.ndarray | None = None
    zmp_reference: np.ndarray | None = None
    zmp_desired: np.ndarray | None = None
    dcm_error: np.ndarray | None = None
    step_adjustment: np.ndarray | None = None
    steps_taken: int = 0


class BipedZmpController:
    """ZMP preview gait controller of the project's biped (implements ``GaitController``)."""

    def __init__(self, params: BipedParams | None = None, model: BipedModel | None = None):
        """Create the controller; ``params`` default to :class:`BipedParams` defaults."""
        self.params = params if params is not None else BipedParams()
        self.model = model if model is not None else BipedModel()
        self.joint_names = list(self.model.joint_names)
        gait = self.params.gait
        self.control_period = gait.control_period
        self.balance = Balance(gait, self.params.feedback, self.model.foot)
        self.omega = self.balance.omega
        self.planner = FootstepPlanner(gait, self.params.steps)
        self.command = CommandFilter(self.params.command)
        self.schedule = GaitSchedule(gait, self.planner)
        self.swing = SwingPlanner(
            self.planner, gait, self.params.feedback, self.omega, self.model.foot
        )
        self.feedforward = FeedforwardTorques(self.model, self.params, self.planner, self.omega)
        self.estimator = StateEstimator(
            self.model, self.omega, self.params.feedback, self.control_period
        )
        self._preview_offsets = gait.control_period * np.arange(self.balance.preview.n_preview + 1)
        self.targets = JointTargets(self.model, self.params)
        self.gains = LegGains(self.params.gains)
        self.status = ControllerStatus()
        self.reset()

    @classmethod
    def from_config(cls, config_file: str | None = None) -> BipedZmpController:
        """Build the controller from a YAML parameter file.

        Args:
            config_file: path of a plain or ROS 2 parameter-file YAML (relative paths are
                looked up in the package's config directory); None loads the package's
                ``config/biped_controller.yaml``.

        """
        return cls(BipedParams.from_yaml(config_file or DEFAULT_CONFIG))

    # ------------------------------------------------------------------ public API
    def reset(self) -> None:
        """Forget all state; the next :meth:`update` re-initialises from the measurement."""
        self._initialized = False
        self._t_last: float | None = None
        self.command.reset()
        self.schedule.reset()
        self.targets.reset()
        self.estimator.reset()

    @property
    def mode(self) -> GaitMode:
        """Standing or walking (a StrEnum: equal to 'stand' or 'walk')."""
        return self.schedule.mode

    def update(
        self,
        t: float,
        base: BaseState,
        q: np.ndarray,
        dq: np.ndarray,
        command: VelocityCommand,
    ) -> JointCommand:
        """Return the motor command for time ``t`` given the measured state and command."""
        q = np.asarray(q, dtype=float)
        dq = np.asarray(dq, dtype=float)
        if not (base.is_finite() and np.all(np.isfinite(q)) and np.isfinite(t)):
            return self._hold(q)
        if not self._initialized or self._t_last is None or t < self._t_last - 1e-9:
            self._initialize(t, base, q)
        dt = self.control_period
        n_ticks = self._ticks_since_last(t)
        elapsed = n_ticks * dt
        self.command.update(command, elapsed, standing=self.schedule.settled(t))
        meas = self.estimator.update(base, q, elapsed)
        if self.schedule.advance(t, meas.feet, self.command):
            self.balance.reanchor(meas, self.schedule.step.zmp_start)

        # ---- reference: ZMP from the footsteps -> preview control -> reference CoM/DCM
        zmp_ref = zmp_reference(self.schedule, self.command, t + self._preview_offsets)
        ref = self.balance.follow(zmp_ref, n_ticks)

        # ---- DCM (capture point) tracking: desired ZMP, kept inside the support polygon
        phase = self.schedule.phases(t)
        self.schedule.track_stance_feet(phase, meas.feet)
        stance = [self.schedule.footstep(s) for s in SIDES if phase[s] is LegPhase.STANCE]
        zmp_cmd, dcm_err = self.balance.desired_zmp(meas.dcm, ref, stance)
        # ---- stepping strategy: move the swing target by the predicted DCM error at touchdown
        adjustment = self.swing.update_target(self.schedule.step, t, meas.dcm, self.command)

        # ---- desired feet poses (odom) and the torso pose the legs are solved from
        feet = self._feet_targets(t, phase)
        weights = {side: self.schedule.stance_weight(t, side) for side in SIDES}
        ground_z = self.schedule.ground_z
        q_des, dq_des, ddq_des = self.targets.solve(meas, feet, phase, weights, ground_z, elapsed)
        kp, kd = self.gains.blend(weights)
        tau = self.feedforward.torques(meas, phase, feet, zmp_cmd, ddq_des)
        # the drivers hold q* for a whole tick: aim at the middle of it
        q_cmd = q_des + 0.5 * dt * dq_des

        self.status = ControllerStatus(
            mode=self.schedule.mode,
            support=self.schedule.step.support.side if self.schedule.step is not None else None,
            com_measured=meas.com.copy(),
            com_reference=ref.com.copy(),
            zmp_reference=zmp_ref[0].copy(),
            zmp_desired=zmp_cmd.copy(),
            dcm_error=dcm_err.copy(),
            step_adjustment=adjustment,
            steps_taken=self.schedule.steps_taken,
        )
        return JointCommand(self.joint_names, q_cmd, dq_des, kp, kd, tau)

    # ------------------------------------------------------------------ internals
    def _hold(self, q: np.ndarray) -> JointCommand:
        """Safe command on invalid input: hold the last target (or the measured angles)."""
        target = self.targets.last if self.targets.last is not None else np.nan_to_num(q)
        kp, kd = self.gains.stance()
        return JointCommand(self.joint_names, target, np.zeros(12), kp, kd, np.zeros(12))

    def _ticks_since_last(self, t: float) -> int:
        """Control periods (1 to 10) since the last update: the preview advances by as many."""
        if self._first_tick:
            n_ticks = 1
            self._first_tick = False
        else:
            n_ticks = int(clamp(round((t - self._t_last) / self.control_period), 1, 10))
        self._t_last = t
        return n_ticks

    def _initialize(self, t: float, base: BaseState, q: np.ndarray) -> None:
        """Restart every part from this measurement, standing."""
        self.reset()
        self._initialized = True
        self._first_tick = True
        self._t_last = t
        meas = self.estimator.initialize(base, q)
        self.schedule.initialize(t, meas.feet)
        self.balance.reset(meas.com[:2])

    def _feet_targets(self, t: float, phase: dict[Side, LegPhase]) -> dict[Side, np.ndarray]:
        """Desired (x, y, z, yaw) of both soles in odom: stance feet stay, the swing foot moves."""
        feet = {side: self.schedule.feet[side].copy() for side in SIDES}
        step = self.schedule.step
        if step is not None and phase[step.swing] is LegPhase.SWING:
            feet[step.swing] = self.swing.foot_pose(step, t, self.schedule.ground_z)
        return feet
