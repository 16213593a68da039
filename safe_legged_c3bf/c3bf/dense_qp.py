r"""The filter's hard QP on DAQP, a compiled dual active-set solver for small dense QPs.

Problem (``W`` symmetric positive definite, ``m`` inputs, ``n`` rows)::

    min_u 1/2 (u - u0)^T W (u - u0)   s.t.   a u >= b,   lo <= u <= hi.

DAQP (Arnström, Bemporad, Axehill, IEEE TAC 2022; ``pip install daqp``) is an exact dual
active-set method written in C: like Goldfarb-Idnani it starts from the unconstrained minimum
and adds violated constraints (dropping those whose multiplier would turn negative) until no
row is violated (the KKT point of a strictly convex QP: *the* optimum, to rounding) or a
violated row cannot be added (a certificate that the constraints are infeasible). It was
chosen by measurement over quadprog, proxsuite, piqp and the former Python active set on the
filter's own QPs (see the commit that introduced this module).

:class:`DenseQP` keeps one DAQP workspace per row count: set up once, then only updated
(``f``, ``A``, bounds). DAQP starts each solve from the previous solve's working set (warm
start), which on consecutive control cycles is usually the answer's active set already. A warm
start that ends anywhere but at the optimum (an infeasibility claim, cycling, the iteration
limit) is re-solved once from scratch, so a warm start never changes the verdict.

Each workspace also keeps the working set of its last optimum (:attr:`DenseQP.working_set`),
which the filter re-solves first (``working_set``): when it still gives a KKT point, DAQP is
not called at all.

Tolerance: a row counts as violated beyond ``primal_tol = 1e-12 (1 + ||u0||)`` (rounded up to a
power of ten), in the units of the rows (unit norm: input units). The caller verifies the
answer against the rows (``SafetyFilter._verify``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import daqp
import numpy as np

__all__ = ["DAQP_INF", "DenseQP", "DenseQPs", "QPResult", "primal_tol", "solve_box_qp"]

DAQP_INF = 1e30
"""DAQP's infinity: a bound at or beyond it is no bound."""

_OPTIMAL = (1, 2)  # DAQP exit flags: optimal, optimal with soft constraints
_INFEASIBLE = -1
_PRIMAL_TOL = 1e-12  # times (1 + ||u0||)
_MAX_WORKSPACES = 16  # row counts kept by DenseQPs (least recently set up dropped first)


class QPResult(NamedTuple):
    """Result of :meth:`DenseQP.solve`.

    ``u``: the optimum (None if not found), exactly on the limits DAQP reports active;
    ``infeasible``: proven infeasible; ``iterations``: DAQP's iterations (of the cold
    re-solve, if there was one); ``flag``: DAQP's exit flag (1 optimal, -1 infeasible, see
    DAQP's docs); ``lam``: DAQP's multipliers (the ``m`` limits, then the rows), or None.
    """

    u: np.ndarray | None
    infeasible: bool
    iterations: int = 0
    flag: int = 0
    lam: np.ndarray | None = None

    @property
    def active(self) -> tuple[int, ...]:
        """The working set at the optimum, e.g. to warm-start a similar QP.

        Index ``i < n``: row ``i``; ``n + j``: ``u_j >= lo_j``; ``n + m + j``: ``u_j <= hi_j``.
        """
        if self.u is None or self.lam is None:
            return ()
        m = len(self.u)
        n = len(self.lam) - m
        lam_b = self.lam[:m].tolist()
        rows = np.flatnonzero(self.lam[m:]).tolist()
        lower = [n + j for j in range(m) if lam_b[j] < 0.0]
        upper = [n + m + j for j in range(m) if lam_b[j] > 0.0]
        return tuple(rows + lower + upper)


class DenseQP:
    """One DAQP workspace for QPs with ``n`` rows, weight ``w`` ``(m, m)``; warm started.

    Not thread-safe (one workspace, one solve at a time).
    """

    def __init__(self, w: np.ndarray, n: int):
        self.w = np.array(w, dtype=float)
        self.m, self.n = self.w.shape[0], n
        self._model: daqp.Model | None = None  # set up on the first solve
        self._bl = np.empty(self.m + n)  # DAQP order: the m simple bounds, then the rows
        self._bu = np.full(self.m + n, DAQP_INF)
        self._box: tuple[list, list] = ([], [])  # the limits in _bl, _bu (as lists)
        self._box_arrays: tuple = (None, None)  # ... and the read-only arrays they came from
        self._cold = np.zeros(self.m + n, dtype=np.int32)
        self._tol = _PRIMAL_TOL
        self._neg_w = -self.w  # f = -W u0
        self.row_lower = self._bl[self.m:]
        """The rows' right-hand sides ``b`` (a caller may write them here and pass
        ``b=None``)."""
        self.working_set: tuple[int, ...] = ()
        """The working set of the last optimum found (``QPResult.active``), or empty."""
        self.last_infeasible = False
        """The last solve ended with DAQP's certificate of infeasibility."""

    def solve(self, u0, a, b, lo, hi, warm=None, size=None) -> QPResult:
        """Solve with rows ``a u >= b`` (``b <= -DAQP_INF``: row off) and ``lo <= u <= hi``.

        Args:
            u0: ``(m,)`` reference.
            a: ``(n, m)`` rows (unit norm is best conditioned).
            b: ``(n,)`` right-hand sides (finite, or ``-DAQP_INF`` to switch a row off), or
                None: already written to :attr:`row_lower`.
            lo: ``(m,)`` lower bounds (``-inf``: none).
            hi: ``(m,)`` upper bounds, ``lo <= hi`` (``inf``: none).
            warm: None (start from the previous solve's working set) or constraint indices
                (as in ``QPResult.active``) to start from; invalid ones are ignored.
            size: ``||u0||`` if the caller knows it.

        """
        m, bl, bu = self.m, self._bl, self._bu
        new_box = self._set_box(lo, hi)
        if b is not None:
            bl[m:] = b
        f = self._neg_w.dot(u0)
        tol = primal_tol(math.hypot(*u0.tolist()) if size is None else size)
        model = self._model
        if model is None:
            sense = self._cold if warm is None else self._sense(warm)
            model = self._model = daqp.Model()
            model.setup(self.w, f, a, bu, bl, sense)
            model.settings = {"primal_tol": tol}
            self._tol = tol
            warm_started = bool(sense.any())
        else:
            if tol != self._tol:
                model.settings = {"primal_tol": tol}
                self._tol = tol
            warm_started = self._update(model, f, a, new_box, warm)
        x, _, flag, info = model.solve()
        if flag not in _OPTIMAL and warm_started:
            model.update(sense=self._cold)  # the verdict of a cold start counts
            x, _, flag, info = model.solve()
        self.last_infeasible = flag == _INFEASIBLE
        if flag not in _OPTIMAL:
            return QPResult(None, self.last_infeasible, info["iterations"], flag)
        lam = info["lam"]
        if not all(map(math.isfinite, x.tolist())):
            return QPResult(None, False, info["iterations"], flag)
        for j, lam_j in enumerate(lam[:m].tolist()):  # a limit in the working set holds
            if lam_j < 0.0:  # exactly (DAQP's x carries rounding there)
                x[j] = bl[j]
            elif lam_j > 0.0:
                x[j] = bu[j]
        res = QPResult(x, False, info["iterations"], flag, lam)  # (x: a fresh array)
        self.working_set = res.active
        return res

    def _set_box(self, lo, hi) -> bool:
        """Write the limits ``lo``, ``hi`` if they changed: whether they did."""
        if (lo is self._box_arrays[0] and hi is self._box_arrays[1]
                and not (lo.flags.writeable or hi.flags.writeable)):
            return False  # the same read-only arrays as last time
        box = (lo.tolist(), hi.tolist())
        self._box_arrays = (lo, hi)
        if box == self._box:
            return False
        m = self.m
        np.maximum(lo, -DAQP_INF, out=self._bl[:m])
        np.minimum(hi, DAQP_INF, out=self._bu[:m])
        self._box = box
        return True

    def _update(self, model, f, a, new_box: bool, warm) -> bool:
        """Pass the new data to DAQP: whether the solve starts from a non-empty working set."""
        if warm is None and self.n and not new_box:  # the usual call
            model.update(f=f, A=a, blower=self._bl)
            return True
        data = {"f": f, "blower": self._bl}
        if self.n:  # (DAQP rejects an empty A in update)
            data["A"] = a
        if new_box:
            data["bupper"] = self._bu
        if warm is not None:
            sense = data["sense"] = self._sense(warm)
            model.update(**data)
            return bool(sense.any())
        model.update(**data)
        return True

    def _sense(self, warm) -> np.ndarray:
        """DAQP's constraint states for a warm start from ``warm`` (``QPResult.active``)."""
        m, n = self.m, self.n
        sense = self._cold.copy()
        for i in dict.fromkeys(warm):
            if 0 <= i < n:
                if self._bl[m + i] > -DAQP_INF:
                    sense[m + i] = 3  # active at the lower bound
            elif n <= i < n + m:
                if self._bl[i - n] > -DAQP_INF:
                    sense[i - n] = 3
            elif n + m <= i < n + 2 * m and self._bu[i - n - m] < DAQP_INF:
                sense[i - n - m] = 1  # active at the upper bound
        return sense


def primal_tol(norm_u0: float) -> float:
    """``1e-12 (1 + ||u0||)`` rounded up to a power of ten (few settings changes)."""
    size = 1.0 + norm_u0
    if size < 10.0:
        return _PRIMAL_TOL
    return _PRIMAL_TOL * 10.0 ** math.ceil(math.log10(min(size, 1e300)))


class DenseQPs:
    """The filter's :class:`DenseQP` workspaces, one per row count, kept between calls."""

    def __init__(self, w: np.ndarray):
        self.w = np.array(w, dtype=float)
        self._qps: dict[int, DenseQP] = {}

    def clear(self) -> None:
        """Drop every workspace (the next solves start cold)."""
        self._qps.clear()

    def get(self, n: int) -> DenseQP:
        """The workspace for ``n`` rows (set up on first use; warm starts carry over)."""
        qp = self._qps.get(n)
        if qp is None:
            if len(self._qps) >= _MAX_WORKSPACES:
                del self._qps[next(iter(self._qps))]
            qp = self._qps[n] = DenseQP(self.w, n)
        return qp

    def solve(self, u0, a, b, lo, hi) -> QPResult:
        """:meth:`DenseQP.solve` on the workspace for ``len(b)`` rows, warm started."""
        return self.get(len(b)).solve(u0, a, b, lo, hi)


def solve_box_qp(w, u0, a, b, lo, hi, warm=()) -> QPResult:
    """One-shot ``argmin (u-u0)^T W (u-u0)`` s.t. ``a u >= b``, ``lo <= u <= hi``.

    ``w``: ``(m, m)`` weight ``W`` (symmetric positive definite); ``warm``: constraint indices
    to start from (``QPResult.active`` of a similar problem; invalid ones ignored). See
    :meth:`DenseQP.solve` for the other arguments; ``b`` must be finite.
    """
    u0, b, lo, hi = (np.asarray(v, dtype=float) for v in (u0, b, lo, hi))
    a = np.asarray(a, dtype=float).reshape(len(b), len(u0))
    return DenseQP(w, len(b)).solve(u0, a, b, lo, hi, tuple(warm))
