r"""The filter's relaxed QP (step 5 of ``filter``) on DAQP, the dense solver of step 3.

Problem (``W`` symmetric positive definite, ``m`` inputs, ``n`` rows, slack ``d``)::

    min_{u, d} 1/2 (u - u0)^T W (u - u0) + rho (sum d_i^2 + sum d_i)
    s.t.       a u + d >= b,   lo <= u <= hi,   d >= 0.

The same problem as OSQP's ``osqp_qp.RelaxedQP``, written as one dense QP over ``z = (u, d)``
for :class:`~.dense_qp.DenseQP`: weight ``blockdiag(W, 2 rho I)`` and reference
``z0 = (u0, -1/2)`` (``1/2 (z - z0)^T P (z - z0)`` has the linear term ``(-W u0, rho)``),
rows ``[a I]``, box ``lo <= u <= hi``, ``0 <= d``. It is always feasible (any ``u`` in the
box with a large enough ``d``), and DAQP solves it exactly (the KKT point), where OSQP
stops at its tolerances: a few tens of microseconds against about half a millisecond for
the filter's 10-40 rows. A row with ``b <= -DAQP_INF`` is off (its slack stays 0).

Units: those of the filter's input ``u`` (m/s^2, rad/s^2); ``rho`` in the same cost units.
"""

from __future__ import annotations

import math

import numpy as np

from .dense_qp import DAQP_INF, DenseQP

__all__ = ["DenseRelaxedQPs"]

_MAX_WORKSPACES = 16  # row counts kept (least recently set up dropped first)


class DenseRelaxedQPs:
    """One warm-started DAQP workspace per row count for the relaxed QP.

    Args:
        w: ``(m, m)`` input weight ``W`` (symmetric positive definite, validated by the filter).
        rho: Slack penalty (> 0), as OSQP's relaxed QP uses it (``QPSolvers.rho``).

    """

    def __init__(self, w: np.ndarray, rho: float) -> None:
        if not (math.isfinite(rho) and rho > 0.0):
            raise ValueError(f"rho must be finite and > 0, got {rho!r}")
        self.w = np.array(w, dtype=float)
        self.rho = float(rho)
        self._qps: dict[int, DenseQP] = {}
        self._rows: dict[int, np.ndarray] = {}

    def clear(self) -> None:
        """Drop every workspace (the next solves start cold)."""
        self._qps.clear()
        self._rows.clear()

    def _get(self, n: int) -> tuple[DenseQP, np.ndarray]:
        qp = self._qps.get(n)
        if qp is None:
            if len(self._qps) >= _MAX_WORKSPACES:
                oldest = next(iter(self._qps))
                del self._qps[oldest], self._rows[oldest]
            m = self.w.shape[0]
            p = np.zeros((m + n, m + n))
            p[:m, :m] = self.w
            p[m:, m:] = 2.0 * self.rho * np.eye(n)
            qp = self._qps[n] = DenseQP(p, n)
            rows = np.zeros((n, m + n))
            rows[:, m:] = np.eye(n)
            self._rows[n] = rows
        return qp, self._rows[n]

    def solve(self, u0, a, b, lo, hi) -> np.ndarray | None:
        """The optimal ``u`` (clipped to ``[lo, hi]``), or None if DAQP found no optimum.

        Args:
            u0: ``(m,)`` reference input.
            a: ``(n, m)`` rows (unit norm).
            b: ``(n,)`` right-hand sides, ``-DAQP_INF`` for a row that is off.
            lo: ``(m,)`` lower limits of ``u``.
            hi: ``(m,)`` upper limits of ``u`` (``lo <= hi``).

        """
        n, m = len(b), len(u0)
        qp, rows = self._get(n)
        rows[:, :m] = a
        z0 = np.concatenate([u0, np.full(n, -0.5)])
        z_lo = np.concatenate([lo, np.zeros(n)])
        z_hi = np.concatenate([hi, np.full(n, DAQP_INF)])
        sol = qp.solve(z0, rows, np.asarray(b, dtype=float), z_lo, z_hi)
        if sol.u is None:
            return None
        u = sol.u[:m]
        if not all(map(math.isfinite, u.tolist())):
            return None
        return np.minimum(np.maximum(u, lo), hi)
