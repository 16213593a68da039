"""The safety filter's :class:`~.result.FilterResult`, built from an input and the rows.

Every path of ``SafetyFilter.filter`` but the fast path (:mod:`.fast_path`, which builds its
own results) ends here: :func:`make_result` for an answered input,
:func:`failsafe_result` for the FAILSAFE brake input. ``terms``, ``G``, ``c0`` are the rows
``G u + c0 >= 0`` the answer was computed for (``rows``); ``cur`` the call's limits; ``t0``
the start of the call (``time.perf_counter``).
"""

from __future__ import annotations

import time

import numpy as np

from .filter_inputs import Bounds
from .result import FilterResult, FilterStatus
from .rows import ACTIVE_TOL, Terms

__all__ = ["failsafe_result", "make_result"]


def make_result(
    u, status, terms: Terms, G, c0, cur: Bounds, solver, t0, message="", norms=None
) -> FilterResult:
    """The result for the input ``u`` (``norms``: ``||G_i||`` if known).

    Raises ``FloatingPointError`` if ``u`` is not finite (the filter then fails safe).
    """
    if not np.isfinite(u).all():
        raise FloatingPointError("non-finite filtered input")  # -> FAILSAFE
    con = c0 + G @ u
    if status is FilterStatus.INACTIVE:
        active = np.zeros(con.shape, dtype=bool)
    else:
        if norms is None:
            norms = np.sqrt(np.einsum("ij,ij->i", G, G))
        active = con <= ACTIVE_TOL * np.maximum(norms, 1.0)
    bounds = (u <= cur.lo) | (u >= cur.hi)
    return FilterResult(
        u_safe=u,
        status=status,
        h=terms.h,
        constraint=con,
        slack=np.maximum(-con, 0.0),
        active=active,
        bounds_active=bounds,
        solver=solver,
        solve_time=time.perf_counter() - t0,
        message=message,
        clearance=terms.gap,
    )


def failsafe_result(
    u, n, cur: Bounds, t0, message, terms: Terms | None = None, G=None, c0=None
) -> FilterResult:
    """FAILSAFE with the brake input ``u`` for ``n`` obstacles (zeros where no rows)."""
    u = np.where(np.isfinite(u), u, np.clip(0.0, cur.lo, cur.hi))
    if terms is None or G is None or c0 is None:
        h = con = gap = np.zeros(n)
    else:
        h = np.nan_to_num(terms.h)
        con = np.nan_to_num(c0 + G @ u)
        gap = np.nan_to_num(terms.gap)
    return FilterResult(
        u_safe=u,
        status=FilterStatus.FAILSAFE,
        h=h,
        constraint=con,
        slack=np.maximum(-con, 0.0),
        active=np.zeros(n, dtype=bool),
        bounds_active=(u <= cur.lo) | (u >= cur.hi),
        solver="none",
        solve_time=time.perf_counter() - t0,
        message=message,
        clearance=gap,
    )
