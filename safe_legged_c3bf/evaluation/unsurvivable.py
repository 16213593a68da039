"""Runs no controller could have kept collision-free: a mover driven into a slow robot.

Definition (doc/evaluation.md, "Unsurvivable runs"). A mover (a vertical obstacle whose script
moves it, tall enough to reach the trunk) makes a run **unsurvivable** when, at some
*reveal time* ``t0`` of its script (t = 0 and every moment its scripted velocity changes:
it starts, turns at a waypoint, turns back, stops), with the robot where it really was at
``t0`` (ground truth; without a trajectory only ``t0 = 0`` at the start pose is checked) and
not yet touching it, there is a later time ``t1`` at which **every** position the robot could
have reached since ``t0`` overlaps the mover. Before ``t0`` the coming motion could not be
known from the mover's present state, so no controller that reacts to what it sees (which is
all a safety filter is) could have avoided being where it was.

It is deliberately conservative (it errs on the side of *not* flagging):

* the robot's reachable set is over-approximated by a box in its frame at ``t0`` that
  assumes it reaches any speed instantly (no acceleration limits), with the most permissive
  limits of the filter and the gait controller (:func:`escape_limits`), turning at its max
  yaw rate while it moves: forward / backward / lateral extents are the integrals of the
  largest velocity component possible in that direction given the heading change so far;
* the robot is only its inscribed trunk disc (``TRUNK_RADIUS``: half the trunk's width) and
  the mover its inscribed disc (smaller semi-axis), so "overlap" means the bodies certainly
  touch;
* a box corner exactly on the boundary does not count (1 mm tolerance).

Units: m, s, rad; odom frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from safe_legged_c3bf.sim.scenario import ObstacleConfig, Scenario

#: Inscribed radius (m) of the trunk seen from above: half its width (A1 trunk box 0.194 m,
#: biped torso box 0.16 m wide).
TRUNK_RADIUS = {"quadruped": 0.097, "biped": 0.08}
#: Highest base height (m) of each robot: a mover lower than this may pass under the trunk.
TRUNK_HEIGHT = {"quadruped": 0.285, "biped": 0.82}
#: Time step (s) of the check.
DT = 0.02
#: A corner must be this far inside the overlap disc (m).
TOLERANCE = 1e-3


@dataclass(frozen=True)
class EscapeLimits:
    """Fastest motion the robot could make, in its body frame (m/s, rad/s)."""

    forward: float
    reverse: float
    lateral: float
    yaw_rate: float


@dataclass(frozen=True)
class Threat:
    """A mover no reaction from ``t0`` on could escape: contact certain at ``t1`` (s)."""

    obstacle: str
    t0: float
    t1: float
    robot_xy: tuple[float, float]

    def describe(self) -> str:
        """One line for the results table."""
        return (f"{self.obstacle}: from t = {self.t0:.2f} s (robot at {self.robot_xy[0]:.2f}, "
                f"{self.robot_xy[1]:.2f}) contact certain by t = {self.t1:.2f} s")


def escape_limits(scenario: Scenario) -> EscapeLimits:
    """The most permissive of the scenario's filter limits and the gait controller's range."""
    from safe_legged_c3bf.safety.params import LATERAL_MODELS
    from safe_legged_c3bf.sim.scenario_clearance import filter_params

    p = filter_params(scenario)
    lateral = p.max_lateral_speed if p.model in LATERAL_MODELS else 0.0
    if scenario.robot.kind == "biped":
        from safe_legged_c3bf.gait.biped.params import CommandLimits

        c = CommandLimits()
        gait = (c.vx_max, -c.vx_min, c.vy_max, c.yaw_rate_max)
    else:
        from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams

        q = QuadrupedParams()  # its command filter clips vx to +-max_forward_speed
        gait = (q.max_forward_speed, q.max_forward_speed, q.max_lateral_speed, q.max_yaw_rate)
    mine = (p.max_speed, p.max_reverse_speed, lateral, p.max_yaw_rate)
    return EscapeLimits(*(max(float(a), float(b)) for a, b in zip(mine, gait, strict=True)))


def reach_box(limits: EscapeLimits, horizon: float, dt: float = DT) -> np.ndarray:
    """``(k, 3)`` forward, backward and lateral extents (m) of the reachable box at k * dt.

    In the robot's frame at the start; row 0 is the start (zeros).
    """
    vf, vr, vl, w = limits.forward, limits.reverse, limits.lateral, limits.yaw_rate
    k = int(math.ceil(horizon / dt)) + 1
    t = np.arange(k) * dt
    theta = np.linspace(0.0, math.pi, 361)
    cos, sin = np.cos(theta), np.abs(np.sin(theta))
    ahead = np.where(cos >= 0, vf, vr) * np.abs(cos) + vl * sin
    behind = np.where(cos >= 0, vr, vf) * np.abs(cos) + vl * sin
    side = max(vf, vr) * sin + vl * np.abs(cos)
    # Largest value over |theta| <= min(w t, pi): running maxima along theta.
    reach = np.minimum(w * t, math.pi)
    idx = np.clip(np.searchsorted(theta, reach, side="right") - 1, 0, len(theta) - 1)
    rates = np.column_stack([np.maximum.accumulate(ahead)[idx],
                             np.maximum.accumulate(behind)[idx],
                             np.maximum.accumulate(side)[idx]])
    out = np.zeros((k, 3))
    out[1:] = np.cumsum(rates[1:] * dt, axis=0)  # right Riemann sum of non-decreasing rates:
    return out  # an upper bound of the integral


def reveal_times(obs: ObstacleConfig, duration: float, dt: float = DT) -> list[float]:
    """The reveal times (s) of ``obs``: t = 0 and whenever its scripted velocity changes."""
    from safe_legged_c3bf.sim.obstacles import MotionScript

    script = MotionScript(obs.position, obs.motion)
    times = np.arange(0.0, duration + 1e-9, dt)
    vel = np.array([script.state(float(t))[1][:2] for t in times])
    change = np.linalg.norm(np.diff(vel, axis=0), axis=1) > 1e-6
    return [0.0] + [float(times[i]) for i in np.nonzero(change)[0]]


def _pose_at(trajectory: np.ndarray | None, scenario: Scenario, t: float) -> np.ndarray:
    """(x, y, yaw) of the base at ``t``: the trajectory sample at or before t, else the start."""
    if trajectory is None or not len(trajectory):
        return np.array([*scenario.robot.position, scenario.robot.yaw], dtype=float)
    i = max(int(np.searchsorted(trajectory[:, 0], t, side="right")) - 1, 0)
    return trajectory[i, [1, 2, 4]].astype(float)


def _first_certain_contact(pose: np.ndarray, centres: np.ndarray, box: np.ndarray,
                           radius: float) -> int | None:
    """Index of the first sample at which every box corner lies inside the overlap disc."""
    n = min(len(centres), len(box))
    c, s = math.cos(pose[2]), math.sin(pose[2])
    ex, ey = np.array([c, s]), np.array([-s, c])
    worst = np.zeros(n)
    for fx in (box[:n, 0], -box[:n, 1]):
        for fy in (box[:n, 2], -box[:n, 2]):
            corner = pose[:2] + fx[:, None] * ex + fy[:, None] * ey
            worst = np.maximum(worst, np.linalg.norm(corner - centres[:n], axis=1))
    hit = np.nonzero(worst < radius - TOLERANCE)[0]
    return int(hit[0]) if hit.size else None


def unsurvivable_threats(scenario: Scenario, trajectory: np.ndarray | None = None,
                         dt: float = DT) -> list[Threat]:
    """The threats of :mod:`this module's definition <.unsurvivable>` in a run (empty: none).

    ``trajectory``: ground-truth base rows (t, x, y, z, yaw, ...) in odom (the monitor's
    ``odom`` series); None checks only t0 = 0 at the start pose.
    """
    from safe_legged_c3bf.sim.obstacles import MotionScript

    kind = scenario.robot.kind
    box = reach_box(escape_limits(scenario), scenario.duration, dt)
    threats: list[Threat] = []
    for obs in scenario.obstacles:
        if obs.plane != "vertical" or obs.motion.type == "static":
            continue
        if obs.position[2] + obs.extent / 2 < TRUNK_HEIGHT[kind]:
            continue  # its top is below the trunk: it may pass under it
        radius = TRUNK_RADIUS[kind] + min(obs.semi_axes)
        script = MotionScript(obs.position, obs.motion)
        times = reveal_times(obs, scenario.duration, dt) if trajectory is not None else [0.0]
        for t0 in times:
            pose = _pose_at(trajectory, scenario, t0)
            ts = np.arange(t0, scenario.duration + 1e-9, dt)
            centres = np.array([script.state(float(t))[0][:2] for t in ts])
            if np.linalg.norm(centres[0] - pose[:2]) < radius:
                continue  # already touching at t0: not a new threat
            k = _first_certain_contact(pose, centres, box, radius)
            if k is not None:
                threats.append(Threat(obs.id, t0, float(ts[k]), (float(pose[0]), float(pose[1]))))
                break
    return threats
