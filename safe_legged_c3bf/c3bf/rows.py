"""The safety filter's constraint rows: barrier terms of every obstacle, scaled to unit norm.

Obstacle ``i`` gives the row ``G_i u + c0_i >= 0`` with ``G_i = Lg h_i`` and
``c0_i = Lf h_i + gamma h_i`` (see ``filter``). Every row comes out of one vectorised
formula, ``lie.cone_rows``: :class:`PointRows` lays an obstacle set out once for the rows
of one body point (the filter keeps it while the same :class:`~.geometry.Obstacles` object
comes back), :func:`obstacle_terms` evaluates the rows of a call (one body point, or the
whole body's row-wise kinematics). :func:`scale_rows` gives the unit-norm form ``Gn u >= bn``
the solvers use; :func:`screen_rows` which of them can bind inside the input box. The
tolerances below are shared by the filter's solve paths.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .geometry import Obstacles
from .inside import INSIDE_REL_CLEARANCE
from .lie import S_MIN, cone_rows, row_rows
from .osqp_qp import OSQP_INF

__all__ = [
    "ACTIVE_TOL",
    "FEAS_TOL",
    "ROUND_TOL",
    "ROW_ZERO",
    "PointRows",
    "Rows",
    "Terms",
    "obstacle_terms",
    "scale_rows",
    "screen_rows",
]

ROW_ZERO = 1e-12  # ||Lg h|| below this: the constraint does not depend on u
FEAS_TOL = 1e-9  # accepted violation of a unit-norm row [input units], times (1 + |u|)
ROUND_TOL = 1e-11  # plus this times ||u_ref|| (rounding of u - u_ref, see dense_qp)
ACTIVE_TOL = 1e-7  # scaled constraint value below which a row counts as binding
_V_MIN = 5e-324  # the smallest positive float: ||v_rel||^2 above it is not 0


class Terms(NamedTuple):
    """The rows ``G u + c0 >= 0`` of a call and what the result reports of them (``(n,)``)."""

    h: np.ndarray
    c0: np.ndarray  # Lf h + gamma h
    G: np.ndarray  # (n, m) Lg h
    clearance: np.ndarray  # ||p_rel||^2 - r^2 [m^2] for the radius r the row uses
    gap: np.ndarray  # ||p_rel|| - r_true [m] (FilterResult.clearance)


class PointRows:
    """An obstacle set laid out for the rows of one body point, built once per set.

    Coordinate-major (the obstacles along the last axis, so every operation of a call runs
    over contiguous rows): ``base`` ``(3 + m, 2, n)`` holds the in-plane centres and
    velocities (then zeros), ``take`` picks each obstacle's in-plane components of the body
    point's kinematics; ``off`` ``[r^2, 0]`` and ``gate`` (``lie.cone_rows``) use the
    constraint radius ``r = radius + margin``. :meth:`products` gives the inner products
    ``lie.cone_rows`` needs from one call's body-point kinematics (tuples of floats).

    Built from the :class:`~.geometry.Obstacles` object ``obs`` (immutable: the filter keeps
    one :class:`PointRows` while ``obs`` itself comes back, and builds a new one for any
    other object).
    """

    __slots__ = ("obs", "n", "stride", "base", "take", "off", "gate", "radius", "one")

    def __init__(self, obs: Obstacles, margin: float, v_eps: float, m: int):
        n = len(obs)
        self.obs, self.n, self.stride = obs, n, 4 + m
        base = np.zeros((3 + m, 2, n))
        base[0] = obs.center.T
        base[1] = obs.velocity.T
        self.base = base
        second = np.where(obs.plane == 0, 1, 2)  # y (x-y plane) or z (x-z plane)
        if n and (second == second[0]).all():
            second = second[:1]  # one plane: the same components for every row
        # Index into P + V + A + B (flattened, B row-major): x and the plane's second axis.
        first = np.r_[0, 3, 6, 9 + np.arange(m)]
        step = np.r_[1, 1, 1, np.full(m, m)]
        self.take = np.stack([np.broadcast_to(first[:, None], (3 + m, len(second))),
                              first[:, None] + step[:, None] * second[None, :]], 1)
        r = obs.radius + margin
        self.radius = r
        self.off = np.zeros((2, n))
        self.off[0] = r * r
        self.gate = np.empty((2, n))
        self.gate[0] = np.maximum(INSIDE_REL_CLEARANCE * r * r, S_MIN * S_MIN)
        self.gate[1] = v_eps * v_eps if v_eps > 0.0 else _V_MIN
        self.one = None  # one obstacle: its numbers as floats (:meth:`one_row`)
        if n == 1:
            (cx, cy), (vx, vy) = obs.center.tolist()[0], obs.velocity.tolist()[0]
            self.one = (cx, cy, vx, vy, int(second[0]), *self.off[0].tolist(),
                        *self.gate[:, 0].tolist(), *obs.radius.tolist())

    def products(self, kin):
        """The inner products ``lie.cone_rows`` needs, ``(2, 3 + m, n)``.

        ``[p_rel, v_rel]`` with ``[p_rel, v_rel, a_rel, b_rel]``; ``kin`` as
        :meth:`~.models.RobotModel.point_kinematics_tuple` returns it.
        """
        P, V, A, B = kin
        K = np.array(P + V + A + B[0] + B[1] + B[2])[self.take]  # (3 + m, 2, 1 or n)
        F = self.base - K  # (3 + m, 2, n): p_rel, v_rel, a_rel, b_rel in-plane
        return np.einsum("aki,bki->abi", F[:2], F)

    def one_row(self, kin, gamma: float):
        """``(h, c0, G, clearance, gap)`` of the one obstacle on floats (``G`` a list), or None.

        The gated branch of ``lie.cone_rows`` on floats, the same operations in the same
        order as on arrays (for one row the arrays cost more than the arithmetic): None
        where the gate is not met.
        """
        cx, cy, cvx, cvy, j, r2, g_cl, g_vv, r0 = self.one
        P, V, A, B = kin
        px, py, vx, vy = cx - P[0], cy - P[j], cvx - V[0], cvy - V[j]
        pp, vv = px * px + py * py, vx * vx + vy * vy
        cl = pp - r2
        if not (cl >= g_cl and vv >= g_vv):
            return None
        s, rho = math.sqrt(cl), math.sqrt(vv)
        ratio, q = s / rho, rho / s
        h = vv * ratio + (px * vx + py * vy)
        a0, aj = A[0], A[j]
        lf = (-(vx * a0 + vy * aj)) * ratio + (-(px * a0 + py * aj))
        lf += q * h
        G = [(-(vx * b0 + vy * bj)) * ratio + (-(px * b0 + py * bj))
             for b0, bj in zip(B[0], B[j], strict=True)]
        return h, lf + (h if gamma == 1.0 else gamma * h), G, cl, math.sqrt(pp) - r0

    def rows(self, Y, v_eps: float, gate=None, off=None):
        """``lie.cone_rows`` of the products ``Y`` (``off``: other radii, e.g. the margin band)."""
        sq = Y.reshape(2 * (self.stride - 1), self.n)[:: self.stride]  # [||p||^2, ||v||^2]
        return cone_rows(sq, Y[0, 1:], Y[1, 1:], self.off if off is None else off, v_eps, gate)

    def gap(self, Y) -> np.ndarray:
        """``||p_rel|| - r_true`` [m] of every row (``FilterResult.clearance``)."""
        return np.sqrt(Y[0, 0]) - self.obs.radius


def obstacle_terms(kin, obs: Obstacles, radius, v_eps: float, gamma: float, direction=None,
                   point: PointRows | None = None) -> Terms:
    """The rows and barrier terms of every obstacle (the general path, every clamp and blend).

    ``kin``: tuples of floats and ``point`` the set's :class:`PointRows` (one body point), or
    row-wise arrays (``(n, 3)``, row ``i`` its own body point: the whole-body filter) with an
    optional ``direction`` per row (``lie.row_barrier_terms``). ``radius``: ``(n,)`` the
    radius each row uses [m].
    """
    if point is None:  # row-wise kinematics (whole-body filter, ``body_rows``)
        t, _, Y = row_rows(kin, obs.center, obs.velocity, radius, obs.plane, v_eps, direction)
        return Terms(t.h, t.rows[0] + gamma * t.h, np.ascontiguousarray(t.rows[1:].T),
                     t.clearance, np.sqrt(Y[0, 0]) - obs.radius)
    Y = point.products(kin)
    off = np.zeros((2, len(obs)))
    off[0] = radius * radius
    t = point.rows(Y, v_eps, off=off)
    G = np.ascontiguousarray(t.rows[1:].T)
    return Terms(t.h, t.rows[0] + gamma * t.h, G, t.clearance, point.gap(Y))


class Rows(NamedTuple):
    """The constraint rows ``G u + c0 >= 0`` and their unit-norm form ``Gn u >= bn``."""

    G: np.ndarray
    c0: np.ndarray
    Gn: np.ndarray
    bn: np.ndarray
    norms: np.ndarray  # ||G_i||
    dead: np.ndarray  # rows that u cannot influence (kept unscaled)
    any_dead: bool
    hopeless: bool  # a dead row is violated: no input can fix it


def scale_rows(G, c0) -> Rows:
    """Scale rows to unit norm (same feasible set, better conditioning)."""
    norms = np.sqrt(np.einsum("ij,ij->i", G, G))
    dead = norms <= ROW_ZERO
    any_dead = bool(dead.any())
    scale = np.where(dead, 1.0, norms) if any_dead else norms
    hopeless = any_dead and bool((dead & (c0 < 0.0)).any())
    return Rows(G, c0, G / scale[:, None], -c0 / scale, norms, dead, any_dead, hopeless)


def screen_rows(rows: Rows, lo, hi, infeasible: bool) -> tuple[np.ndarray, bool]:
    """``(lo_rows, infeasible)`` of the unit-norm rows over the box ``lo <= u <= hi``.

    ``lo_rows``: ``bn``, with ``-OSQP_INF`` for rows that cannot bind inside the box (dead,
    or holding at every point of it). ``infeasible``: already known (``infeasible`` given),
    or a binding row cannot hold anywhere in the box.
    """
    Gn, bn = rows.Gn, rows.bn
    with np.errstate(invalid="ignore"):
        row_min = np.where(Gn > 0, Gn * lo, np.where(Gn < 0, Gn * hi, 0.0)).sum(axis=1)
        row_max = np.where(Gn > 0, Gn * hi, np.where(Gn < 0, Gn * lo, 0.0)).sum(axis=1)
    redundant = rows.dead | (bn <= row_min)
    lo_rows = np.where(redundant, -OSQP_INF, bn)
    return lo_rows, infeasible or bool((bn > row_max + FEAS_TOL)[~redundant].any())
