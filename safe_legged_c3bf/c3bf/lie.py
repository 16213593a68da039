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

from .barrier import DEFAULT_V_EPS
from .domain import MAX_DERIVED, checked, checked_scalar
from .errors import InvalidInputError
from .models import PointKinematics, RobotModel

__all__ = [
    "PLANE_AXES",
    "S_MIN",
    "BarrierTerms",
    "ConeRows",
    "barrier_terms",
    "c3bf_lie_derivatives",
    "cone_rows",
    "plane_take",
    "products",
    "reference_directions",
    "row_barrier_terms",
    "row_rows",
]

PLANE_AXES = np.array([[0, 1], [0, 2]], dtype=np.intp)
"""Row ``k``: indices of the body-point coordinates used by obstacles in ``Plane(k)``."""

S_MIN = 1e-12
"""Lower clamp [m] of ``s = sqrt(||p||^2 - r^2)`` in the ``p / s`` term (``barrier``)."""


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


class ConeRows(NamedTuple):
    """What :func:`cone_rows` returns (rows of shape ``S``, quantity axis first)."""

    h: np.ndarray
    """``S`` barrier values [m^2/s]."""
    rows: np.ndarray
    """``(1 + m,) + S``: ``Lf h``, then ``Lg h`` for each input (``rows[1:]`` is ``Lg h^T``)."""
    clearance: np.ndarray
    """``S`` ``||p_rel||^2 - r^2`` [m^2]."""


def cone_rows(sq, pw, vw, off, v_eps: float, gate=None, direction=None):
    r"""``h``, ``Lf h`` and ``Lg h`` from the products of ``p_rel``, ``v_rel`` (the one formula).

    Every path to the barrier terms (:func:`barrier_terms`, :func:`row_barrier_terms`, the
    filter's rows in ``rows``) computes a few inner products and calls this. With the
    in-plane relative acceleration ``d v_rel/dt = a_rel + b_rel u`` (``a_rel = -a_drift``,
    ``b_rel = -B``: the obstacle does not accelerate), the module docstring's formulas read
    (``n = n_eps(||v||)``, ``dn/dv = k v``, ``q = n / max(s, S_MIN)``, ``ratio = s k``)::

        h    = <p, v> + n s
        Lf h = <dh/dp, v> + <dh/dv, a_rel> = ||v||^2 + q <p, v> + <p, a_rel> + ratio <v, a_rel>
        Lg h = <dh/dv, b_rel>              = <p, b_rel> + ratio <v, b_rel>

    Above the clamp and the blend (``n = ||v||``, ``k = 1 / ||v||``: ``q ratio = 1``) the
    first two collapse to ``h = <p, v> + ratio ||v||^2`` and ``Lf h = q h + <dh/dv, a_rel>``,
    so one broadcast operation gives ``h``, ``<dh/dv, a_rel>`` and ``Lg h`` together (the
    gated branch).

    Args:
        sq: ``(2,) + S`` ``[||p||^2, ||v||^2]``.
        pw: ``(2 + m,) + S`` ``<p, v>``, ``<p, a_rel>``, then ``<p, b_rel[:, j]>``.
        vw: ``(2 + m,) + S`` the same with ``v`` (``vw[0] = ||v||^2``).
        off: ``[r^2, 0]`` (broadcast against ``sq``), ``r`` the radius of each row [m].
        v_eps: Relative-speed regularisation [m/s] (``barrier``).
        gate: None, or ``[clearance_min, ||v||^2_min]`` (broadcast against ``sq``) with
            ``clearance_min >= S_MIN^2`` and ``||v||^2_min`` at least ``v_eps^2`` (``v_eps >
            0``) or the smallest positive float (``v_eps = 0``): where every row is above both
            the clamp and the blend do not apply (the gated branch); any row below either
            returns None.
        direction: None, or ``(<e, v>, <e, [a_rel | b_rel]>, ||e||^2)`` of the low-speed
            directions ``e`` (:func:`row_barrier_terms`).

    Returns:
        :class:`ConeRows` (new arrays), or None (``gate`` not met).

    """
    X = sq - off  # [clearance, ||v||^2]
    if gate is not None:
        if np.count_nonzero(np.less(X, gate)):  # (cheaper than .any() on small arrays)
            return None
        sr = np.sqrt(X)  # [s, rho]: s >= S_MIN and rho > 0
        rq = sr / sr[::-1]  # [s / rho (= s k = ratio), rho / s (= q)]
        Z = vw * rq[0]
        Z += pw  # [h, <dh/dv, a_rel>, Lg h]
        Z[1] += rq[1] * Z[0]
        return ConeRows(Z[0], Z[1:], X[0])
    s, ratio, q, ns = _blend(X, v_eps)
    rows = vw[1:] * ratio
    if direction is not None:
        q, ns = _low_speed_directions(X[1], s, v_eps, q, ns, rows, direction)
    rows += pw[1:]  # <dh/dv, [a_rel | b_rel]>
    lf = q * pw[0]
    lf += X[1]
    rows[0] += lf  # + <dh/dp, v>
    return ConeRows(pw[0] + ns, rows, X[0])


def _blend(X, v_eps: float):
    """``(s, ratio, q, n s)`` of every row (clamp of ``s`` and low-speed blend included)."""
    cl, vv = X
    s = np.sqrt(np.maximum(cl, 0.0))
    rho = np.sqrt(vv)
    if v_eps > 0.0:
        u = np.minimum(vv / (v_eps * v_eps), 1.0)  # t^2 (capped: the blend is unused above)
        small = u < 1.0
        n = np.where(small, v_eps * u * (1.875 + u * (-1.25 + 0.375 * u)), rho)
        k_small = (3.75 + u * (-5.0 + 2.25 * u)) / v_eps
        ratio = np.where(small, s * k_small, s / np.where(small, 1.0, rho))
    else:
        n = rho
        ratio = np.where(rho > 0.0, s / np.where(rho > 0.0, rho, 1.0), 0.0)
    return s, ratio, n / np.maximum(s, S_MIN), n * s


def _low_speed_directions(vv, s, v_eps: float, q, ns, rows, direction):
    """Rows below ``v_eps`` with a direction ``e``: ``(q, n s)``, ``rows`` written there.

    ``h = <p, v> + s <e, v>``, ``dh/dp = v + <e, v> p / s``, ``dh/dv = p + s e``
    (:func:`row_barrier_terms`): ``s <e, [a_rel | b_rel]>`` goes into ``rows``.
    """
    ev, eab, e2 = direction
    use = (vv < v_eps * v_eps) & (s > 0.0) & (e2 > 0.0)
    if use.any():
        q = np.where(use, ev / np.where(use, s, 1.0), q)
        ns = np.where(use, s * ev, ns)
        np.copyto(rows, eab * s, where=use)
    return q, ns


def products(p, v, a_rel, b_rel):
    """``(sq, pw, vw)`` of :func:`cone_rows` from in-plane arrays, broadcast together.

    Last axis: the 2 in-plane coordinates (``b_rel``: ``(..., 2, m)``).
    """
    lead = np.broadcast_shapes(v.shape[:-1], a_rel.shape[:-1], b_rel.shape[:-2]) + (2,)
    w = np.concatenate([np.broadcast_to(v[..., None], lead + (1,)),
                        np.broadcast_to(a_rel[..., None], lead + (1,)),
                        np.broadcast_to(b_rel, lead + b_rel.shape[-1:])], -1)
    pw = np.moveaxis(np.einsum("...k,...kj->...j", p, w), -1, 0)  # (2 + m,) + S
    vw = np.moveaxis(np.einsum("...k,...kj->...j", v, w), -1, 0)
    return np.stack([np.einsum("...k,...k->...", p, p), vw[0]]), pw, vw


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
    """Unchecked :func:`barrier_terms` (float arrays)."""
    axes = PLANE_AXES[np.asarray(plane, dtype=np.intp)]  # (..., n, 2)
    P = np.take_along_axis(kin.position[..., None, :], axes, -1)
    V = np.take_along_axis(kin.velocity[..., None, :], axes, -1)
    A = np.take_along_axis(kin.accel_drift[..., None, :], axes, -1)
    B = np.take_along_axis(kin.accel_input[..., None, :, :], axes[..., None], -2)
    return _terms_in_plane(P, V, A, B, center, velocity, radius, v_eps)


def _terms_in_plane(P, V, A, B, center, velocity, radius, v_eps) -> BarrierTerms:
    """:class:`BarrierTerms` from in-plane body-point kinematics, through :func:`cone_rows`."""
    r = np.asarray(radius, dtype=float)
    p = np.asarray(center, dtype=float) - P
    v = np.asarray(velocity, dtype=float) - V
    sq, pw, vw = products(p, v, -A, -B)
    off = np.zeros_like(sq)
    off[0] = r * r
    t = cone_rows(sq, pw, vw, off, v_eps)
    return BarrierTerms(t.h, t.rows[0], np.moveaxis(t.rows[1:], 0, -1), p, v, t.clearance)


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
    t, F, _ = row_rows(kin, center, velocity, radius, plane, v_eps, direction)
    lg = t.rows[1:].T
    return BarrierTerms(t.h, t.rows[0], lg, F[0].T, F[1].T, t.clearance)


def row_rows(kin: PointKinematics, center, velocity, radius, plane, v_eps, direction=None):
    """:func:`row_barrier_terms` as ``(ConeRows, F, Y)`` (coordinate-major, as ``rows.PointRows``).

    ``F`` ``(3 + m, 2, n)``: ``p_rel``, ``v_rel``, ``a_rel``, ``b_rel`` of every row in its
    plane; ``Y`` ``(2, 3 + m, n)``: the inner products of ``F[:2]`` with ``F``.
    """
    n = len(plane)
    axes = PLANE_AXES[np.asarray(plane, dtype=np.intp)]  # (n, 2)
    K = np.concatenate([kin.position[..., None], kin.velocity[..., None],
                        kin.accel_drift[..., None], kin.accel_input], -1)  # (n, 3, 3 + m)
    F = np.negative(K[np.arange(n)[:, None], axes].T, order="C")  # -P, -V, a_rel, b_rel
    F[0] += np.asarray(center, dtype=float).T
    F[1] += np.asarray(velocity, dtype=float).T
    Y = np.einsum("aki,bki->abi", F[:2], F)
    e = None
    if direction is not None:
        ed = np.einsum("ki,bki->bi", np.asarray(direction, dtype=float).T, F[1:])
        e = (ed[0], ed[1:], np.einsum("ik,ik->i", direction, direction))
    r = np.asarray(radius, dtype=float)
    off = np.zeros((2, n))
    off[0] = r * r
    stride = Y.shape[1] + 1
    sq = Y.reshape(2 * (stride - 1), n)[::stride]  # [||p||^2, ||v||^2]
    return cone_rows(sq, Y[0, 1:], Y[1, 1:], off, v_eps, direction=e), F, Y


def reference_directions(kin: PointKinematics, center, velocity, plane, u_ref,
                         horizon: float) -> np.ndarray:
    """``(n, 2)`` unit direction of each row's relative velocity ``horizon`` s ahead.

    Under ``u_ref``: ``c_dot - (V + (a_drift + B u_ref) horizon)``, zero where it vanishes.
    """
    axes = PLANE_AXES[np.asarray(plane, dtype=np.intp)]
    rows = np.arange(len(axes))[:, None]
    acc = kin.accel_drift + kin.accel_input @ np.asarray(u_ref, dtype=float)
    d = np.asarray(velocity, dtype=float) - kin.velocity[rows, axes] - horizon * acc[rows, axes]
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
