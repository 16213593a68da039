"""Result type of the safety filter."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

__all__ = ["FilterResult", "FilterStatus"]

_NO_POINT = np.zeros(0, dtype=np.intp)  # FilterResult.point of the single-point filter
_NO_POINT.setflags(write=False)  # (empty and read-only: one array serves every result)


class FilterStatus(StrEnum):
    """What the filter did with the reference input."""

    INACTIVE = "inactive"
    """The reference satisfies every constraint and the input limits: passed unchanged."""
    ACTIVE = "active"
    """The output is the exact QP optimum; it differs from the reference because a barrier
    constraint and/or an input bound is binding (see ``active`` / ``bounds_active``)."""
    RELAXED = "relaxed"
    """The barrier constraints and input limits cannot all hold: the output minimises the
    weighted input change plus a heavy penalty on constraint violations (``slack > 0``).
    (Also used, with a ``message`` saying so, in the rare case that OSQP could not solve the
    exact QP to tolerance.)"""
    EMERGENCY = "emergency"
    """The body point is inside an inflated circle (``||p_rel||^2 - r^2 < 1e-9 r^2``: the
    barrier is undefined there). Leaving every such circle (radial speed ``> 0``): the usual
    QP with, for those circles, the no-deeper constraint on the radial speed in place of the
    cone constraint (an outward motion is not braked; ``message`` says "... and leaving").
    Otherwise: brake and accelerate away from their centres ("... not leaving"). See
    ``inside``."""
    FAILSAFE = "failsafe"
    """The solver failed or the numbers overflowed: brake input (clipped to the limits)."""


@dataclass(slots=True)
class FilterResult:
    """Output of :meth:`SafetyFilter.filter`.

    Per-constraint arrays have one entry per obstacle, in the order of the
    :class:`~.geometry.Obstacles` passed in. All arrays are finite.

    Attributes:
        u_safe: ``(m,)`` filtered input, always finite and within ``[u_min, u_max]``.
        status: :class:`FilterStatus`.
        h: ``(n,)`` barrier values ``h`` [m^2/s] at the current state; ``h >= 0`` means
            safe. For obstacles the robot is inside the cone barrier is undefined and ``h``
            is reported as ``min(<p_rel, v_rel>, gamma (||p_rel||^2 - r^2 - 1e-9 r^2))``,
            always ``< 0`` (``inside.signed_h``).
        constraint: ``(n,)`` ``Lf h + Lg h u_safe + gamma h`` [m^2/s^2]; ``>= 0`` means
            satisfied. For obstacles the robot is inside: the no-deeper constraint
            ``Lf b + Lg b u_safe + gamma (b - exit_speed)`` [m/s^2] of the radial speed ``b``.
        slack: ``(n,)`` constraint violation ``max(0, -constraint)`` (0 unless RELAXED,
            EMERGENCY or FAILSAFE).
        active: ``(n,)`` bool, constraints binding at ``u_safe`` (for EMERGENCY: the
            obstacles the robot is inside).
        bounds_active: ``(m,)`` bool, inputs at ``u_min`` or ``u_max`` after filtering.
        solver: ``'closed_form'``, ``'active_set'``, ``'osqp'``, ``'clip'`` (a reference
            beyond ``domain.REF_RATIO_MAX`` whose clip is the exact optimum) or ``'none'``.
        solve_time: Wall-clock time of the whole ``filter`` call [s].
        message: Human-readable detail (empty when nothing noteworthy happened).
        clearance: ``(n,)`` signed distance [m] from the body point to each (true, i.e.
            without ``margin``) inflated circle, in the obstacle's plane: ``||p_rel|| - r``,
            negative inside. (Not ``BarrierTerms.clearance``, which is ``||p_rel||^2 - r^2``
            [m^2].) Zeros for a FAILSAFE raised before the barrier terms were computed.
            With a whole-body filter (``SafetyFilter(body=...)``) every per-obstacle entry is
            the worst over the obstacle's (body point, obstacle) rows (``body_rows``).
        point: ``(n,)`` whole-body filter only: the index in ``RobotBody.points`` of the body
            point nearest each obstacle (-1 unknown); empty for the single-point filter.

    """

    u_safe: np.ndarray
    status: FilterStatus
    h: np.ndarray
    constraint: np.ndarray
    slack: np.ndarray
    active: np.ndarray
    bounds_active: np.ndarray
    solver: str
    solve_time: float
    message: str = ""
    clearance: np.ndarray = field(default_factory=lambda: np.zeros(0))
    point: np.ndarray = field(default_factory=lambda: _NO_POINT)

    @property
    def modified(self) -> bool:
        """True if ``u_safe`` differs from the reference (any status but INACTIVE)."""
        return self.status is not FilterStatus.INACTIVE
