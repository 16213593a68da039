"""OSQP problems of the safety filter, set up once per size and then only updated.

``HardQP``: ``min 1/2 u'Wu + q'u`` s.t. ``l <= [G; I] u <= u`` (the filter's exact QP, rows
scaled to unit norm). ``RelaxedQP``: the same with one non-negative slack per row and a
heavy penalty on it. Both keep a fixed sparsity pattern (explicit zeros are kept), so each
call only updates ``q``, ``l``, ``u`` and ``Ax`` and warm starts from the last solution.
``QPSolvers``: one of each per row count, and how the filter solves and checks them.
"""

from __future__ import annotations

import numpy as np
import osqp
import scipy.sparse as sp

__all__ = [
    "INFEASIBLE",
    "OSQP_DEFAULTS",
    "OSQP_INF",
    "RETRYABLE",
    "HardQP",
    "QPSolvers",
    "RelaxedQP",
]

OSQP_INF = 1e30
"""OSQP's infinity (a bound beyond it is no bound)."""

INFEASIBLE = (
    osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE,
    osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE_INACCURATE,
)
RETRYABLE = (
    osqp.SolverStatus.OSQP_SOLVED,
    osqp.SolverStatus.OSQP_SOLVED_INACCURATE,
    osqp.SolverStatus.OSQP_MAX_ITER_REACHED,
)
_SOLVED = (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)

OSQP_DEFAULTS = {
    "verbose": False,
    "eps_abs": 1e-7,
    "eps_rel": 1e-7,
    "eps_prim_inf": 1e-7,
    "eps_dual_inf": 1e-7,
    "polishing": True,
    "polish_refine_iter": 5,
    "max_iter": 4000,
    "warm_starting": True,
    "check_termination": 10,
}


def _csc(data, indices, indptr, shape):
    """CSC matrix that keeps explicit entries (never drops zeros)."""
    return sp.csc_matrix(
        (np.asarray(data, float), np.asarray(indices, np.int64), np.asarray(indptr, np.int64)),
        shape=shape,
    )


class HardQP:
    """``min 1/2 u'Wu + q'u`` s.t. ``l <= [G; I] u <= u`` with ``n`` rows of ``G``."""

    def __init__(self, n: int, m: int, w: np.ndarray, settings: dict):
        self.n, self.m = n, m
        # P: full upper triangle of W, column-major (CSC of triu).
        p_rows = [i for j in range(m) for i in range(j + 1)]
        p_ptr = np.r_[0, np.cumsum(np.arange(1, m + 1))]
        p_data = np.array([w[i, j] for j in range(m) for i in range(j + 1)])
        P = _csc(p_data, p_rows, p_ptr, (m, m))
        # A = [G; I]: column j holds rows 0..n-1 then row n+j.
        a_rows = np.concatenate([np.r_[np.arange(n), n + j] for j in range(m)])
        a_ptr = np.arange(m + 1) * (n + 1)
        self.ax = np.ones((m, n + 1))
        A = _csc(self.ax.ravel(), a_rows, a_ptr, (n + m, m))
        self.l = np.full(n + m, -OSQP_INF)
        self.u = np.full(n + m, OSQP_INF)
        self.solver = osqp.OSQP()
        self.solver.setup(P, np.zeros(m), A, self.l, self.u, **settings)
        self.settings = dict(settings)

    def solve(self, g_rows, lo, u_min, u_max, q):
        """Solve with rows ``g_rows >= lo``, limits and linear cost ``q``: ``(x, status)``."""
        n = self.n
        self.ax[:, :n] = g_rows.T
        self.l[:n] = lo
        self.l[n:] = u_min
        self.u[n:] = u_max
        self.solver.update(q=q, l=self.l, u=self.u, Ax=self.ax.ravel())
        res = self.solver.solve(raise_error=False)
        return res.x[: self.m].copy(), int(res.info.status_val)

    def tighten(self, factor: float):
        """Scale the tolerances by ``factor`` and allow 4x the iterations (see restore)."""
        s = self.settings
        self.solver.update_settings(
            eps_abs=s["eps_abs"] * factor, eps_rel=s["eps_rel"] * factor, max_iter=4 * s["max_iter"]
        )

    def restore(self):
        """Back to the settings given at setup."""
        s = self.settings
        self.solver.update_settings(
            eps_abs=s["eps_abs"], eps_rel=s["eps_rel"], max_iter=s["max_iter"]
        )


class RelaxedQP:
    """Variables ``(u, d)``; ``[G I; I 0; 0 I] (u, d)`` in ``[lo, inf; u_min, u_max; 0, inf]``."""

    def __init__(self, n: int, m: int, w: np.ndarray, rho: float, settings: dict):
        self.n, self.m = n, m
        p_rows = [i for j in range(m) for i in range(j + 1)] + list(range(m, m + n))
        p_ptr = np.r_[0, np.cumsum(np.arange(1, m + 1)), m * (m + 1) // 2 + np.arange(1, n + 1)]
        p_data = np.r_[[w[i, j] for j in range(m) for i in range(j + 1)], np.full(n, 2.0 * rho)]
        P = _csc(p_data, p_rows, p_ptr, (m + n, m + n))
        rows_u = [np.r_[np.arange(n), n + j] for j in range(m)]
        rows_d = [np.array([i, n + m + i]) for i in range(n)]
        a_rows = np.concatenate(rows_u + rows_d) if (rows_u or rows_d) else np.zeros(0)
        a_ptr = np.r_[np.arange(m + 1) * (n + 1), m * (n + 1) + 2 * np.arange(1, n + 1)]
        self.ax = np.ones(m * (n + 1) + 2 * n)
        self.ax_g = self.ax[: m * (n + 1)].reshape(m, n + 1)
        A = _csc(self.ax, a_rows, a_ptr, (2 * n + m, m + n))
        self.l = np.full(2 * n + m, -OSQP_INF)
        self.l[n + m :] = 0.0
        self.u = np.full(2 * n + m, OSQP_INF)
        self.q = np.full(m + n, rho)
        self.solver = osqp.OSQP()
        self.solver.setup(P, self.q.copy(), A, self.l, self.u, **settings)

    def solve(self, g_rows, lo, u_min, u_max, q_u):
        """Solve with rows ``g_rows``, limits and cost ``q_u`` on ``u``: ``(u, status)``."""
        n, m = self.n, self.m
        self.ax_g[:, :n] = g_rows.T
        self.l[:n] = lo
        self.l[n : n + m] = u_min
        self.u[n : n + m] = u_max
        self.q[:m] = q_u
        self.solver.update(q=self.q, l=self.l, u=self.u, Ax=self.ax)
        res = self.solver.solve(raise_error=False)
        return res.x[:m].copy(), int(res.info.status_val)


class QPSolvers:
    """The filter's hard and relaxed QPs, one of each per row count ``n``, kept between calls.

    Args:
        w: ``(m, m)`` weight ``W`` (validated).
        relax_penalty: Slack penalty of the relaxed QP relative to the largest eigenvalue of
            ``W`` (validated, > 0).
        overrides: Overrides of ``OSQP_DEFAULTS`` (None: none).

    """

    def __init__(self, w: np.ndarray, relax_penalty: float, overrides: dict | None):
        self.w = w
        self.m = w.shape[0]
        self.rho = relax_penalty * float(np.linalg.eigvalsh(w).max())
        self.settings = {**OSQP_DEFAULTS, **(overrides or {})}
        # The relaxed QP is a fallback whose answer is a compromise anyway: looser tolerances
        # (still polished) keep its worst-case iteration count low.
        self.relaxed_settings = {
            **self.settings,
            "eps_abs": max(self.settings["eps_abs"], 1e-5),
            "eps_rel": max(self.settings["eps_rel"], 1e-5),
        }
        self.hard: dict[int, HardQP] = {}
        self.relaxed: dict[int, RelaxedQP] = {}

    def clear(self) -> None:
        """Drop every solver (the next solves set up fresh ones, no warm start)."""
        self.hard.clear()
        self.relaxed.clear()

    def solve_hard(self, n, Gn, lo_rows, lo, hi, q, verify):
        """The hard QP with ``n`` rows: ``(u, True, status)``, else ``(None, False, status)``.

        ``u`` is clipped to ``[lo, hi]`` and accepted when OSQP reports solved and
        ``verify(u, Gn, lo_rows)`` holds; otherwise it is re-solved once with tighter
        tolerances, warm started from that iterate.
        """
        qp = self.hard.get(n)
        if qp is None:
            qp = self.hard[n] = HardQP(n, self.m, self.w, self.settings)
        u, st = qp.solve(Gn, lo_rows, lo, hi, q)
        if st in _SOLVED or st == osqp.SolverStatus.OSQP_MAX_ITER_REACHED:
            u = np.clip(u, lo, hi)
            if st == osqp.SolverStatus.OSQP_SOLVED and verify(u, Gn, lo_rows):
                return u, True, st
            # Not certified (an iterate at the iteration limit can be feasible yet far from
            # optimal) or not verified: tighten and re-solve, warm started from that iterate.
            qp.tighten(1e-3)
            try:
                u2, st = qp.solve(Gn, lo_rows, lo, hi, q)
            finally:
                qp.restore()
            u2 = np.clip(u2, lo, hi)
            if st in _SOLVED and verify(u2, Gn, lo_rows):
                return u2, True, st
        return None, False, st

    def solve_relaxed(self, n, Gn, lo_rows, lo, hi, q):
        """The relaxed QP with ``n`` rows: ``(u, status)``, ``u`` clipped; ``u`` None if failed."""
        qp = self.relaxed.get(n)
        if qp is None:
            qp = self.relaxed[n] = RelaxedQP(n, self.m, self.w, self.rho, self.relaxed_settings)
        u, st = qp.solve(Gn, lo_rows, lo, hi, q)
        if st not in RETRYABLE or not np.isfinite(u).all():
            return None, st
        return np.clip(u, lo, hi), st
