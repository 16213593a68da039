r"""Exact solution of the filter's small QP by a dual active-set method (Goldfarb-Idnani).

Problem (the safety filter's hard QP; ``W`` symmetric positive definite)::

    min_u (u - u0)^T W (u - u0)   s.t.   A u >= b,   lo <= u <= hi.

Every constraint, finite bounds included, is written as a row ``a_i u >= b_i``; with
``d = u - u0`` and ``r_i = b_i - a_i u0`` the rows read ``a_i d >= r_i``. By stationarity the
optimum is ``d = W^-1 A^T mu`` with multipliers ``mu >= 0`` that vanish on inactive rows, so
everything can be computed from the Gram matrix ``K = A W^-1 A^T`` (``N x N``, rank ``<= m``)
and ``r``: row values are ``A d = K mu``.

Algorithm: the dual method of Goldfarb and Idnani (Math. Programming 27, 1983), the one
behind ``quadprog``. It starts at the unconstrained minimum ``d = 0`` and keeps an active set
``S`` of linearly independent rows whose equality-constrained minimiser has ``mu_S >= 0``
(a dual-feasible point). Each major step takes the most violated row ``p`` and moves along
the direction that changes ``a_p d`` while keeping the rows of ``S`` tight; a multiplier of
``S`` that would turn negative first is dropped (partial step), otherwise ``p`` joins ``S``
(full step). The dual objective strictly increases, so no active set repeats and the method
ends after finitely many steps, with

* no violated row: ``d`` is primal feasible and (``mu >= 0``, stationarity) a KKT point of
  a strictly convex QP, hence *the* optimum; or
* a violated row ``p`` whose normal is a combination of the active normals with no positive
  coefficient: a Farkas certificate that the constraints are infeasible.

The dimensions here are tiny (``m <= 3`` inputs, ``N`` = obstacles + bounds rows), so one
numpy product builds ``K``; a major step costs one ``K mu`` product and the inner steps run
on Python floats (``|S| <= m`` systems solved explicitly). A partial step removes a row from
``S``, so a major step has at most ``m`` of them.

Numerics: rows are expected at unit norm. A row counts as violated below
``-_VIOL_TOL * (1 + max |r|)``, as linearly dependent on ``S`` when its squared distance to
their span (``W^-1`` metric) is below ``_DEP_TOL * K_pp``. The iteration count is capped; when
the cap is hit the result is "unknown" and the caller uses a general solver. The caller also
verifies the returned point against the constraints.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = ["ActiveSetResult", "solve_box_qp"]

_VIOL_TOL = 1e-12  # a row is violated below -_VIOL_TOL * (1 + max |r|)
_DEP_TOL = 1e-10  # squared distance to the span of S below _DEP_TOL * K_pp: dependent
_POS_TOL = 1e-12  # a step component counts as positive above _POS_TOL * (1 + max |comp|)
_MAX_STEPS_PER_ROW = 6
_WARM_DEP = 1e-6  # warm-start rows count as dependent below this Gram determinant ratio
_BOX = [np.concatenate((np.eye(k), -np.eye(k))) for k in range(4)]  # u >= lo, -u >= -hi


class ActiveSetResult(NamedTuple):
    """Result of :func:`solve_box_qp`.

    ``u``: the optimum (None if not found); ``infeasible``: proven infeasible; ``active``: the
    final active rows (the rows of ``a``, then the finite lower bounds, then the finite upper
    bounds), to warm-start the next, similar problem.
    """

    u: np.ndarray | None
    infeasible: bool
    active: tuple[int, ...] = ()


def _solve(ks: list[list[float]], rhs: list[float]) -> list[float] | None:
    """Solve the small symmetric positive definite system ``ks x = rhs`` (size 0..3)."""
    n = len(rhs)
    if n == 0:
        return []
    if n == 1:
        return [rhs[0] / ks[0][0]]
    if n == 2:
        (a, b), (_, d) = ks
        det = a * d - b * b
        if not det > 0.0:
            return None
        return [(d * rhs[0] - b * rhs[1]) / det, (a * rhs[1] - b * rhs[0]) / det]
    if n == 3:
        (a, b, c), (_, d, e), (_, _, f) = ks
        c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
        c11, c12, c22 = a * f - c * c, b * c - a * e, a * d - b * b
        det = a * c00 + b * c01 + c * c02
        if not det > 0.0:
            return None
        r0, r1, r2 = rhs
        return [
            (c00 * r0 + c01 * r1 + c02 * r2) / det,
            (c01 * r0 + c11 * r1 + c12 * r2) / det,
            (c02 * r0 + c12 * r1 + c22 * r2) / det,
        ]
    try:
        return np.linalg.solve(np.array(ks), np.array(rhs)).tolist()
    except np.linalg.LinAlgError:
        return None


def _warm_start(warm, kk, r, n_rows: int, m: int, mu: np.ndarray) -> list[int]:
    """Active rows to start from: ``warm`` if it is a dual-feasible S-pair, else none.

    The equality-constrained minimiser on rows ``S`` has multipliers ``K_SS^-1 r_S``; it is a
    valid starting point of the dual method when the rows are independent (Gram determinant
    not small against the product of its diagonal) and every multiplier is ``>= 0``.
    Writes the multipliers into ``mu``.
    """
    S = list(dict.fromkeys(i for i in warm if 0 <= i < n_rows))
    if not 0 < len(S) <= min(m, 3):
        return []
    ks = [[kk(i, j) for j in S] for i in S]
    diag = math.prod(ks[i][i] for i in range(len(S)))
    if len(S) == 2:
        det = ks[0][0] * ks[1][1] - ks[0][1] ** 2
    elif len(S) == 3:
        (a, b, c), (_, d, e), (_, _, f) = ks
        det = a * (d * f - e * e) - b * (b * f - c * e) + c * (b * e - c * d)
    else:
        det = diag
    if not det > _WARM_DEP * diag:
        return []
    lam = _solve(ks, [float(r[i]) for i in S])
    if lam is None or not all(x >= 0.0 and math.isfinite(x) for x in lam):
        return []
    for i, x in zip(S, lam, strict=True):
        mu[i] = x
    return S


def _add_row(p: int, sp: float, S: list[int], mu: np.ndarray, kk, m: int):
    """Major step 2: move until the violated row ``p`` (value ``sp < 0``) is tight.

    Moves along the direction that changes ``a_p d`` and keeps the rows of ``S`` tight; a row
    of ``S`` whose multiplier would turn negative first is dropped (partial step) and the
    move goes on. Updates ``S`` and ``mu`` in place. Returns None once ``p`` joined ``S``
    (full step), else the final :class:`ActiveSetResult`: infeasible (``a_p`` depends on
    ``S`` with no positive coefficient: a Farkas certificate) or unknown (singular system).
    """
    kpp = kk(p, p)
    while True:
        if S:
            kps = [kk(p, j) for j in S]
            rd = _solve([[kk(i, j) for j in S] for i in S], kps)  # S-multipliers' rates
            if rd is None:
                return ActiveSetResult(None, False)
            # a_p d changes by zp per unit step (d moves by W^-1 (a_p - A_S^T rd)).
            zp = kpp - sum(x * c for x, c in zip(kps, rd, strict=True))
            pos_tol = _POS_TOL * (1.0 + max(map(abs, rd)))
        else:
            rd, zp, pos_tol = [], kpp, 0.0
        t1, block = math.inf, -1  # partial step: first S-multiplier to reach zero
        for j, c in zip(S, rd, strict=True):
            if c > pos_tol and mu[j] / c < t1:
                t1, block = float(mu[j] / c), j
        # full step (a_p independent of S; with m rows in S it cannot be)
        t2 = -sp / zp if len(S) < m and zp > _DEP_TOL * kpp else math.inf
        if t1 == math.inf and t2 == math.inf:
            return ActiveSetResult(None, True)  # a_p depends on S with rd <= 0: Farkas
        t = min(t1, t2)
        sp += t * zp
        for j, c in zip(S, rd, strict=True):
            mu[j] -= t * c
        mu[p] += t
        if t2 <= t1:
            S.append(p)
            return None
        mu[block] = 0.0
        S.remove(block)


def solve_box_qp(
    w_inv: np.ndarray,
    u0: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    bounded: bool | None = None,
    warm: tuple[int, ...] = (),
) -> ActiveSetResult:
    """Exact ``argmin (u-u0)^T W (u-u0)`` s.t. ``a u >= b``, ``lo <= u <= hi`` (see module).

    Args:
        w_inv: ``(m, m)`` inverse of the symmetric positive definite weight ``W``.
        u0: ``(m,)`` reference.
        a: ``(k, m)`` constraint rows (no all-zero rows; unit norm is best conditioned).
        b: ``(k,)`` right-hand sides (finite).
        lo: ``(m,)`` lower bounds (``-inf``: none).
        hi: ``(m,)`` upper bounds, ``lo <= hi`` (``inf``: none).
        bounded: whether every bound is finite, if the caller knows (None: checked here).
        warm: rows to start from (e.g. the previous call's ``active``). Used only if they are
            linearly independent and their equality-constrained minimiser has multipliers
            ``>= 0`` (a dual-feasible start, so the result is the same optimum); else ignored.

    Returns:
        :class:`ActiveSetResult`: ``u`` the optimum (not clipped; every row and bound holds
        to within the tolerances), or ``u=None`` with ``infeasible=True`` when a Farkas
        certificate was found, ``infeasible=False`` when the iteration cap was hit.

    """
    m = u0.shape[0]
    if bounded is None:
        bounded = bool(np.isfinite(lo).all() and np.isfinite(hi).all())
    if bounded and m < len(_BOX):
        A = np.concatenate((a, _BOX[m]))  # the usual case: every input bounded
        r = np.concatenate((b, lo, -hi)) - A @ u0  # need A d >= r
    else:
        fin_lo, fin_hi = np.isfinite(lo), np.isfinite(hi)
        eye = np.eye(m)
        A = np.concatenate((a, eye[fin_lo], -eye[fin_hi]))
        r = np.concatenate((b, lo[fin_lo], -hi[fin_hi])) - A @ u0
    viol_tol = _VIOL_TOL * (1.0 + float(np.abs(r).max()))
    if r.max() <= viol_tol:
        return ActiveSetResult(u0.copy(), False)
    V = w_inv @ A.T  # (m, N): columns W^-1 a_i
    K = A @ V  # Gram matrix (symmetric): row values are A d = K mu
    kk = K.item
    n_rows = r.shape[0]

    S: list[int] = []  # active rows, linearly independent
    mu = np.zeros(n_rows)  # multipliers (non-zero only on S and the row being added)
    if warm:
        S = _warm_start(warm, kk, r, n_rows, m, mu)
    for _ in range(_MAX_STEPS_PER_ROW * (n_rows + m)):
        # Step 1: the most violated row (unit rows: the furthest from its half-space), if any.
        s = K @ mu - r  # a_i d - r_i
        for i in S:
            s[i] = 0.0  # tight by construction
        p = int(s.argmin())
        if not s[p] < -viol_tol:
            return ActiveSetResult(u0 + V @ mu, False, tuple(S))
        # Step 2: add p, dropping rows whose multiplier would turn negative on the way.
        stop = _add_row(p, float(s[p]), S, mu, kk, m)
        if stop is not None:
            return stop
    return ActiveSetResult(None, False)
