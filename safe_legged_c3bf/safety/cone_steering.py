"""Cone steering: the reference's heading turned out of the obstacles' collision cones.

The C3BF keeps the robot's relative velocity out of each obstacle's collision cone, but the
QP is myopic: it minimises the change to the reference input, so a reference heading straight
into a cone is braked, not turned, and a robot at rest in front of an obstacle stays there
(every barrier is 0 at rest and only forbids moving towards the obstacles). This stage, in
front of the QP, shapes the reference of a unicycle instead: it keeps the reference where its
heading is free, and otherwise turns it to the free heading nearest the one it asked for
(velocity obstacles with a time horizon, the same cones the barrier uses). The QP still filters
the shaped reference, so no barrier constraint is weakened; the planner stays
obstacle-agnostic.

Geometry (odom, m, m/s, rad): the robot is a disc of radius ``robot_radius`` about its base
(for the whole-body filter its cover's half width, not its length: turning towards a free
heading is what the disc decides); obstacle ``i`` a circle of radius ``r_i`` at ``c_i``
moving at ``w_i``. Heading ``psi`` at speed ``v`` is blocked by obstacle ``i`` when, with
``p = c_i - x`` and ``v_rel = w_i - v (cos psi, sin psi)``, the relative path
``p + v_rel t`` comes within ``r_i + robot_radius`` for some ``t`` in ``[0, horizon]``.
Headings are searched on a grid of ``heading_step`` around the reference heading ``psi_ref =
yaw + wz_ref * lookahead``; the side chosen last is preferred for ``side_memory`` s.

Speed along a steered heading (``cruise_memory`` > 0): a goal-seeking planner slows down with
its heading error (it would rather turn first), and while the steering holds the heading off
the planner's, that error is the filter's doing, not the planner's wish: the robot crawled
along a wall at half the planner's speed. Once the steering has turned or clamped a
reference that asks to walk forward, its forward speed is at least the planner's cruise
speed, the largest forward speed the reference asked for in the last ``cruise_memory`` s
(scaled by the cosine of the heading error while turning towards the free heading). It never
exceeds what the planner itself asked for in that window; the QP filters the result. Headings
are judged at that cruise speed too, the speed the steered robot walks them: judged at a
slowed reference's speed (0.08 m/s reach 1.6 m in 20 s), a bench 2.9 m ahead looked out of
reach while the barrier's cone, which has no horizon, refused the heading.

Walking off from rest: with the heading blocked the robot turns in place to a free one
first (the barrier would refuse the forward part). With ``settle_yaw_rate`` it then lets the
turn settle below that commanded yaw rate and walks straight along the heading; only once
it walks (``START_SPEED``) may the reference turn back towards the cone's edge. Asked to
walk and turn back while still turning, the body points ahead of and behind the base move
sideways, and accelerating forward would sweep the rear one's velocity across the cone: its
row capped the forward acceleration near 0.1 m/s^2 and the QP turned on to relax it (the
yaw is cheap), so the A1 crept 0.37 m in 4 s before a pillar 4.2 m ahead (random A1 seed 5
without movers, in the unit harness of test/filter_harness.py; 0.88 m with 0.05 rad/s, the
A1 profile's). The biped profile keeps it off: over random biped seeds 0-19 it reached 13
goals of 17 with it against 16 without.

Out of a standstill: with no free heading (``stall_detour``), or in a standoff, the robot
turning to and fro in place between the steering's free heading and the planner's blocked
one (``ConeSteering._standoff``), a committed detour round the blocked headings.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.safety import stall_detour
from safe_legged_c3bf.safety.escape import footprint_circles
from safe_legged_c3bf.safety.stall_detour import (
    SWITCH_MARGIN,
    StallDetour,
    chosen_side,
    first_free_offset,
)
from safe_legged_c3bf.safety.velocity_obstacles import first_contact_times

__all__ = [
    "EDGE_STEPS", "MAX_TURN", "START_SPEED", "STATIC_SPEED", "SWITCH_MARGIN", "ConeSteering",
    "Steer",
    "blocked_headings",
    "cover_half_width",
]

MAX_TURN = math.radians(100.0)
"""Largest heading change [rad] the steering asks for: a way on only behind the robot is
not taken (it would walk away from the goal); the reference is kept and the QP brakes."""
EDGE_STEPS = 2
"""Heading steps (of ``heading_step``) the steering keeps off a cone's edge."""
START_SPEED = 0.1
"""Commanded speed [m/s] below which a blocked heading is turned in place before walking."""
STATIC_SPEED = 0.05
"""Speed [m/s] below which an obstacle counts as static (a stall among movers is waited out)."""


@dataclass(frozen=True)
class Steer:
    """A shaped reference: forward speed [m/s], yaw rate [rad/s], and what was done."""

    vx: float
    yaw_rate: float
    side: int  # +1 turned left of the reference heading, -1 right, 0 unchanged
    free: bool  # a free heading was found (False: the reference is kept, the QP brakes)
    detour: bool = False  # on a detour out of a standstill (``stall_detour``)


def cover_half_width(body) -> float:  # noqa: ANN001 - a c3bf RobotBody or None
    """The robot's disc for steering [m]: its cover's half width.

    The footprint circles' reach in y; 0 without a body (the point model's circles are
    already grown by its width).
    """
    if body is None:
        return 0.0
    offsets, radii = footprint_circles(body)
    return float((np.abs(offsets[:, 1]) + radii).max())


def blocked_headings(psi, speed, p, w, radius, horizon) -> np.ndarray:
    """``(k,)`` bool: heading ``psi[j]`` at ``speed`` meets some obstacle within ``horizon``.

    Args:
        psi: ``(k,)`` candidate headings [rad].
        speed: Robot speed along the heading [m/s] (> 0).
        p: ``(n, 2)`` obstacle centres minus the robot position [m].
        w: ``(n, 2)`` obstacle velocities [m/s].
        radius: ``(n,)`` sum of obstacle and robot radii [m].
        horizon: Look-ahead time [s].

    """
    d = np.stack([np.cos(psi), np.sin(psi)], -1)  # (k, 2)
    # Already overlapping (the QP's inside handling answers): blocks only approaching headings.
    return np.isfinite(first_contact_times(speed * d, p, w, radius, horizon))


STANDOFF_REVERSALS = 2
"""Turns back of the yaw (left, right, left) that make a long standstill a standoff."""
SWING = math.radians(10.0)
"""Least turn [rad] of the yaw away from its last extreme that counts as a turn back."""


class _Swing:
    """Counts the yaw's reversals: turns back by at least ``SWING`` from its last extreme."""

    def __init__(self) -> None:
        self.reversals, self._extreme, self._direction = 0, None, 0

    def note(self, yaw: float) -> None:
        """Take this cycle's yaw [rad]."""
        if self._extreme is None:
            self._extreme = yaw
            return
        change = math.remainder(yaw - self._extreme, math.tau)
        if self._direction * change > 0.0:
            self._extreme = yaw  # further the same way: a new extreme
        elif abs(change) >= SWING:
            self.reversals += self._direction != 0  # the first turn is no reversal
            self._direction = 1 if change > 0.0 else -1
            self._extreme = yaw


class ConeSteering:
    """Shapes a unicycle's reference (see the module docstring); keeps the chosen side."""

    def __init__(self, horizon: float, robot_radius: float, lookahead: float,
                 heading_gain: float, heading_step: float = math.radians(5.0),
                 side_memory: float = 3.0, cruise_memory: float = 0.0,
                 min_run: int = 1, settle_yaw_rate: float = 0.0) -> None:
        """Configure the steering (units in the arguments' descriptions).

        ``horizon`` [s], ``robot_radius`` [m], ``lookahead`` [s] (reference heading = yaw +
        wz_ref * lookahead), ``heading_gain`` [1/s] (yaw rate per rad of heading error),
        ``heading_step`` [rad], ``side_memory`` [s], ``cruise_memory`` [s] (0: a steered
        reference keeps its own forward speed; see the module docstring), ``min_run``: the
        fewest free grid headings a run must hold to be turned to
        (``stall_detour.first_free_offset``), ``settle_yaw_rate`` [rad/s] (0: off; see the
        module docstring).
        """
        self.horizon, self.robot_radius = horizon, robot_radius
        self.lookahead, self.heading_gain = lookahead, heading_gain
        self.side_memory, self.cruise_memory = side_memory, cruise_memory
        self.settle_yaw_rate = settle_yaw_rate
        self._asked: deque[tuple[float, float]] = deque()  # (t, vx_ref), vx decreasing
        n = int(math.ceil(MAX_TURN / heading_step))
        offsets = heading_step * np.arange(1, n + 1)
        self._left, self._right = offsets, -offsets
        self._both, self._n = np.concatenate([offsets, -offsets]), n  # one scan, both sides
        self._side, self._side_time = 0, -math.inf
        self.detour = StallDetour(heading_step, heading_gain, START_SPEED, EDGE_STEPS, min_run)
        self._standoff_since: float | None = None  # s: stood while the planner asks to move
        self._swing = _Swing()  # the yaw's turns to and fro during that standstill

    def steer(self, t: float, pos, yaw: float, vx_ref: float, wz_ref: float,
              centers, velocities, radii, max_yaw_rate: float, speed: float = 0.0,
              yaw_rate: float = 0.0) -> Steer:
        """The shaped reference at time ``t`` [s] (see :class:`Steer`).

        ``speed``: the robot's commanded forward speed [m/s]; below ``START_SPEED`` a robot
        whose heading is blocked turns in place before it walks. ``yaw_rate``: its commanded
        yaw rate [rad/s]; from rest on a free heading, with ``settle_yaw_rate``, the turn
        settles below it before the robot walks, straight.
        """
        cruise = self._cruise(t, vx_ref)
        if len(radii) == 0 or self.horizon <= 0.0:
            self.detour.cancel()
            return Steer(vx_ref, wz_ref, 0, True)
        p = np.asarray(centers, dtype=float) - np.asarray(pos, dtype=float)[:2]
        w = np.asarray(velocities, dtype=float)
        r = np.asarray(radii, dtype=float) + self.robot_radius

        def blocked(psi: np.ndarray) -> np.ndarray:  # at the planner's cruise speed
            return blocked_headings(psi, max(cruise, 1e-3), p, w, r, self.horizon)

        detour = self._detour_step(t, yaw, speed, cruise, vx_ref, wz_ref, max_yaw_rate, blocked)
        if detour is None:
            detour = self._standoff(t, yaw, speed, cruise, vx_ref, wz_ref, max_yaw_rate,
                                    blocked, (p, w, r))
        if detour is not None:
            return detour
        if vx_ref <= 1e-3:
            self.detour.reset_stall()
            return Steer(vx_ref, wz_ref, 0, True)
        psi_ref = yaw + wz_ref * self.lookahead
        # The yaw, the reference heading and the scan around the yaw in one call (the scan
        # is what a free yaw needs next; each heading's answer is its own row).
        scan = blocked_headings(np.concatenate([[yaw, psi_ref], yaw + self._both]), cruise,
                                p, w, r, self.horizon)
        yaw_blocked, ref_blocked = scan[0], scan[1]
        if not yaw_blocked:
            self.detour.reset_stall()
            out = self._within_free_interval(yaw, psi_ref, vx_ref, wz_ref, max_yaw_rate,
                                             scan[2:])
            if out.side == 0:
                return out
            if speed < START_SPEED and self.settle_yaw_rate > 0.0:  # the turn settles first
                if abs(yaw_rate) > self.settle_yaw_rate:
                    return Steer(0.0, 0.0, out.side, True)
                return Steer(max(vx_ref, cruise), 0.0, out.side, True)
            return Steer(max(vx_ref, cruise), out.yaw_rate, out.side, True)
        if not ref_blocked:
            self.detour.reset_stall()
            return Steer(vx_ref, wz_ref, 0, True)
        side = self._pick_side(t, psi_ref, cruise, p, w, r)
        if side is None:
            kept = self._side if t - self._side_time <= self.side_memory else 0
            if (self.detour.stalled(t, speed) and self._static_dead_end(psi_ref, cruise, p, w, r)
                    and self.detour.start(t, psi_ref, kept, blocked)):
                detour = self._detour_step(t, yaw, speed, cruise, vx_ref, wz_ref,
                                           max_yaw_rate, blocked)
                if detour is not None:
                    return detour
            return Steer(vx_ref, wz_ref, 0, False)
        self.detour.reset_stall()
        offset_side, offset = side
        error = math.remainder(psi_ref + offset - yaw, math.tau)
        wz = max(-max_yaw_rate, min(max_yaw_rate, self.heading_gain * error))
        # From (near) rest, forward only along a free heading: turn in place first (the
        # barrier would refuse the forward part and, with it, most of the turn). Once
        # walking, the QP turns the robot out of the cone itself.
        if speed < START_SPEED:
            return Steer(0.0, wz, offset_side, True)
        return Steer(max(vx_ref, cruise) * max(math.cos(error), 0.0), wz, offset_side, True)

    def _detour_step(self, t, yaw, speed, cruise, vx_ref, wz_ref, max_yaw_rate,
                     blocked) -> Steer | None:
        """The detour's shaped reference (its side kept as the steering's); None: no detour."""
        out = self.detour.step(t, yaw, speed, cruise, vx_ref, wz_ref, max_yaw_rate, blocked)
        if out is None:
            return None
        self._side, self._side_time = out[2], t
        return Steer(*out, True, True)

    def _standoff(self, t, yaw, speed, cruise, vx_ref, wz_ref, max_yaw_rate, blocked,
                  vo) -> Steer | None:
        """A detour out of a standoff, when one has lasted ``STANDOFF_TIME``; else None.

        A standoff: the robot stands (commanded forward speed below ``START_SPEED``) while
        the planner keeps asking to move and its heading turns to and fro: the steering turns
        it towards a free heading, the planner, whose heading error grows, stops walking and
        turns back in place, and the QP refuses the few cm/s either asks for (random biped
        seeds 4 and 6: 25 s of turning to and fro between pillars, a wall and stopped
        walkers). Judged whatever the steering found free: its velocity obstacles take the
        planner's momentary speed, near zero while it turns. ``STANDOFF_REVERSALS`` turns
        back of at least ``SWING`` tell it from one long turn towards a free heading (a start).
        A detour starts only when the planner's heading is blocked by the static obstacles
        alone at cruise speed (movers are waited out); the clock restarts when the robot
        walks or the planner stops.
        """
        if speed >= START_SPEED or (vx_ref <= 1e-3 and abs(wz_ref) <= 1e-3):
            self._standoff_since = None
            return None
        if self._standoff_since is None:
            self._standoff_since = t
            self._swing = _Swing()
        self._swing.note(yaw)
        if (t - self._standoff_since < stall_detour.STANDOFF_TIME
                or self._swing.reversals < STANDOFF_REVERSALS):
            return None
        p, w, r = vo
        psi_ref = yaw + wz_ref * self.lookahead
        kept = self._side if t - self._side_time <= self.side_memory else 0
        if not (self._blocked_by_static(np.array([psi_ref]), cruise, p, w, r)[0]
                and self.detour.start(t, psi_ref, kept, blocked)):
            return None
        self._standoff_since = None
        return self._detour_step(t, yaw, speed, cruise, vx_ref, wz_ref, max_yaw_rate, blocked)

    def _blocked_by_static(self, psi, cruise, p, w, r) -> np.ndarray:
        """``(k,)`` bool: heading ``psi[j]`` meets a static obstacle (``STATIC_SPEED``)."""
        still = np.hypot(w[:, 0], w[:, 1]) < STATIC_SPEED
        if not still.any():
            return np.zeros(len(psi), dtype=bool)
        return blocked_headings(psi, max(cruise, 1e-3), p[still], w[still], r[still],
                                self.horizon)

    def _static_dead_end(self, psi_ref, cruise, p, w, r) -> bool:
        """No heading within ``MAX_TURN`` of ``psi_ref`` is free of the static obstacles alone.

        A robot held only by movers waits for them to pass rather than detour (a detour is
        for a standstill in front of static obstacles: pillars, walls, stopped walkers).
        """
        return bool(self._blocked_by_static(psi_ref + self._both, cruise, p, w, r).all())

    def _cruise(self, t: float, vx_ref: float) -> float:
        """The largest forward speed [m/s] asked for in the last ``cruise_memory`` s.

        This cycle's ``vx_ref`` included; ``vx_ref`` itself when ``cruise_memory`` is 0.
        """
        if self.cruise_memory <= 0.0:
            return vx_ref
        asked = self._asked
        if asked and t < asked[-1][0]:
            asked.clear()  # time went back (a new run, a reset clock)
        while asked and asked[-1][1] <= vx_ref:
            asked.pop()
        asked.append((t, vx_ref))
        while asked[0][0] < t - self.cruise_memory:
            asked.popleft()
        return asked[0][1]

    def _within_free_interval(self, yaw, psi_ref, vx_ref, wz_ref, max_yaw_rate, both):
        """From a free heading: the reference turn, kept inside the free headings around it.

        The free interval is scanned from the yaw to each side up to the first blocked
        heading; a reference heading beyond it (or on its far side) is clamped one
        ``heading_step`` inside its edge, so the robot follows the cone's edge instead of
        turning into the cone and being braked there. ``both``: whether the headings
        ``yaw + self._both`` are blocked at ``vx_ref``.
        """
        edges = []
        for offsets, blocked in ((self._left, both[:self._n]), (self._right, both[self._n:])):
            k = int(np.argmax(blocked)) if blocked.any() else len(offsets)
            k -= EDGE_STEPS  # keep off the cone's edge, where every row's h is 0
            edges.append(float(offsets[k - 1]) if k > 0 else 0.0)
        hi, lo = edges[0], edges[1]  # free offsets from the yaw: [lo, hi], lo <= 0 <= hi
        if hi >= self._left[-1] - 1e-9 and lo <= self._right[-1] + 1e-9:
            return Steer(vx_ref, wz_ref, 0, True)  # nothing blocked anywhere
        error = math.remainder(psi_ref - yaw, math.tau)
        clamped = min(max(error, lo), hi)
        if clamped == error:
            return Steer(vx_ref, wz_ref, 0, True)
        wz = max(-max_yaw_rate, min(max_yaw_rate, self.heading_gain * clamped))
        return Steer(vx_ref, wz, 1 if clamped > error else -1, True)

    def _pick_side(self, t, psi_ref, speed, p, w, r) -> tuple[int, float] | None:
        """(side, heading offset [rad]) of the nearest free heading; the kept side first."""
        best = {}
        both = ~blocked_headings(psi_ref + self._both, speed, p, w, r, self.horizon)
        for side, offsets, free in ((1, self._left, both[:self._n]),
                                    (-1, self._right, both[self._n:])):
            offset = first_free_offset(free, offsets, EDGE_STEPS, self.detour.min_run)  # off edge
            if offset is not None:
                best[side] = offset
        if not best:
            return None
        kept = self._side if t - self._side_time <= self.side_memory else 0
        side = chosen_side(best, kept)
        self._side, self._side_time = side, t
        return side, best[side]

