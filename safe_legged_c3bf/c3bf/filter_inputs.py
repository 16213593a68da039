"""Validation of the safety filter's per-call inputs and its weight and limits.

Everything is checked before any work (see ``domain``) and reported as
:class:`~.errors.InvalidInputError` naming the argument, entry and value. The checks on the
per-call path use Python floats (``m``, ``n_x`` <= 7): cheaper than numpy reductions.
"""

from __future__ import annotations

import math
import sys
from typing import NamedTuple

import numpy as np

from .domain import MAX_MAGNITUDE, bad_entry, checked
from .errors import InvalidInputError

__all__ = ["FLOAT_MAX", "Bounds", "check_bounds", "check_weights", "check_yaw", "vector"]

FLOAT_MAX = sys.float_info.max
"""Limit for ``vector`` of a reference (finite; its bound is relative, ``REF_RATIO_MAX``)."""


def vector(value, n: int, name: str, limit: float = MAX_MAGNITUDE):
    """``(array, list, size)`` of a ``(n,)`` input, entries finite with ``|x| <= limit``.

    ``size`` is ``||x||_2`` (between ``max |x_i|`` and ``sqrt(n)`` times it). One C-level
    ``hypot`` (overflow-safe; NaN/inf propagate) when all is well.
    """
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} is not a numeric array: {exc}") from exc
    if a.shape != (n,):
        raise InvalidInputError(f"{name} must have shape ({n},), got {a.shape}")
    lst = a.tolist()
    size = math.hypot(*lst)
    if not size <= limit:  # NaN, inf, or some entry possibly beyond the limit
        problem = bad_entry(name, a, limit)
        if problem:
            raise InvalidInputError(problem)
        size = max(map(abs, lst))
    return a, lst, size


class Bounds(NamedTuple):
    """Validated input limits, as arrays and as lists of floats."""

    lo: np.ndarray
    hi: np.ndarray
    lo_l: list
    hi_l: list
    finite: bool  # every limit finite

    @property
    def scale(self) -> float:
        """Input scale ``1 + max |finite limit|`` (see ``domain.REF_RATIO_MAX``)."""
        return 1.0 + max((abs(v) for v in self.lo_l + self.hi_l if math.isfinite(v)), default=0.0)


def check_weights(weights, m: int) -> np.ndarray:
    """``W`` from None (identity), ``(m,)`` (diagonal) or ``(m, m)`` (SPD, in the domain)."""
    if weights is None:
        return np.eye(m)
    w = checked("weights", weights)
    if w.shape == (m,):
        w = np.diag(w)
    if w.shape != (m, m) or not np.allclose(w, w.T):
        raise InvalidInputError(f"weights must be (m,) or symmetric (m, m), m={m}")
    try:
        np.linalg.cholesky(w)
    except np.linalg.LinAlgError as exc:
        raise InvalidInputError("weights must be positive definite") from exc
    return w


def check_bounds(u_min, u_max, m: int) -> Bounds:
    """Limits ``(m,)`` (None: open): no NaN, ``u_min <= u_max``, finite ones ``|x| <= 1e9``."""
    try:
        lo = np.full(m, -np.inf) if u_min is None else np.array(u_min, dtype=float)
        hi = np.full(m, np.inf) if u_max is None else np.array(u_max, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"u_min/u_max are not numeric: {exc}") from exc
    if lo.shape != (m,) or hi.shape != (m,):
        raise InvalidInputError(f"u_min/u_max must have shape ({m},) and no NaN")
    # Element-wise checks on Python floats (m is tiny): NaN, order, no +inf lower/-inf upper.
    lo_l, hi_l = lo.tolist(), hi.tolist()
    for a, b in zip(lo_l, hi_l, strict=True):
        if math.isnan(a) or math.isnan(b):
            raise InvalidInputError(f"u_min/u_max must have shape ({m},) and no NaN")
        if a > b or a == math.inf or b == -math.inf:
            raise InvalidInputError(f"need u_min <= u_max (finite or open), got {lo}, {hi}")
        if not (-MAX_MAGNITUDE <= a or a == -math.inf) or not (b <= MAX_MAGNITUDE or b == math.inf):
            raise InvalidInputError(
                f"finite input limits must be within +-{MAX_MAGNITUDE:.0e} (use inf for none), "
                f"got u_min={lo_l}, u_max={hi_l}"
            )
    lo.setflags(write=False)  # (solvers may recognise unchanged limits by identity)
    hi.setflags(write=False)
    return Bounds(lo, hi, lo_l, hi_l, all(map(math.isfinite, lo_l + hi_l)))


def check_yaw(model, yaw) -> float | None:
    """``float(yaw)`` [rad] for models that need it (finite, ``|yaw| <= 1e9``), else None."""
    if not model.needs_yaw:
        return None
    try:
        yaw = float(yaw)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{type(model).__name__} needs yaw=<float>") from exc
    if not abs(yaw) <= MAX_MAGNITUDE:  # False for NaN
        raise InvalidInputError(bad_entry("yaw", yaw))
    return yaw
