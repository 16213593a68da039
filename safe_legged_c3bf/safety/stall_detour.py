"""Leaving a standstill in clutter: a committed detour round the blocked headings (issue #17).

The cone steering (``cone_steering``) turns a reference heading that meets an obstacle to the
nearest free heading within ``MAX_TURN`` of it; when every heading within that turn is
blocked (the robot stands in a pocket of pillars, walls or stopped walkers between it and
where the planner wants to go) it keeps the reference and the QP brakes. The planner knows
nothing of obstacles and keeps asking for the blocked heading, so the robot stood there until
its time ran out (random biped seed 4 stood 30 s between two pillars and walkers; held by
the walkers, it waits: see below).

Once the robot has stood (commanded forward speed below ``START_SPEED``) for ``STALL_TIME``
with no free heading, and no heading would be free of the static obstacles alone either (a
robot held by movers waits for them to pass: ``cone_steering.STATIC_SPEED``), this stage
starts a **detour**: it remembers the heading the planner
asked for (``goal_heading``), commits to one side (the nearest free heading on either side,
up to half a turn away; the side the steering kept last when about as near), turns in place
to that free heading and walks along it at the planner's cruise speed; a free heading behind
the robot (more than a quarter turn away) is backed along, rear first (a robot boxed in
cannot turn in place: its front would swing towards the walls beside it, which the barrier
refuses). Every cycle the heading
is the free one nearest ``goal_heading`` on the committed side (``EDGE_STEPS`` off the
blocked sector's edge), so the robot follows the edge of the blocked headings round the
obstacles, as a bug algorithm follows a boundary, while the planner, turned away from its
goal, asks to turn back in place. The detour ends when ``goal_heading`` itself is free from
where the robot is, when the planner stops (zero speed and yaw rate), or after
``DETOUR_MAX``. The QP filters every shaped reference: no barrier constraint is weakened.

A detour also starts out of a **standoff** (``cone_steering.ConeSteering._standoff``): the
robot has stood for ``STANDOFF_TIME`` while the planner asked to move and its yaw turned to
and fro, the steering towards a free heading and the planner back towards its blocked one,
with the planner's heading blocked by the static obstacles alone (random biped seeds 4 and 6
turned to and fro for 25 s). Units: s, rad, m/s; headings in odom (REP-103).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = [
    "DETOUR_MAX", "STALL_TIME", "STANDOFF_TIME", "SWITCH_MARGIN", "TURN_FIRST", "StallDetour",
    "chosen_side", "first_free_offset",
]

STALL_TIME = 2.0
"""Time [s] stood still with no free heading before a detour starts."""
STANDOFF_TIME = 6.0
"""Time [s] stood still while the planner asks to move and the yaw turns to and fro, before a
detour out of that standoff starts (``cone_steering.ConeSteering._standoff``). Longer than a
turn in place towards a free heading takes: 100 deg at the biped's 0.4 rad/s in 4.4 s."""
DETOUR_MAX = 15.0
"""Longest detour [s]; a robot still blocked after it stalls again and starts a new one."""
TURN_FIRST = math.radians(10.0)
"""Heading error [rad] above which a detour from (near) rest turns in place before walking."""
SWITCH_MARGIN = math.radians(45.0)
"""The kept side is left only for a side whose free heading is this much nearer [rad]."""

def first_free_offset(free: np.ndarray, offsets: np.ndarray, edge_steps: int,
                      min_run: int = 1) -> float | None:
    """The offset [rad] ``edge_steps`` into the first run of free headings; None if none.

    Off the blocked sector's edge, where every row's h is 0. A run too short to hold that
    offset (a narrow window between two cones) is aimed at its middle heading instead: the
    offset ``edge_steps`` past its start would be blocked again (in random A1 seed 22 it was
    the robot's own yaw, so the turn in place asked for nothing and the A1 stood still before
    a bar; ``test/test_cone_steering.py``). A run of fewer than ``min_run`` headings is passed
    over, unless it reaches the last offset (then its true width is unknown).
    """
    n = len(free)
    start = int(np.argmax(free)) if n else 0
    while start < n and free[start]:  # argmax / argmin: this runs twice per filter cycle
        rest = free[start:]
        k = int(np.argmin(rest))
        length = len(rest) if rest[k] else k
        if length >= min_run or start + length == n:
            return float(offsets[start + (edge_steps if length > edge_steps
                                          else (length - 1) // 2)])
        after = free[start + length:]
        start += length + int(np.argmax(after))
    return None


def chosen_side(best: dict[int, float], kept: int) -> int:
    """The side (+1 / -1) of the nearest free heading (``best``: side -> offset [rad]).

    The ``kept`` side while it is within ``SWITCH_MARGIN`` of that, so noise cannot dither.
    """
    side = min(best, key=lambda s: abs(best[s]))
    if kept in best and abs(best[kept]) <= abs(best[side]) + SWITCH_MARGIN:
        return kept
    return side


Blocked = Callable[[np.ndarray], np.ndarray]
"""``blocked(headings)``: ``(k,)`` bool, heading (odom, rad) meets an obstacle at cruise speed."""


@dataclass
class _Detour:
    goal_heading: float  # rad, odom: the heading the planner asked for when the robot stalled
    side: int  # +1 round the blocked headings to the left (counter-clockwise), -1 right
    since: float  # s


class StallDetour:
    """The detour stage of the cone steering (see the module docstring)."""

    def __init__(self, heading_step: float, heading_gain: float, start_speed: float,
                 edge_steps: int, min_run: int = 1) -> None:
        """Configure the stage (units in the arguments' descriptions).

        ``heading_step`` [rad] of the search, ``heading_gain`` [1/s] (yaw rate per rad),
        ``start_speed`` [m/s] below which the robot counts as standing, ``edge_steps``
        (heading steps kept off a blocked sector's edge), ``min_run`` (fewest free headings
        of a run turned to: ``first_free_offset``).
        """
        n = int(math.ceil(math.pi / heading_step))
        self._offsets = heading_step * np.arange(1, n + 1)  # up to half a turn
        self.heading_gain, self.start_speed = heading_gain, start_speed
        self.edge_steps, self.min_run = edge_steps, min_run
        self._stood_since: float | None = None
        self._detour: _Detour | None = None

    @property
    def active(self) -> bool:
        """A detour is under way."""
        return self._detour is not None

    def cancel(self) -> None:
        """End a detour under way (nothing is left to detour round)."""
        self._detour = None

    def reset_stall(self) -> None:
        """A free heading was found (or nothing is asked): the standstill clock restarts."""
        self._stood_since = None

    def stalled(self, t: float, speed: float) -> bool:
        """Note that no heading is free at ``t`` [s]; whether the robot has stood long enough.

        ``speed``: the commanded forward speed [m/s].
        """
        if speed >= self.start_speed:
            self._stood_since = None
            return False
        if self._stood_since is None:
            self._stood_since = t
        return t - self._stood_since >= STALL_TIME

    def start(self, t: float, goal_heading: float, kept_side: int, blocked: Blocked) -> bool:
        """Begin a detour from ``goal_heading`` [rad]; False when no heading at all is free."""
        best = {}
        for side in (1, -1):
            offset = self._free_offset(goal_heading, side, blocked)
            if offset is not None:
                best[side] = offset
        if not best:
            return False
        self._detour = _Detour(goal_heading, chosen_side(best, kept_side), t)
        self._stood_since = None
        return True

    def step(self, t: float, yaw: float, speed: float, cruise: float, vx_ref: float,
             wz_ref: float, max_yaw_rate: float,
             blocked: Blocked) -> tuple[float, float, int] | None:
        """``(vx [m/s], yaw rate [rad/s], side)`` of the detour at ``t``; None once it ends.

        ``speed``: commanded forward speed [m/s]; ``cruise``: the planner's cruise speed [m/s].
        """
        d = self._detour
        if d is None:
            return None
        stopped = vx_ref <= 1e-3 and abs(wz_ref) <= 1e-3
        expired = not 0.0 <= t - d.since <= DETOUR_MAX
        if stopped or expired or not blocked(np.array([d.goal_heading]))[0]:
            self._detour = None
            return None
        offset = self._free_offset(d.goal_heading, d.side, blocked)
        if offset is None:
            self._detour = None
            return None
        error = math.remainder(d.goal_heading + d.side * offset - yaw, math.tau)
        sign = 1.0
        if abs(error) > math.pi / 2:  # behind: back out along it, the rear first
            error, sign = math.remainder(error - math.pi, math.tau), -1.0
        wz = max(-max_yaw_rate, min(max_yaw_rate, self.heading_gain * error))
        if sign > 0 and abs(error) > TURN_FIRST and speed < self.start_speed:
            return 0.0, wz, d.side
        return sign * cruise * max(math.cos(error), 0.0), wz, d.side

    def _free_offset(self, goal_heading: float, side: int, blocked: Blocked) -> float | None:
        """Offset [rad, >= 0] of the first free heading on ``side``, off the edge; None."""
        free = ~blocked(goal_heading + side * self._offsets)
        return first_free_offset(free, self._offsets, self.edge_steps, self.min_run)
