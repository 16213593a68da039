"""The safety filter's usual call in few array operations (one body point, ``method='auto'``).

Where every row is clear of its circle (outside ``r + margin``, ``s >= S_MIN``) and of low
relative speeds (``||v_rel|| >= v_eps``, or ``> 0`` for ``v_eps = 0``), the clamp and the
blend of the barrier do not apply, and ``lie.cone_rows`` evaluates the rows of every
obstacle with a handful of operations on the set's :class:`~.rows.PointRows` (kept while the
same :class:`~.geometry.Obstacles` object comes back). Then, as in the general path
(``filter``, module docstring): the reference when it is admissible (INACTIVE), the closed
form of a single row when it lies within the limits, else DAQP warm started on the unit-norm
rows, its answer verified; infeasible or unverified, the OSQP and relaxed steps of the
general path take these rows over.

Anything else (a row inside or near its circle, a slow row, a row ``u`` cannot move,
non-finite terms) returns None and the general path answers: the same formulas with every
clamp and blend (``lie.cone_rows`` without a gate), so both give the same numbers wherever
both apply (``test/test_c3bf_fast_path.py`` compares them).
"""

from __future__ import annotations

import math
import time
from operator import le, mul
from typing import TYPE_CHECKING

import numpy as np

from .dense_qp import primal_tol
from .result import FilterResult, FilterStatus
from .rows import ACTIVE_TOL, FEAS_TOL, ROUND_TOL, ROW_ZERO, Rows, Terms
from .working_set import resolve

if TYPE_CHECKING:
    from .filter import SafetyFilter

__all__ = ["fast_filter", "one_row"]

_INACTIVE, _ACTIVE = FilterStatus.INACTIVE, FilterStatus.ACTIVE


def fast_filter(flt: SafetyFilter, x, yaw, kin, u0, ul, obs, t0) -> FilterResult | None:
    """``flt.filter`` for one body point when the usual case holds, else None.

    ``kin``: the body point's kinematics (tuples of floats); ``u0``, ``ul``: ``u_ref`` as an
    array and a list; ``t0``: start of the call. ``flt._cur`` and ``flt._umax`` hold the
    call's limits and ``||u_ref||``; the reference is not far (``domain.REF_RATIO_MAX``).
    """
    point = flt._point_rows(obs)
    if point.n == 1:  # on floats: INACTIVE or the closed form, most often
        row = point.one_row(kin, flt.gamma)
        if row is None:
            return None  # in (or near) its circle, or slow: the general path
        res = one_row(flt, row, u0, ul, t0)
        if res is not None or not math.isfinite(row[1] + sum(row[2])):
            return res  # (None for non-finite terms: the general path fails safe)
        h, c0, g, clearance, gap = row
        h, T = np.array((h,)), np.array((c0, *g))[:, None]
        clearance, gap = np.array((clearance,)), np.array((gap,))
    else:
        Y = point.products(kin)
        t = point.rows(Y, flt.v_eps, point.gate)
        if t is None:
            return None  # a row in (or near) its circle, or slow: the general path
        h, T, clearance, gap = t.h, t.rows, t.clearance, point.gap(Y)
        T[0] += h if flt.gamma == 1.0 else flt.gamma * h  # T: [Lf h; Lg h^T] -> [c0; G^T]
        if not math.isfinite(np.add.reduce(T, None)):
            return None  # NaN or inf (or the sum overflowing): the general path checks each
        con = np.array((1.0, *ul)) @ T  # c0 + G u_ref
        cur = flt._cur
        if con[con.argmin()] >= 0.0 and all(map(le, cur.lo_l, ul)) and all(
                map(le, ul, cur.hi_l)):  # (x[x.argmin()]: x.min(), NaN too, for less)
            return _result(u0.copy(), ul, _INACTIVE, h, con, None, gap, cur, "none", t0)
    norms = np.hypot(T[1], T[2]) if len(T) == 3 else np.sqrt(np.einsum("ki,ki->i", T[1:], T[1:]))
    if not norms[norms.argmin()] > ROW_ZERO:
        return None  # a row u cannot move (or NaN): the general path
    res = _exact_qp(flt, T, norms, h, gap, u0, ul, t0)
    if res is not None:
        return res
    # Infeasible (DAQP's certificate) or not verified: OSQP, then the relaxed QP.
    infeasible = flt._dense.get(point.n).last_infeasible
    G = np.ascontiguousarray(T[1:].T)
    terms = Terms(h, T[0].copy(), G, clearance, gap)
    rows = Rows(G, terms.c0, G / norms[:, None], -terms.c0 / norms, norms,
                np.zeros(point.n, dtype=bool), False, False)
    with np.errstate(all="ignore"):
        return flt._solve_osqp(x, u0, yaw, terms, rows, infeasible, t0)


def _exact_qp(flt: SafetyFilter, T, norms, h, gap, u0, ul, t0) -> FilterResult | None:
    """The QP's optimum over the rows ``T = [c0; G^T]`` (``norms``: ``||G_i||``), verified.

    First the last optimum's working set re-solved (``working_set``: accepted as a KKT point
    within DAQP's primal tolerance), else DAQP warm started on the unit-norm rows (accepted
    when every row holds within ``SafetyFilter._verify``'s tolerance). None: infeasible (the
    workspace's ``last_infeasible``) or not verified.
    """
    cur = flt._cur
    qp = flt._dense.get(len(norms))
    if qp.working_set:
        res = _working_set(flt, qp, T, norms, h, gap, ul, t0)
        if res is not None:
            return res
    lo_l, hi_l = cur.lo_l, cur.hi_l
    Tn = T / norms  # [-bn; Gn^T]: unit-norm rows Gn u >= bn
    np.negative(Tn[0], out=qp.row_lower)
    sol = qp.solve(u0, Tn[1:].T, None, cur.lo, cur.hi, size=flt._umax)
    if sol.u is None:
        return None
    uu = [min(max(v, a), b) for v, a, b in zip(sol.u.tolist(), lo_l, hi_l, strict=True)]
    con = np.array((1.0, *uu)) @ T
    z = con / norms  # Gn u - bn
    tol = FEAS_TOL * (1.0 + math.hypot(*uu)) + ROUND_TOL * flt._umax
    if not z[z.argmin()] >= -tol:  # every unit-norm row holds (as SafetyFilter._verify)
        return None
    return _result(np.array(uu), uu, _ACTIVE, h, con, z, gap, cur, "active_set", t0)


def _working_set(flt: SafetyFilter, qp, T, norms, h, gap, ul, t0) -> FilterResult | None:
    """The optimum from the last one's working set (``working_set``), or None.

    The set re-solved; a negative multiplier drops its constraint, a violated row (the most
    violated) joins a set of fewer than ``m``; at most three sets. Accepted only as a KKT
    point: multipliers >= 0, every row and limit within DAQP's primal tolerance.
    """
    cur = flt._cur
    lo_l, hi_l = cur.lo_l, cur.hi_l
    tol = primal_tol(flt._umax)
    ws = qp.working_set
    for _ in range(3):
        uu, lam = resolve(ws, T, ul, lo_l, hi_l, flt._w_inv_ws)
        if uu is None:
            if lam is None or len(ws) == 1:
                return None
            ws = ws[:lam.index(min(lam))] + ws[lam.index(min(lam)) + 1:]
            continue
        uu = _within(uu, lo_l, hi_l, tol)
        if uu is None:
            return None
        uv = np.array((1.0, *uu))
        con = uv @ T
        z = con / norms
        worst = int(z.argmin())
        if z[worst] >= -tol:  # KKT: every row holds (as DAQP would accept it)
            qp.working_set = ws
            return _result(uv[1:], uu, _ACTIVE, h, con, z, gap, cur, "active_set", t0)
        if len(ws) >= len(ul) or worst in ws:
            return None
        ws = (*ws, worst)
    return None


def _within(u, lo_l, hi_l, tol: float) -> list[float] | None:
    """``u`` clipped to the limits if it is within ``tol`` of them, else None."""
    out = []
    for v, a, b in zip(u, lo_l, hi_l, strict=True):
        if v < a:
            if v < a - tol:
                return None
            v = a
        elif v > b:
            if v > b + tol:
                return None
            v = b
        out.append(v)
    return out


def one_row(flt: SafetyFilter, row, u0, ul, t0) -> FilterResult | None:
    """One row ``g u + c0 >= 0`` on floats: INACTIVE, the closed form, or None (DAQP next).

    The closed form (``closed_form.cbf_closed_form``) ``u = u_ref - W^-1 g^T psi / (g W^-1
    g^T)`` answers when ``u_ref`` violates the row and ``u`` is within the limits.
    """
    h, c0, g, _, gap = row
    cur = flt._cur
    psi = c0 + sum(map(mul, g, ul))
    if not math.isfinite(psi):
        return None
    if psi >= 0.0:
        if all(map(le, cur.lo_l, ul)) and all(map(le, ul, cur.hi_l)):
            return _one_result(u0.copy(), ul, _INACTIVE, h, psi, None, gap, cur, "none", t0)
        return None  # u_ref holds the row but not a limit: DAQP
    wa = g if flt._w_inv_ws is None else [sum(map(mul, r, g)) for r in flt._w_inv_ws]
    den = sum(map(mul, g, wa))
    if not den > ROW_ZERO**2 * (1.0 + abs(psi)):
        return None
    k = psi / den
    uu = [v - k * w for v, w in zip(ul, wa, strict=True)]
    if not (all(map(le, cur.lo_l, uu)) and all(map(le, uu, cur.hi_l))
            and all(map(math.isfinite, uu))):
        return None
    con = c0 + sum(map(mul, g, uu))
    norm = math.sqrt(sum(map(mul, g, g)))
    return _one_result(np.array(uu), uu, _ACTIVE, h, con, norm, gap, cur, "closed_form", t0)


def _one_result(u, ul, status, h, con, norm, gap, cur, solver, t0) -> FilterResult:
    """:func:`_result` for one row given as floats (``norm``: ``||g||``, None: INACTIVE)."""
    active = norm is not None and min(con / norm, con) <= ACTIVE_TOL
    vals = np.array((h, con, max(-con, 0.0), gap))
    flags = np.array((active, *(v <= a or v >= b for v, a, b in
                                zip(ul, cur.lo_l, cur.hi_l, strict=True))))
    return FilterResult(u, status, vals[0:1], vals[1:2], vals[2:3], flags[0:1], flags[1:],
                        solver, time.perf_counter() - t0, "", vals[3:4])


def _result(u, ul, status, h, con, z, gap, cur, solver, t0) -> FilterResult:
    """The result, as ``filter_outputs.make_result`` builds it.

    ``z``: ``con / ||G_i||``, or None for INACTIVE.

    A row is active where ``con <= ACTIVE_TOL max(||G_i||, 1)``, i.e. where ``con`` (rows of
    norm < 1) or ``z`` (norm >= 1) is at most ``ACTIVE_TOL``: either is, for every row.
    """
    if z is None:
        active = np.zeros(con.shape, dtype=bool)
    else:
        active = np.minimum(z, con) <= ACTIVE_TOL
    bounds = np.array([v <= a or v >= b for v, a, b in zip(ul, cur.lo_l, cur.hi_l, strict=True)])
    return FilterResult(u, status, h, con, np.maximum(-con, 0.0), active, bounds, solver,
                        time.perf_counter() - t0, "", gap)
