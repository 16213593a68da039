r"""Lie derivatives of the collision-cone barrier along a robot model.

For obstacle ``i`` in plane ``k`` (coordinates ``(0, 1)`` = x-y or ``(0, 2)`` = x-z of the
3-D body point), centre ``c``, constant velocity ``c_dot`` and inflated radius ``r``::

    p_rel = c - P_k(x)          v_rel = c_dot - V_k(x)
    h(x)  = h_cone(p_rel, v_rel)           (see ``barrier``)

With the obstacle moving at constant velocity, ``d p_rel/dt = v_rel`` exactly (because
``V = dP/dx f`` and ``dP/dx g = 0``) and ``d v_rel/dt = -(a_drift_k + B_k u)``. The chain
rule over the *full* state (and the obstacle's motion) gives::

    Lf h = <dh/dp, v_rel> - <dh/dv, a_drift_k>
    Lg h = -(dh/dv)^T B_k                                  (a row of length m)

so ``dh/dt = Lf h + Lg h u``. Here ``Lf h`` includes the explicit time dependence through the
moving obstacle (``dh/dt = dh/dx f + dh/dc c_dot``), i.e. it is the derivative along the
augmented drift ``(f(x), c_dot)``; the tests check this against central finite differences.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .barrier import DEFAULT_V_EPS, _gradient, c3bf_gradient_scalar
from .domain import MAX_DERIVED, checked, checked_scalar
from .errors import InvalidInputError
from .models import PointKinematics, RobotModel

__all__ = [
    "PLANE_AXES",
    "BarrierTerms",
    "plane_take",
    "reference_directions",
    "barrier_terms",
    "barrier_terms_scalar",
    "row_barrier_terms",
    "c3bf_lie_derivatives",
]

PLANE_AXES = np.array([[0, 1], [0, 2]], dtype=np.intp)
"""Row ``k``: indices of the body-point coordinates used by obstacles in ``Plane(k)``."""


class BarrierTerms(NamedTuple):
    """Barrier value, Lie derivatives and geometry for ``n`` obstacles (batch dims allowed)."""

    h: np.ndarray
    """``(..., n)`` barrier values [m^2/s]."""
    lf_h: np.ndarray
    """``(..., n)`` ``Lf h`` [m^2/s^2]."""
    lg_h: np.ndarray
    """``(..., n, m)`` ``Lg h`` (units [m^2/s^2] per input unit)."""
    p_rel: np.ndarray
    """``(..., n, 2)`` relative position (obstacle minus body point) [m]."""
    v_rel: np.ndarray
    """``(..., n, 2)`` relative velocity [m/s]."""
    clearance: np.ndarray
    """``(..., n)`` ``||p_rel||^2 - r^2`` [m^2]; ``<= 0`` means inside the inflated circle."""


def barrier_terms(
    kin: PointKinematics, center, velocity, radius, plane, v_eps: float = DEFAULT_V_EPS
) -> BarrierTerms:
    """Evaluate :class:`BarrierTerms` from precomputed body-point kinematics.

    Args:
        kin: Output of :meth:`RobotModel.point_kinematics` (batch shape ``S``).
        center: ``(..., n, 2)`` in-plane obstacle centres [m] (broadcast against ``S``).
        velocity: ``(..., n, 2)`` in-plane obstacle velocities [m/s].
        radius: ``(..., n)`` inflated radii [m].
        plane: ``(..., n)`` integer :class:`~.geometry.Plane` values.
        v_eps: Relative-speed regularisation [m/s].

    Raises:
        InvalidInputError: a number not finite or beyond ``domain.MAX_DERIVED``, a radius
            not > 0, a plane not 0 or 1.

    """
    kin = PointKinematics(*(checked(f"kin.{k}", a, MAX_DERIVED) for k, a in kin._asdict().items()))
    center = checked("center", center, MAX_DERIVED)
    velocity = checked("velocity", velocity, MAX_DERIVED)
    radius = checked("radius", radius, MAX_DERIVED, positive=True)
    pl = np.asarray(plane)
    if not np.isin(pl, (0, 1)).all():
        raise InvalidInputError(f"plane entries must be 0 (VERTICAL) or 1 (HORIZONTAL): {pl}")
    return _barrier_terms(kin, center, velocity, radius, pl, checked_scalar("v_eps", v_eps, 0.0))


def _barrier_terms(kin, center, velocity, radius, plane, v_eps) -> BarrierTerms:
    """Unchecked :func:`barrier_terms` (the filter's vectorised path)."""
    axes = PLANE_AXES[np.asarray(plane, dtype=np.intp)]  # (..., n, 2)
    pos = np.asarray(kin.position, dtype=float)
    if pos.ndim == 1:  # single state: plain fancy indexing (fast path)
        P = pos[axes]
        V = np.asarray(kin.velocity, dtype=float)[axes]
        A = np.asarray(kin.accel_drift, dtype=float)[axes]
        B = np.asarray(kin.accel_input, dtype=float)[axes]  # (n, 2, m)
    else:
        P = np.take_along_axis(pos[..., None, :], axes, -1)
        V = np.take_along_axis(kin.velocity[..., None, :], axes, -1)
        A = np.take_along_axis(kin.accel_drift[..., None, :], axes, -1)
        B = np.take_along_axis(kin.accel_input[..., None, :, :], axes[..., None], -2)
    return _terms_in_plane(P, V, A, B, center, velocity, radius, v_eps)


def _terms_in_plane(P, V, A, B, center, velocity, radius, v_eps, direction=None) -> BarrierTerms:
    """:class:`BarrierTerms` from in-plane body-point kinematics (module docstring).

    ``direction``: the low-speed directions of :func:`row_barrier_terms` (None: the smooth
    regularisation everywhere).
    """
    r = np.asarray(radius, dtype=float)
    p = np.asarray(center, dtype=float) - P
    v = np.asarray(velocity, dtype=float) - V
    h, dh_dp, dh_dv, s = _gradient(p, v, r, v_eps)
    if direction is not None:
        use = (((v * v).sum(-1) < v_eps * v_eps) & (s > 0.0)
               & ((direction * direction).sum(-1) > 0.0))
        if use.any():
            lin = (direction * v).sum(-1)
            su = s[use]
            h = np.where(use, (p * v).sum(-1) + s * lin, h)
            dh_dp[use] = v[use] + (lin[use] / su)[:, None] * p[use]
            dh_dv[use] = p[use] + su[:, None] * direction[use]
    lf = (dh_dp * v).sum(-1) - (dh_dv * A).sum(-1)
    lg = -(dh_dv[..., :, None] * B).sum(-2)
    return BarrierTerms(h, lf, lg, p, v, (p * p).sum(-1) - r * r)


def plane_take(arr, axes: np.ndarray, rowwise: bool) -> np.ndarray:
    """In-plane components of kinematics ``arr`` for rows with plane axes ``axes`` ``(n, 2)``.

    ``rowwise`` False: ``arr`` is one point's ``(3,)`` or ``(3, m)``, the same for every row;
    True: ``(n, 3)`` or ``(n, 3, m)``, row ``i`` its own point. Returns ``(n, 2)`` or
    ``(n, 2, m)``.
    """
    arr = np.asarray(arr, dtype=float)
    if not rowwise:
        return arr[axes]
    if arr.ndim == 3:
        return np.take_along_axis(arr, axes[:, :, None], -2)
    return np.take_along_axis(arr, axes, -1)


def row_barrier_terms(kin: PointKinematics, center, velocity, radius, plane, v_eps,
                      direction=None):
    """Unchecked barrier terms with row-wise kinematics (row ``i``: its own body point).

    ``kin`` arrays ``(n, 3)`` and ``(n, 3, m)``; ``center``, ``velocity`` ``(n, 2)``; ``radius``,
    ``plane`` ``(n,)``. The formulas of :func:`barrier_terms` (module docstring), row by row.

    ``direction``: ``(n, 2)`` unit (or zero) vectors ``e``. Below ``v_eps`` (``||v|| <
    v_eps``) a row with ``e != 0`` uses ``h = <p + s e, v>`` instead of the smooth blend:
    ``<e, v> <= ||v||``, so it stays below the paper's ``h`` (never less safe), and ``h`` only
    jumps up where ``||v||`` reaches ``v_eps``. With ``e`` the direction in which the
    reference moves the relative velocity, a robot at (or near) rest may start along any
    direction outside the cone; the blend, flat at ``v = 0``, would forbid every direction
    with a component towards the obstacle's centre, and the exact barrier every direction
    on the far side of ``v`` (its linearisation at a tiny ``v`` is a half-plane through 0).
    ``e`` is held constant: ``dh/dp = v + <e, v> p / s``, ``dh/dv = p + s e`` there.
    """
    axes = PLANE_AXES[np.asarray(plane, dtype=np.intp)]
    P = np.take_along_axis(kin.position, axes, -1)
    V = np.take_along_axis(kin.velocity, axes, -1)
    A = np.take_along_axis(kin.accel_drift, axes, -1)
    B = np.take_along_axis(kin.accel_input, axes[:, :, None], -2)  # (n, 2, m)
    return _terms_in_plane(P, V, A, B, center, velocity, radius, v_eps, direction)


def reference_directions(kin: PointKinematics, center, velocity, plane, u_ref,
                         horizon: float) -> np.ndarray:
    """``(n, 2)`` unit direction of each row's relative velocity ``horizon`` s ahead.

    Under ``u_ref``: ``c_dot - (V + (a_drift + B u_ref) horizon)``, zero where it vanishes.
    """
    axes = PLANE_AXES[np.asarray(plane, dtype=np.intp)]
    V = np.take_along_axis(kin.velocity, axes, -1)
    acc = kin.accel_drift + kin.accel_input @ np.asarray(u_ref, dtype=float)
    d = np.asarray(velocity, dtype=float) - V - horizon * np.take_along_axis(acc, axes, -1)
    norm = np.sqrt((d * d).sum(-1))
    return d / np.where(norm > 1e-12, norm, np.inf)[:, None]


def c3bf_lie_derivatives(
    model: RobotModel,
    state,
    center,
    velocity,
    radius,
    plane,
    *,
    yaw=None,
    v_eps: float = DEFAULT_V_EPS,
) -> BarrierTerms:
    """Barrier ``h``, ``Lf h`` and ``Lg h`` of ``model`` at ``state`` for each obstacle.

    Args:
        model: A :class:`~.models.RobotModel`.
        state: ``(..., n_x)`` state(s) in the model's layout (SI, odom frame).
        center: ``(..., n, 2)`` in-plane obstacle centres [m].
        velocity: ``(..., n, 2)`` in-plane obstacle velocities [m/s] (constant).
        radius: ``(..., n)`` inflated radii [m].
        plane: ``(..., n)`` :class:`~.geometry.Plane` values (must be in ``model.planes``).
        yaw: Yaw [rad] for models with ``needs_yaw`` (holonomic), else ignored.
        v_eps: Relative-speed regularisation [m/s].

    """
    kin = model.point_kinematics(state, yaw)
    return barrier_terms(kin, center, velocity, radius, plane, v_eps)


def barrier_terms_scalar(kin: PointKinematics, cx, cy, cvx, cvy, r, plane, v_eps=DEFAULT_V_EPS):
    """Scalar fast path of :func:`barrier_terms` for ONE obstacle and tuple kinematics.

    Args:
        kin: Output of :meth:`RobotModel.point_kinematics_tuple`.
        cx: Obstacle centre, first in-plane coordinate (odom x) [m].
        cy: Second in-plane coordinate (odom y for VERTICAL, odom z for HORIZONTAL) [m].
        cvx: Obstacle velocity along the first coordinate [m/s].
        cvy: Obstacle velocity along the second coordinate [m/s].
        r: Inflated radius [m].
        plane: Plane value (0 or 1).
        v_eps: Relative-speed regularisation [m/s].

    Returns:
        ``(h, lf_h, lg_h, clearance)`` with ``lg_h`` a list of floats.

    """
    j = 1 if plane == 0 else 2
    P, V, A, B = kin
    px, py = cx - P[0], cy - P[j]
    vx, vy = cvx - V[0], cvy - V[j]
    h, dpx, dpy, dvx, dvy, _ = c3bf_gradient_scalar(px, py, vx, vy, r, v_eps)
    lf = dpx * vx + dpy * vy - (dvx * A[0] + dvy * A[j])
    b0, b1 = B[0], B[j]
    lg = [-(dvx * b0[k] + dvy * b1[k]) for k in range(len(b0))]
    return h, lf, lg, px * px + py * py - r * r
