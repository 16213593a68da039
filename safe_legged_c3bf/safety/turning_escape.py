"""Escape shaping for a robot that cannot side-step (plain unicycle): turn, then go.

The side-stepping models escape a mover at the present heading (``escape``). A plain unicycle
cannot: its only way out of a walker's path is a turn, and it needs that turn's time. The QP
alone answers a head-on walker myopically. Measured in the harness
(``test_safety_cycle``, a walker from 6 m at 0.4 m/s, the A1's cover): it held ``h`` near 0
with a slow back-and-turn for 10 s, so the cone, distance-free, widened faster than the robot
could follow once the walker was near, and the walker reached the cover's circle (RELAXED,
then EMERGENCY).

This stage has the escape stage's trigger (the cover standing still meets a mover within
``horizon``, and so does the reference's straight path at the present heading) and a
candidate set that turns first:

* **Candidates:** a change of heading ``d`` (every ``HEADING_STEP``, both ways, up to half a
  turn) and a speed along the new heading (forward or back, ``SPEED_FRACTIONS`` of the limits,
  or none). The turn takes ``|d| / w_max + w_max / alpha_max`` (at the yaw-rate limit, plus
  reaching it); the robot stands while it turns, then goes straight.
* **First contact:** while turning, the cover at every heading it passes through, standing,
  is tested from 0 until the turn leaves that heading (conservative: a contact before the
  robot gets there counts too), and a heading where it would overlap an obstacle (a pillar
  beside the rear, swept by the turn) is a contact when the turn gets there; then the cover
  at the new heading moves at the candidate's velocity (``velocity_obstacles``, the
  obstacles advanced to the turn's end).
* **Choice:** as the escape stage: the clear candidate nearest the reference (turn time plus
  speed change over the forward limit, in s); if none is clear, the latest first contact among
  those that move no cover point towards a mover, ties to the most clearance at closest
  approach, then the nearest.

The safety cycle tracks the result at full acceleration: the yaw rate towards the new heading
(gain ``HEADING_GAIN``), the speed only once the heading is within ``ALIGNED``. The QP still
filters it (no barrier constraint is weakened). Geometry as in ``escape``: odom, m, m/s, rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.safety.escape import MOVER_SPEED, footprint_circles
from safe_legged_c3bf.safety.velocity_obstacles import (
    closest_clearances_batched,
    contact_times_batched,
)

__all__ = ["ALIGNED", "HEADING_GAIN", "TurningEscape", "TurningEscapeShaping"]

HEADING_STEP = math.radians(10.0)
"""Spacing [rad] of the candidate changes of heading."""
SPEED_FRACTIONS = (0.5, 1.0)
"""Candidate speeds along the new heading, as fractions of the forward and reverse limits."""
HEADING_GAIN = 2.0
"""Yaw rate [rad/s] per rad of heading still to turn (saturated at the yaw-rate limit)."""
ALIGNED = math.radians(10.0)
"""Heading error [rad] below which the escape's speed is commanded (before it: turn only)."""


@dataclass(frozen=True)
class TurningEscape:
    """A shaped reference: heading change [rad] (left positive), then speed [m/s] along it."""

    heading: float
    vx: float
    contact_time: float  # s; inf: clear over the horizon


class TurningEscapeShaping:
    """Turn-then-go escape of a plain unicycle's cover (see the module docstring)."""

    def __init__(self, horizon: float, cover_offsets, cover_radii) -> None:
        """Configure the stage.

        ``horizon`` [s] (0: off); the cover's x-y circles: offsets ``(c, 2)`` [m] in
        base_link and radii ``(c,)`` [m].
        """
        self.horizon = float(horizon)
        self._offsets = np.asarray(cover_offsets, dtype=float).reshape(-1, 2)
        self._radii = np.asarray(cover_radii, dtype=float).reshape(-1)
        half = int(round(math.pi / HEADING_STEP))
        steps = np.arange(-half + 1, half + 1)  # (-180, 180]
        self._headings = steps * HEADING_STEP  # (H,)
        self._steps = steps
        self._zero = half - 1  # the index of no turn

    @classmethod
    def for_body(cls, body, horizon: float) -> TurningEscapeShaping | None:  # noqa: ANN001
        """The stage over a ``c3bf.body.RobotBody``'s x-y circles (None: no body or off)."""
        if body is None or horizon <= 0.0:
            return None
        return cls(horizon, *footprint_circles(body))

    def shape(self, pos, yaw: float, ref_vx: float, vx: float, centers, velocities, radii,
              limits) -> TurningEscape | None:
        """The escape, or None (reference kept).

        None when standing still is safe, or when the straight paths at the present heading
        of both the reference and the present speed stay clear. ``pos`` (x, y) and ``yaw`` of
        the base in odom; ``ref_vx`` the reference's and ``vx`` the commanded forward speed
        [m/s]; ``centers`` ``(n, 2)``, ``velocities`` ``(n, 2)``, ``radii`` ``(n,)`` of the
        vertical obstacles; ``limits`` (forward, reverse [m/s], yaw rate [rad/s], yaw
        acceleration [rad/s^2]).
        """
        w = np.asarray(velocities, dtype=float).reshape(-1, 2)
        movers = np.hypot(w[:, 0], w[:, 1]) > MOVER_SPEED
        if self.horizon <= 0.0 or not movers.any() or len(self._radii) == 0:
            return None
        forward, reverse, yaw_rate, yaw_accel = limits
        # The trigger at the present heading first (every cycle with a mover: kept cheap).
        rel, pair_w, pair_r = self._pairs(pos, yaw, np.zeros(1), centers, w, radii)
        now = np.clip([0.0, ref_vx, vx], -reverse, forward)[:, None] * [math.cos(yaw),
                                                                       math.sin(yaw)]
        standing, *going = contact_times_batched(now[None], rel, pair_w, pair_r,
                                                 self.horizon)[0]
        if math.isinf(standing) or np.isinf(going).all():
            return None
        rel, _, _ = self._pairs(pos, yaw, self._headings, centers, w, radii)  # (H, m, 2)
        psi = yaw + self._headings
        e = np.stack([np.cos(psi), np.sin(psi)], -1)  # (H, 2)
        stand = contact_times_batched(np.zeros((len(psi), 1, 2)), rel, pair_w, pair_r,
                                      self.horizon)[:, 0]  # (H,) each heading, standing
        speeds = np.array([0.0] + [f * forward for f in SPEED_FRACTIONS]
                          + [-f * reverse for f in SPEED_FRACTIONS])  # (S,)
        turn = np.abs(self._headings) / yaw_rate + np.where(self._steps == 0, 0.0,
                                                             yaw_rate / yaw_accel)  # (H,)
        during = self._contact_while_turning(stand, turn, rel, pair_r, yaw_rate)  # (H,)
        moved = rel + pair_w[None] * turn[:, None, None]
        vel = speeds[None, :, None] * e[:, None, :]  # (H, S, 2)
        after = turn[:, None] + contact_times_batched(vel, moved, pair_w, pair_r,
                                                      self.horizon - turn)  # (H, S)
        times = np.minimum(during[:, None], after)
        times[~(times <= self.horizon)] = np.inf
        cost = turn[:, None] + np.abs(speeds[None] - ref_vx) / max(forward, 1e-6)
        return self._choose(times, cost, vel, moved, pair_w, pair_r, rel, movers, turn, speeds)

    def _pairs(self, pos, yaw, headings, centers, w, radii):  # noqa: ANN001, ANN202
        """Centre offsets ``(H, c n, 2)`` from the cover turned by each of ``headings``.

        ``headings`` ``(H,)`` [rad] changes of heading; also returns the pairs' velocities
        and radii.
        """
        psi = yaw + headings
        c, s = np.cos(psi), np.sin(psi)
        ox, oy = self._offsets[:, 0], self._offsets[:, 1]
        cover = np.stack([c[:, None] * ox - s[:, None] * oy,
                          s[:, None] * ox + c[:, None] * oy], -1)  # (H, c, 2)
        cover += np.asarray(pos, dtype=float)[:2]
        cen = np.asarray(centers, dtype=float).reshape(-1, 2)
        rel = cen[None, None] - cover[:, :, None]  # (H, c, n, 2)
        pair_w = np.broadcast_to(w[None], rel.shape[1:]).reshape(-1, 2)
        pair_r = (np.asarray(radii, dtype=float)[None] + self._radii[:, None]).reshape(-1)
        return rel.reshape(len(psi), -1, 2), pair_w, pair_r

    def _contact_while_turning(self, stand: np.ndarray, turn: np.ndarray, rel, pair_r,
                               yaw_rate: float) -> np.ndarray:
        """``(H,)`` first contact during each candidate's turn (inf: none).

        A heading passed through counts, standing, from 0 until the turn leaves it
        (``HEADING_STEP`` further on); conservative, as a contact before the robot gets
        there counts too. A heading whose cover overlaps an obstacle more than the present
        one does (a static pillar beside the rear, swept by the turn) is a contact when the
        turn gets there: standing, such a pair neither closes in nor separates.
        """
        step = HEADING_STEP / yaw_rate
        gap = np.sqrt((rel * rel).sum(-1)) - pair_r  # (H, m)
        zero = self._zero
        deeper = (gap < np.minimum(gap[zero], 0.0) - 1e-9).any(axis=1)  # (H,)
        hit = np.where(stand <= turn + step, stand, np.inf)  # touched while (or before) there
        hit = np.minimum(hit, np.where(deeper, np.maximum(turn - step, 0.0), np.inf))
        out = np.empty(len(stand))
        for order in (np.arange(zero, len(stand)), np.arange(zero, -1, -1)):
            out[order] = np.minimum.accumulate(hit[order])  # every heading passed so far
        return out

    def _choose(self, times, cost, vel, moved, pair_w, pair_r, rel, movers, turn,  # noqa: ANN001
                speeds) -> TurningEscape:
        """The clear candidate of least cost; else the latest contact (see module docstring)."""
        clear = np.isinf(times)
        if clear.any():
            h, k = np.unravel_index(np.argmin(np.where(clear, cost, np.inf)), cost.shape)
            return TurningEscape(float(self._headings[h]), float(speeds[k]), math.inf)
        n_pairs = rel.shape[1]
        mover_pairs = np.tile(movers, n_pairs // max(len(movers), 1))
        towards = np.einsum("hsd,hmd->hsm", vel, rel[:, mover_pairs]) > 1e-9
        ok = ~towards.any(axis=-1)  # (H, S); speed 0 always qualifies
        closest = closest_clearances_batched(vel, moved, pair_w, pair_r, self.horizon - turn)
        flat = np.nonzero(ok.reshape(-1))[0]
        j = flat[np.lexsort((cost.reshape(-1)[flat], -closest.reshape(-1)[flat],
                             -times.reshape(-1)[flat]))[0]]
        h, k = np.unravel_index(j, times.shape)
        return TurningEscape(float(self._headings[h]), float(speeds[k]), float(times[h, k]))

