r"""The last optimum's working set, re-solved: the warm start of the filter's exact QP.

On consecutive control cycles the optimum of the filter's QP (``dense_qp``)

.. math::  \min_u\ \tfrac12 (u - u_0)^T W (u - u_0)
           \quad\text{s.t.}\quad a_i u \ge b_i,\quad lo \le u \le hi

usually binds the same few constraints (at most ``m``, the number of inputs: 2 to 4) as on
the previous cycle. For such a working set ``S`` the equality-constrained minimiser is

.. math::  u = u_0 + W^{-1} A_S^T \lambda,\qquad (A_S W^{-1} A_S^T)\,\lambda = b_S - A_S u_0,

and ``u`` is *the* optimum of the strictly convex QP exactly when the KKT conditions hold:
``lambda >= 0`` (checked here) and every other constraint holds at ``u`` (checked by the
caller, over all rows at once, with DAQP's own primal tolerance). :func:`resolve` solves the
``|S| x |S|`` system on floats; the caller (``fast_path``) starts from the last optimum's
working set and, where it fails, makes at most two of the active-set method's moves (drop the
constraint of the most negative multiplier, or add the most violated row) before it leaves
the QP to DAQP, which then solves from its own warm start as before. Working sets of more
than 3 constraints (only a 4-input model, ``lateral_models``, has them) are left to DAQP.

Why this is written here instead of calling DAQP every cycle: DAQP's Python interface costs
about 4 us per solve (``update`` and ``solve`` with their argument conversions and result
copies) for a QP of 2-3 variables; this check costs about 1 us. It answers only with a
verified KKT point, so the answer is DAQP's up to rounding (the well-conditioned systems
accepted here: ``det(M) >= 1e-2 prod(diag(M))``, i.e. binding constraints more than ~6 deg
from parallel in the ``W^-1`` metric).
"""

from __future__ import annotations

from operator import mul

__all__ = ["MAX_SET", "WELL_CONDITIONED", "resolve"]

MAX_SET = 3
"""Largest working set solved here (Cramer's rule up to 3 x 3); larger ones go to DAQP."""

WELL_CONDITIONED = 1e-2
"""Smallest ``det(M) / prod(diag(M))`` of the working set's system solved here (Hadamard:
``<= 1``; the squared sine of the angle between two constraints in the ``W^-1`` metric)."""


def resolve(ws, T, ul, lo_l, hi_l, w_inv_l):
    """``(u, lambda)``: the minimiser over the working set ``ws`` and its multipliers.

    Args:
        ws: Constraint indices (``dense_qp.QPResult.active``: row ``i < n``, ``n + j`` the
            lower limit of input ``j``, ``n + m + j`` its upper limit), at most ``m``.
        T: ``(1 + m, n)`` the rows as ``[c0; G^T]`` (``G u + c0 >= 0``; any positive scaling).
        ul: ``u_0`` as a list of floats.
        lo_l: Lower limits (list).
        hi_l: Upper limits (list).
        w_inv_l: ``W^-1`` as a list of rows, or None for ``W = I``.

    Returns:
        ``u`` as a list of floats, exactly on the limits of ``ws`` (within the others up to the
        caller's check), or None where a multiplier is negative; ``lambda`` (a list, in the
        order of ``ws``), or None for an empty, too large or badly conditioned ``ws``.

    """
    k, m, n = len(ws), len(ul), T.shape[1]
    if not 0 < k <= min(m, MAX_SET):
        return None, None
    rows_only = max(ws) < n
    if rows_only and w_inv_l is None and k <= 2:  # the usual case, in fewer steps
        return _rows(ws, T, ul)
    if rows_only:
        A = [T[:, c].tolist() for c in ws]  # [c0_i, G_i]
        b = [-a.pop(0) for a in A]
    else:
        A, b = _constraints(ws, T, m, n, lo_l, hi_l)
    WA = A if w_inv_l is None else [[sum(map(mul, row, a)) for row in w_inv_l] for a in A]
    r = [bp - sum(map(mul, a, ul)) for a, bp in zip(A, b, strict=True)]
    if k == 1:
        den = sum(map(mul, A[0], WA[0]))
        lam = [r[0] / den] if den > 0.0 else None
    else:
        lam = _solve_spd([[sum(map(mul, a, wa)) for wa in WA] for a in A], r)
    if lam is None or min(lam) < 0.0:
        return None, lam
    u = ul
    for lp, wa in zip(lam, WA, strict=True):
        u = [v + lp * w for v, w in zip(u, wa, strict=True)]
    if not rows_only:
        for c in ws:  # a limit in the working set holds exactly
            if n <= c < n + m:
                u[c - n] = lo_l[c - n]
            elif c >= n + m:
                u[c - n - m] = hi_l[c - n - m]
    return u, lam


def _rows(ws, T, ul):
    """:func:`resolve` for one or two rows and ``W = I`` (the same formulas, unrolled)."""
    c0, *g = T[:, ws[0]].tolist()
    r0 = -c0 - sum(map(mul, g, ul))
    g2 = sum(map(mul, g, g))
    if len(ws) == 1:
        if not g2 > 0.0:
            return None, None
        lam = r0 / g2
        if lam < 0.0:
            return None, [lam]
        return [v + lam * w for v, w in zip(ul, g, strict=True)], [lam]
    d0, *e = T[:, ws[1]].tolist()
    r1 = -d0 - sum(map(mul, e, ul))
    ge, e2 = sum(map(mul, g, e)), sum(map(mul, e, e))
    det = g2 * e2 - ge * ge
    if not det >= WELL_CONDITIONED * (g2 * e2) or not det > 0.0:
        return None, None
    lam = [(r0 * e2 - ge * r1) / det, (g2 * r1 - ge * r0) / det]
    if lam[0] < 0.0 or lam[1] < 0.0:
        return None, lam
    return [v + lam[0] * a + lam[1] * c for v, a, c in zip(ul, g, e, strict=True)], lam


def _constraints(ws, T, m: int, n: int, lo_l, hi_l):
    """``(A, b)``: the working set's constraints ``a u >= b`` as lists (rows and limits)."""
    A, b = [], []
    for c in ws:
        if c < n:
            col = T[:, c].tolist()
            A.append(col[1:])
            b.append(-col[0])
        elif c < n + m:
            A.append([1.0 if j == c - n else 0.0 for j in range(m)])
            b.append(lo_l[c - n])
        else:
            A.append([-1.0 if j == c - n - m else 0.0 for j in range(m)])
            b.append(-hi_l[c - n - m])
    return A, b


def _solve_spd(M, r) -> list[float] | None:
    """``M^-1 r`` (Cramer's rule), or None unless ``M`` (order 1-3) is well conditioned."""
    k = len(M)
    diag = M[0][0] if k == 1 else (M[0][0] * M[1][1] if k == 2 else M[0][0] * M[1][1] * M[2][2])
    if not diag > 0.0:
        return None
    if k == 1:
        return [r[0] / M[0][0]]
    if k == 2:
        det = M[0][0] * M[1][1] - M[0][1] * M[1][0]
        if not det >= WELL_CONDITIONED * diag:
            return None
        return [(r[0] * M[1][1] - M[0][1] * r[1]) / det, (M[0][0] * r[1] - M[1][0] * r[0]) / det]
    det = _det3(M)
    if not det >= WELL_CONDITIONED * diag:
        return None
    out = []
    for j in range(3):
        Mj = [[r[i] if c == j else M[i][c] for c in range(3)] for i in range(3)]
        out.append(_det3(Mj) / det)
    return out


def _det3(M) -> float:
    """Determinant of a 3 x 3 matrix (lists)."""
    (a, b, c), (d, e, f), (g, h, i) = M
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
