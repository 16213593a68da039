"""The safety filter's constraint rows: barrier terms of every obstacle, scaled to unit norm.

Obstacle ``i`` gives the row ``G_i u + c0_i >= 0`` with ``G_i = Lg h_i`` and
``c0_i = Lf h_i + gamma h_i`` (see ``filter``). :func:`obstacle_terms` computes the barrier
terms of every obstacle (per obstacle on floats for a few, vectorised beyond);
:func:`scale_rows` the unit-norm form ``Gn u >= bn`` the solvers use; :func:`screen_rows`
which of them can bind inside the input box. The tolerances below are shared by the
filter's solve paths.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .geometry import Obstacles
from .lie import _barrier_terms, barrier_terms_scalar, row_barrier_terms
from .models import PointKinematics
from .osqp_qp import OSQP_INF

__all__ = [
    "ACTIVE_TOL",
    "FEAS_TOL",
    "ROUND_TOL",
    "ROW_ZERO",
    "SCALAR_TERMS_MAX",
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
SCALAR_TERMS_MAX = 16  # obstacles up to which barrier terms are computed per obstacle


class Terms(NamedTuple):
    """The parts of :class:`~.lie.BarrierTerms` the QP needs (``(n,)``, ``lg_h`` ``(n, m)``)."""

    h: np.ndarray
    lf_h: np.ndarray
    lg_h: np.ndarray
    clearance: np.ndarray  # ||p_rel||^2 - r^2 [m^2] for the radius r the row uses
    gap: np.ndarray  # ||p_rel|| - r_true [m] (FilterResult.clearance)


def _gap(clearance, radius, obs: Obstacles) -> np.ndarray:
    """Signed distance [m] from the body point to each true inflated circle (< 0 inside).

    NaN where rounding makes ``||p||^2`` negative (body point at a centre): such a row is
    inside its circle, and ``inside.inside_rows`` recomputes its gap with a clamp.
    """
    return np.sqrt(clearance + radius * radius) - obs.radius


def obstacle_terms(kin, obs: Obstacles, radius, v_eps: float, m: int, direction=None) -> Terms:
    """h, Lf h, Lg h and clearances of every obstacle (``kin`` as tuples, ``m`` inputs).

    ``kin`` may also be row-wise arrays (``(n, 3)``, row ``i`` its own body point), then
    with an optional ``direction`` per row (``lie.row_barrier_terms``).

    Up to ``SCALAR_TERMS_MAX`` obstacles the scalar formulas per obstacle
    (``barrier_terms_scalar``, tested against ``barrier_terms``) cost fewer operations
    than the vectorised ones; beyond that numpy is faster.
    """
    n = len(obs)
    if np.ndim(kin[0]) == 2:  # row-wise kinematics (whole-body filter, ``body_rows``)
        t = row_barrier_terms(kin, obs.center, obs.velocity, radius, obs.plane, v_eps,
                              direction)
        return Terms(t.h, t.lf_h, t.lg_h, t.clearance, _gap(t.clearance, radius, obs))
    if 0 < n <= SCALAR_TERMS_MAX:
        fn = barrier_terms_scalar
        rows = [
            fn(kin, c[0], c[1], v[0], v[1], r, pl, v_eps)
            for c, v, r, pl in zip(
                obs.center.tolist(), obs.velocity.tolist(), radius.tolist(),
                obs.plane.tolist(), strict=True,
            )
        ]
        h, lf, lg, clearance = zip(*rows, strict=True)
        cl = np.array(clearance)
        return Terms(np.array(h), np.array(lf), np.array(lg), cl, _gap(cl, radius, obs))
    kin = PointKinematics(*(np.array(k, dtype=float) for k in kin))
    t = _barrier_terms(kin, obs.center, obs.velocity, radius, obs.plane, v_eps)
    lg = t.lg_h.reshape(n, m)
    return Terms(t.h, t.lf_h, lg, t.clearance, _gap(t.clearance, radius, obs))


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
