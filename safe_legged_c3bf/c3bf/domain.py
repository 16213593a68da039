"""The numbers the library accepts, and the error messages that name a bad one.

Domain: every number given to the library (states, yaw, obstacle centres, velocities, radii
and semi-axes, model offsets, filter parameters, finite input limits) is finite with
magnitude ``<= MAX_MAGNITUDE`` (1e9, SI units: 1e6 km, 1e9 m/s). Inside the domain no
intermediate of the barrier, its Lie derivatives or the filter overflows (the largest, ``Lf h``
of a fast spinning unicycle with a large offset, stays below ~1e60), so results are the
float evaluation of the documented formulas. Outside it the library raises
:class:`~.errors.InvalidInputError` naming the argument, the entry and its value, instead of
returning ``inf``/``nan`` or a number dominated by rounding.

The filter's reference input has its own, relative bound (:data:`REF_RATIO_MAX`).
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidInputError

__all__ = [
    "MAX_DERIVED", "MAX_MAGNITUDE", "REF_RATIO_MAX", "bad_entry", "checked", "checked_scalar",
    "far_reference_error",
]

MAX_MAGNITUDE = 1e9
"""Largest accepted magnitude of any input number (SI units)."""

MAX_DERIVED = 1e60
"""Largest accepted magnitude of a *derived* quantity passed to a public function:
relative positions and velocities (``c3bf_value`` ...), body-point kinematics
(``barrier_terms``), barrier terms (``cbf_closed_form``). Inputs in the domain yield at most
~1e27 (``l w^2`` at ``l = w = 1e9``); below 1e60 the barrier's largest intermediate,
``||v||^2 ||p|| / s_min`` with ``s_min = 1e-12``, stays below ~1e200."""

REF_RATIO_MAX = 1e3
"""Largest ``max_i |u_ref_i|`` the filter solves for, relative to the input scale
``1 + max |finite input limit|`` (1 when no limit is finite).

Why a bound: the optimum ``u* = argmin (u - u_ref)^T W (u - u_ref)`` lies within the limits,
but every exact method computes it from ``u_ref``. The active-set method works in
``d = u - u_ref``, which moves the limits and constraint values by about ``eps |u_ref|``
(``eps = 2.2e-16``; at ``|u_ref| = 1e17`` the limits ``+-2`` are lost altogether: the filter
used to answer 0 for the limit 2). OSQP's stopping tolerance is relative to
``|q| = |W u_ref|``: from ~1e4 x the scale its unpolished answers were off by 1e-4..1e-1
(measured against exact rational arithmetic). Up to ``1e3`` x the scale both are within
~1e-12 ``|u_ref|`` (<= ~1e-9 of the input scale) of the exact optimum. Clipping the
reference to the limits does not help in general: with a binding barrier constraint the
optimum for a far reference is not the optimum for its clip.

Beyond the bound the filter answers only where the answer is exact at any magnitude: the
reference itself when it satisfies every limit and constraint, or, for a diagonal ``W`` (the
W-projection onto the box is then the clip), the clipped reference when it satisfies every
barrier constraint (the projection onto the box lies in the smaller feasible set, so it is
the optimum over it). Otherwise it raises :class:`~.errors.InvalidInputError` naming the
entry.
"""


def bad_entry(name: str, values, limit: float = MAX_MAGNITUDE, positive: bool = False) -> str:
    """Message naming the first entry of ``values`` outside the domain (``''`` if none).

    ``"state[3] = 1e+300 is beyond the supported magnitude 1e+09"``, ``"center[0, 1] = nan
    is not finite"``, ``"radius[2] = -0.1 must be > 0"``.
    """
    a = np.asarray(values, dtype=float)
    flat = a.reshape(-1)
    bad = ~np.isfinite(flat) | (np.abs(flat) > limit)
    if positive:
        bad |= ~(flat > 0.0)
    if not bad.any():
        return ""
    i = int(np.flatnonzero(bad)[0])
    where = "" if a.ndim == 0 else "[" + ", ".join(map(str, np.unravel_index(i, a.shape))) + "]"
    v = float(flat[i])
    if not np.isfinite(v):
        why = "is not finite"
    elif abs(v) > limit:
        why = f"is beyond the supported magnitude {limit:.0e}"
    else:
        why = "must be > 0"
    return f"{name}{where} = {v!r} {why}"


def far_reference_error(u_ref: np.ndarray, scale: float) -> InvalidInputError:
    """The error for a far reference (see ``REF_RATIO_MAX``) whose clip is not the optimum.

    ``scale``: the input scale ``1 + max |finite limit|``; the message names the largest entry.
    """
    i = int(np.argmax(np.abs(u_ref)))
    return InvalidInputError(
        f"u_ref[{i}] = {float(u_ref[i])!r} is beyond {REF_RATIO_MAX:.0e} x the input scale "
        f"{scale:g} (1 + largest finite limit) and the optimum is not its clip to the "
        "limits: rounding would dominate the QP's answer; bring the reference within the "
        "bound"
    )


def checked(name: str, value, limit: float = MAX_MAGNITUDE, positive: bool = False) -> np.ndarray:
    """``value`` as a float array, every entry finite with ``|x| <= limit`` (``> 0`` if asked).

    One vectorised test when all is well; else :class:`InvalidInputError` naming the entry.
    """
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} is not a numeric array: {exc}") from exc
    ok = np.abs(a) <= limit  # False for NaN
    if positive:
        ok &= a > 0.0
    if not ok.all():
        raise InvalidInputError(bad_entry(name, a, limit, positive))
    return a


def checked_scalar(
    name: str, value, low: float = -MAX_MAGNITUDE, high: float = MAX_MAGNITUDE,
    low_open: bool = False,
) -> float:
    """``float(value)`` if finite and in ``[low, high]`` (``(low, high]`` if ``low_open``).

    Raises :class:`InvalidInputError` naming the parameter and its value otherwise.
    """
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be a number, got {value!r}") from exc
    if not (low < v <= high if low_open else low <= v <= high):  # False for NaN
        bracket = "(" if low_open else "["
        raise InvalidInputError(f"{name} = {v!r} must be finite and in {bracket}{low:g}, {high:g}]")
    return v
