"""The whole-body filter's reference shaping, in front of the QP, in the order it applies.

1. **Cone steering** (``cone_steering``; unicycle models): a reference heading into an
   obstacle's collision cone is turned to the nearest free heading. Walled bars are left out:
   a way round a bar across the path is the planner's to find.
2. **Hold before a walled bar** (``bar_walls``): while the reference's straight path would
   bring the cover into a bar the body cannot duck under, its planar velocity is zero.
3. **Escape from movers**: when standing still is not safe, the nearest velocity whose
   straight path stays clear: at the present heading for the side-stepping models
   (``escape``), after a turn for the plain unicycle (``turning_escape``).

Each stage changes the reference ``(vx, vy, vz, wz)`` (base_link, m/s, rad/s) in place and
says what it did; the QP still filters the result, so no barrier constraint is weakened and
the planner stays obstacle-agnostic. The single-point filter (the paper's) has no shaping.
Units: m, s, rad; frames: odom for positions, base_link for the reference (REP-103/105).
"""

from __future__ import annotations

import math

import numpy as np

from safe_legged_c3bf.c3bf.body import RobotBody
from safe_legged_c3bf.safety.bar_walls import BarWalls
from safe_legged_c3bf.safety.cone_steering import ConeSteering, cover_half_width
from safe_legged_c3bf.safety.escape import EscapeShaping
from safe_legged_c3bf.safety.params import LATERAL_MODELS, TURNING_MODELS, FilterParams
from safe_legged_c3bf.safety.turning_escape import ALIGNED, HEADING_GAIN, TurningEscapeShaping

__all__ = ["ReferenceShaping"]


class ReferenceShaping:
    """The three stages for one parameter set (see the module docstring)."""

    def __init__(self, params: FilterParams, body: RobotBody | None, qp_margin: float) -> None:
        """Configure the stages.

        ``params``: validated filter parameters; ``body``: the cover (None: the single
        point, no shaping); ``qp_margin``: the QP's own constraint margin [m].
        """
        self.params, self.body = params, body
        self.steering = ConeSteering(
            params.steer_horizon, cover_half_width(body), params.steer_lookahead,
            params.steer_gain, cruise_memory=params.steer_cruise_memory,
            min_run=params.steer_min_free_run, settle_yaw_rate=params.steer_settle_yaw_rate,
        )
        self.escape = EscapeShaping.for_body(body, params.escape_horizon)
        self.turning_escape = TurningEscapeShaping.for_body(body, params.escape_horizon)
        self.walls = BarWalls.for_body(body, params.min_height, qp_margin,
                                       params.bar_wall_range)

    @property
    def steers(self) -> bool:
        """True when the cone steering runs (whole body, unicycle models, a horizon)."""
        p = self.params
        return self.body is not None and p.model in TURNING_MODELS and p.steer_horizon > 0.0

    def shape(self, t: float, ref_arr: np.ndarray, circles, ids, walled: np.ndarray,  # noqa: ANN001
              pos: np.ndarray, yaw: float, vx_command: float,
              yaw_rate_command: float = 0.0) -> tuple[str, bool]:
        """Shape ``ref_arr`` in place; returns (what was done, escaping).

        Args:
            t: sim time [s].
            ref_arr: the reference ``(vx, vy, vz, wz)`` [m/s, rad/s], changed in place.
            circles: this cycle's c3bf ``Obstacles``.
            ids: their obstacle ids.
            walled: mask of the circles of walled bars (``bar_walls``).
            pos: base position in odom [m].
            yaw: base yaw [rad].
            vx_command: the commanded forward speed [m/s] (the steering turns in place first
                below ``cone_steering.START_SPEED``).
            yaw_rate_command: the commanded yaw rate [rad/s] (from rest, the steering lets
                a turn settle before the robot walks).

        """
        if self.body is None:
            return "", False
        vertical = np.asarray(circles.plane) == 0
        if not vertical.any():
            return "", False
        text = self._steer(t, ref_arr, circles, vertical & ~walled, pos, yaw, vx_command,
                           yaw_rate_command)
        if walled.any():
            text += self._hold_before_walls(ref_arr, circles, walled, ids, pos, yaw)
        escape = self._escaped(ref_arr, circles, vertical, pos, yaw, vx_command)
        return text + escape, bool(escape)

    def _steer(self, t, ref_arr, circles, mask, pos, yaw, vx_command,  # noqa: ANN001
               yaw_rate_command) -> str:
        """Cone steering over the circles in ``mask`` (unicycle models); what it did."""
        p = self.params
        if not self.steers or not mask.any():
            return ""
        out = self.steering.steer(
            t, pos, yaw, float(ref_arr[0]), float(ref_arr[3]), circles.center[mask],
            circles.velocity[mask], circles.radius[mask], p.max_yaw_rate, vx_command,
            yaw_rate_command,
        )
        if out.side == 0:
            return "" if out.free else " (no free heading: following)"
        ref_arr[0], ref_arr[3] = out.vx, out.yaw_rate
        side = "left" if out.side > 0 else "right"
        if out.detour:
            return f" (detour {side} round the blocked headings: out of a standstill)"
        return f" (steering {side} out of a collision cone)"

    def _hold_before_walls(self, ref_arr, circles, walled, ids, pos, yaw) -> str:  # noqa: ANN001
        """Zero the planar velocity while the reference's path meets a walled bar."""
        if not self.walls.blocks(pos, yaw, ref_arr[:2], circles.center[walled],
                                 circles.velocity[walled], circles.radius[walled]):
            return ""
        ref_arr[:2] = 0.0
        names = sorted({i for i, w in zip(ids, walled.tolist(), strict=True) if w})
        return f" (holding before {', '.join(map(repr, names))}: too low to duck under)"

    def _escaped(self, ref_arr, circles, vertical, pos, yaw, vx_command) -> str:  # noqa: ANN001
        """Escape from movers; what it did ("": none)."""
        p = self.params
        if p.model not in LATERAL_MODELS:
            return self._turned_escape(ref_arr, circles, vertical, pos, yaw, vx_command)
        if self.escape is None:
            return ""
        out = self.escape.shape(
            pos, yaw, ref_arr[:2], circles.center[vertical], circles.velocity[vertical],
            circles.radius[vertical], (p.max_speed, p.max_reverse_speed, p.max_lateral_speed),
        )
        if out is None:
            return ""
        ref_arr[0], ref_arr[1], ref_arr[3] = out.vx, out.vy, 0.0
        return (f" (escaping a mover: {out.vx:+.2f}, {out.vy:+.2f} m/s; contact ahead "
                f"{_ahead(out.contact_time)})")

    def _turned_escape(self, ref_arr, circles, vertical, pos, yaw, vx_command) -> str:  # noqa: ANN001
        """The plain unicycle's escape: turn towards the new heading, then go."""
        p = self.params
        if self.turning_escape is None:
            return ""
        out = self.turning_escape.shape(
            pos, yaw, float(ref_arr[0]), vx_command, circles.center[vertical],
            circles.velocity[vertical], circles.radius[vertical],
            (p.max_speed, p.max_reverse_speed, p.max_yaw_rate, p.max_yaw_accel),
        )
        if out is None:
            return ""
        turn = min(max(HEADING_GAIN * out.heading, -p.max_yaw_rate), p.max_yaw_rate)
        ref_arr[0] = out.vx if abs(out.heading) <= ALIGNED else 0.0
        ref_arr[1], ref_arr[3] = 0.0, turn
        return (f" (escaping a mover: turn {math.degrees(out.heading):+.0f} deg, then "
                f"{out.vx:+.2f} m/s; contact ahead {_ahead(out.contact_time)})")


def _ahead(contact_time: float) -> str:
    """An escape's first contact [s] for its message ("none": clear over the horizon)."""
    return "none" if math.isinf(contact_time) else f"{contact_time:.1f} s"
