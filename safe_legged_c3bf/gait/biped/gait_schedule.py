"""Gait schedule of the biped: standing, or a sequence of steps, and each leg's phase.

A step is a double support (both feet down, the ZMP moves onto the new support foot) then a
single support (the other foot swings to the step's target). Walking starts from standing
with a longer double support, the ZMP first held still for ``start_delay`` so the preview can
prepare the weight shift. At each touchdown the landed foot's *measured* pose becomes the new
support, so the plan never drifts away from the real feet. A zero command stops after the
step that puts the feet side by side; the ZMP then moves back between the feet.

Poses are (x, y, z, yaw) of a sole in odom (REP-103: x forward, y left, z up; m, rad).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.gait.biped.command_filter import CommandFilter
from safe_legged_c3bf.gait.biped.footstep_planner import Footstep, FootstepPlanner, clamp
from safe_legged_c3bf.gait.biped.params import GaitParams
from safe_legged_c3bf.gait.biped.side import SIDES, Side
from safe_legged_c3bf.gait.biped.swing_trajectory import SwingTrajectory

#: fraction of the measured sole height folded into the ground height per standing tick
_GROUND_GAIN = 0.05


class GaitMode(enum.StrEnum):
    """Standing on both feet, or stepping."""

    STAND = "stand"
    WALK = "walk"


class LegPhase(enum.Enum):
    """A leg on the ground, or in the air."""

    STANCE = "stance"
    SWING = "swing"


@dataclass
class Step:
    """One step of the walk: double support on both feet, then ``swing`` in the air.

    Attributes:
        support: the foot that stays on the ground.
        swing_start: (4,) pose of the swing foot at the start of the step.
        target: where the swing foot lands (re-planned until ``frozen``).
        t_start: start of the double support (s).
        double_support: its duration (s).
        single_support: swing duration (s).
        zmp_start: (2,) ZMP reference at ``t_start`` in odom (m).
        hold: time at the start of the double support the ZMP stays at ``zmp_start`` (s).
        trajectory: the swing foot's trajectory, created at lift-off.
        frozen: True once the target is no longer re-planned.

    """

    support: Footstep
    swing_start: np.ndarray
    target: Footstep
    t_start: float
    double_support: float
    single_support: float
    zmp_start: np.ndarray
    hold: float = 0.0
    trajectory: SwingTrajectory | None = None
    frozen: bool = False

    @property
    def swing(self) -> Side:
        """The leg that swings in this step."""
        return self.support.side.other

    @property
    def t_lift(self) -> float:
        """Lift-off time of the swing foot (s)."""
        return self.t_start + self.double_support

    @property
    def t_end(self) -> float:
        """Touchdown time of the swing foot (s)."""
        return self.t_lift + self.single_support


@dataclass(frozen=True)
class ZmpShift:
    """A straight move of the standing ZMP from ``start`` to ``end`` (odom, m) from ``t0`` (s)."""

    t0: float
    start: np.ndarray
    end: np.ndarray

    def at(self, times: np.ndarray, duration: float) -> np.ndarray:
        """ZMP (len(times), 2) at ``times`` for a move lasting ``duration`` s."""
        a = np.clip((times - self.t0) / duration, 0.0, 1.0)[:, None]
        return self.start + a * (self.end - self.start)


class GaitSchedule:
    """When each foot is on the ground and where: the gait mode, current step and stance feet.

    Attributes:
        mode: standing or walking.
        step: the current step while walking, else None.
        feet: per leg, (4,) pose of the foot where it stands (the swing foot: where it lifted
            off); z is the ground height.
        ground_z: ground height in odom (m), learnt while standing.
        stand_zmp: the standing ZMP's move after a stop.
        steps_taken: number of completed steps.

    """

    def __init__(self, gait: GaitParams, planner: FootstepPlanner) -> None:
        """Schedule steps with the timing of ``gait`` and the footsteps of ``planner``."""
        self.gait = gait
        self.planner = planner
        self.reset()

    def reset(self) -> None:
        """Stand, with no feet known."""
        self.mode = GaitMode.STAND
        self.step: Step | None = None
        self.feet: dict[Side, np.ndarray] = {}
        self.ground_z = 0.0
        self.stand_zmp = ZmpShift(0.0, np.zeros(2), np.zeros(2))
        self.steps_taken = 0

    def initialize(self, t: float, feet: dict[Side, np.ndarray]) -> None:
        """Stand at time ``t`` (s) on the measured sole poses ``feet``, the ZMP between them."""
        for side in SIDES:
            self.feet[side] = feet[side].copy()
        self.ground_z = float(np.mean([self.feet[s][2] for s in SIDES]))
        mid = self.stand_midpoint()
        self.stand_zmp = ZmpShift(t, mid, mid)
        self.mode = GaitMode.STAND
        self.step = None

    def footstep(self, side: Side) -> Footstep:
        """Where the ``side`` foot stands (see :attr:`feet`)."""
        return Footstep.from_pose(side, self.feet[side])

    def stand_midpoint(self) -> np.ndarray:
        """Standing ZMP (2,): midway between the feet's ZMP points (odom, m)."""
        return 0.5 * sum(self.planner.zmp_point(self.footstep(s)) for s in SIDES)

    def settled(self, t: float) -> bool:
        """True when standing at ``t`` (s) with the ZMP's move back between the feet done.

        A walk starts from a settled stand only: started while the ZMP (and the CoM after it)
        still moves from the last support foot, the first steps begin off balance.
        """
        shift = self.stand_zmp
        moved = t >= shift.t0 + self.gait.stop_double_support
        return self.mode is GaitMode.STAND and (moved or np.array_equal(shift.start, shift.end))

    def stand_zmp_at(self, times: np.ndarray) -> np.ndarray:
        """Standing ZMP reference (len(times), 2) at ``times`` (s)."""
        return self.stand_zmp.at(times, self.gait.stop_double_support)

    def advance(self, t: float, feet: dict[Side, np.ndarray], command: CommandFilter) -> bool:
        """Advance to time ``t`` (s) given the measured sole poses ``feet`` and the command.

        Returns:
            True when a touchdown started the next step (the reference may be re-anchored).

        """
        gait = self.gait
        if self.mode is GaitMode.STAND:
            # follow the measured sole height while both feet are down (ground level in odom)
            z = float(np.mean([feet[s][2] for s in SIDES]))
            self.ground_z += _GROUND_GAIN * (z - self.ground_z)
            for side in SIDES:
                self.feet[side][2] = self.ground_z
            if not command.moving:
                return False
            swing = self.planner.first_swing_side(command.target)
            support = self.footstep(swing.other)
            zmp_now = self.stand_zmp_at(np.array([t]))[0]
            ds = gait.start_delay + gait.start_double_support
            self.step = self._new_step(support, t, ds, zmp_now, command)
            self.step.hold = gait.start_delay
            self.mode = GaitMode.WALK
            return False
        step = self.step
        if t < step.t_end - 1e-9:
            return False
        # touchdown: the landed foot's measured pose becomes the new support
        landed_side = step.swing
        landed = feet[landed_side].copy()
        target = step.target
        # keep the plan's heading/height but take the measured position and yaw
        self.feet[landed_side] = np.array([landed[0], landed[1], self.ground_z, landed[3]])
        self.steps_taken += 1
        new_support = self.footstep(landed_side)
        old_support = step.support
        if not command.moving and self.planner.is_aligned(old_support, target):
            self.mode = GaitMode.STAND
            self.step = None
            start = self.planner.zmp_point(new_support)
            self.stand_zmp = ZmpShift(step.t_end, start, self.stand_midpoint())
            return False
        zmp_start = self.planner.zmp_point(old_support)
        self.step = self._new_step(new_support, step.t_end, gait.double_support, zmp_start, command)
        return True

    def _new_step(
        self, support: Footstep, t0: float, ds: float, zmp_start, command: CommandFilter
    ) -> Step:
        return Step(
            support=support,
            swing_start=self.feet[support.side.other].copy(),
            target=self.planner.next_target(support, command.velocity, command.moving),
            t_start=t0,
            double_support=ds,
            single_support=self.gait.single_support,
            zmp_start=np.asarray(zmp_start, dtype=float),
        )

    def phases(self, t: float) -> dict[Side, LegPhase]:
        """Stance or swing for each leg at time ``t`` (s)."""
        phase = {side: LegPhase.STANCE for side in SIDES}
        if self.mode is GaitMode.WALK and t >= self.step.t_lift:
            phase[self.step.swing] = LegPhase.SWING
        return phase

    def track_stance_feet(self, phases: dict[Side, LegPhase], feet: dict[Side, np.ndarray]) -> None:
        """A foot on the ground is where it is measured: copy x, y, yaw of ``feet``."""
        for side in SIDES:
            if phases[side] is LegPhase.STANCE:
                self.feet[side][[0, 1, 3]] = feet[side][[0, 1, 3]]

    def stance_weight(self, t: float, side: Side) -> float:
        """1 for a loaded stance leg, 0 for a swing leg, ramps around touchdown/lift-off."""
        step = self.step
        if self.mode is not GaitMode.WALK or step is None:
            return 1.0
        gait = self.gait
        if side == step.swing:
            if t >= step.t_lift:
                return 0.0
            down = clamp((step.t_lift - t) / gait.liftoff_blend, 0.0, 1.0)
            up = 1.0
            if self.steps_taken > 0:  # this foot touched down at t_start
                up = clamp((t - step.t_start) / gait.touchdown_blend, 0.0, 1.0)
            return min(up, down)
        # the support foot touched down at t_start (except for the very first step)
        if step.hold > 0.0:
            return 1.0
        return clamp((t - step.t_start) / gait.touchdown_blend, 0.0, 1.0)
