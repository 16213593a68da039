"""The paper's closed-form C3BF-QP solution for one constraint.

:func:`cbf_closed_form` is the public, checked formula (no input limits).
:func:`one_obstacle` is the safety filter's fast path for one obstacle: the same formula on
Python floats, answered only when it is the exact optimum within the input limits.
"""

from __future__ import annotations

import math
import time
from operator import ge, le, mul, or_

import numpy as np

from .domain import MAX_DERIVED, checked, checked_scalar
from .errors import InvalidInputError
from .filter_inputs import Bounds
from .geometry import Obstacles
from .inside import INSIDE_REL_CLEARANCE
from .lie import barrier_terms_scalar
from .result import FilterResult, FilterStatus
from .rows import ACTIVE_TOL, ROW_ZERO

__all__ = ["cbf_closed_form", "one_obstacle"]


def cbf_closed_form(lg_h, lf_h, h, u_ref, gamma: float = 1.0, w_inv=None) -> np.ndarray:
    """Closed-form minimiser of ``(u-u_ref)^T W (u-u_ref)`` s.t. ``Lf h + Lg h u + gamma h >= 0``.

    The paper's KKT solution generalised to a weight ``W`` (input bounds are ignored)::

        psi = Lf h + Lg h u_ref + gamma h
        u   = u_ref                                     if psi >= 0
        u   = u_ref - W^-1 Lg h^T psi / (Lg h W^-1 Lg h^T)   otherwise

    (evaluated with ``Lg h`` scaled to unit max-norm, so the denominator cannot underflow).

    Args:
        lg_h: ``(m,)`` ``Lg h``.
        lf_h: ``Lf h`` (scalar).
        h: Barrier value (scalar).
        u_ref: ``(m,)`` reference input.
        gamma: Class-K gain ``gamma`` [1/s], ``>= 0``.
        w_inv: ``(m, m)`` inverse weight ``W^-1``, positive definite (identity if None).

    Returns:
        ``(m,)`` safe input. If ``Lg h = 0`` the constraint cannot be influenced and ``u_ref``
        is returned.

    Raises:
        InvalidInputError: a number not finite or beyond ``domain.MAX_DERIVED``, mismatched
            shapes, ``w_inv`` not positive definite, or an answer beyond the float range.

    """
    a = checked("lg_h", lg_h, MAX_DERIVED)
    u0 = checked("u_ref", u_ref, MAX_DERIVED)
    if a.ndim != 1 or u0.shape != a.shape:
        raise InvalidInputError(f"lg_h and u_ref must have one shape (m,): {a.shape}, {u0.shape}")
    lf = checked_scalar("lf_h", lf_h, -MAX_DERIVED, MAX_DERIVED)
    hv = checked_scalar("h", h, -MAX_DERIVED, MAX_DERIVED)
    gamma = checked_scalar("gamma", gamma, 0.0)
    psi = lf + float(a @ u0) + gamma * hv
    amax = float(np.abs(a).max(initial=0.0))
    if psi >= 0.0 or amax == 0.0:
        return u0.copy()
    an = a / amax
    if w_inv is None:
        wa = an
    else:
        wi = checked("w_inv", w_inv, MAX_DERIVED)
        if wi.shape != (a.size, a.size):
            raise InvalidInputError(f"w_inv must have shape ({a.size}, {a.size}), got {wi.shape}")
        wa = wi @ an
    den = float(an @ wa)
    if not den > 0.0:
        raise InvalidInputError("w_inv must be positive definite (Lg h W^-1 Lg h^T <= 0)")
    u = u0 - wa * ((psi / amax) / den)
    if not np.isfinite(u).all():
        raise InvalidInputError(f"the closed form overflows (|psi / Lg h| = {psi / amax:.3g})")
    return u


def one_obstacle(
    kin, ul, obs: Obstacles, margin, gamma, v_eps, cur: Bounds, method, w_inv_l, t0
) -> FilterResult | None:
    """The filter's scalar fast path for one obstacle: INACTIVE or exact closed form, else None.

    ``kin``: body-point kinematics as tuples; ``ul``: ``u_ref`` as a list; ``cur``: the
    call's limits; ``w_inv_l``: ``W^-1`` as lists; ``t0``: start of the call
    (``perf_counter``). The other arguments are the :class:`~.filter.SafetyFilter`'s. None:
    inside the margin band or a circle, overflow, or the answer not the closed form within
    the limits; the general path answers.
    """
    (c,), (cv,), (r0,), (pl,) = obs.as_lists
    r = r0 + margin
    h, lf, lg, clearance = barrier_terms_scalar(kin, c[0], c[1], cv[0], cv[1], r, pl, v_eps)
    if not clearance > INSIDE_REL_CLEARANCE * r * r:
        return None  # inside the margin band / emergency (or NaN): general path
    c0 = lf + gamma * h
    psi = c0 + sum(map(mul, lg, ul))
    if not math.isfinite(psi):
        return None  # overflow: the general path fails safe
    lo_b, hi_b = cur.lo_l, cur.hi_l
    in_box = all(map(le, lo_b, ul)) and all(map(le, ul, hi_b))
    if in_box and psi >= 0.0:
        status, u, ulist, solver = FilterStatus.INACTIVE, np.array(ul), ul, "none"
    elif method == "auto" and psi < 0.0:
        wa = [sum(map(mul, row, lg)) for row in w_inv_l]
        den = sum(map(mul, lg, wa))
        if not den > ROW_ZERO**2 * (1.0 + abs(psi)):
            return None
        k = psi / den
        ulist = [v - k * w for v, w in zip(ul, wa, strict=True)]
        if not (all(map(le, lo_b, ulist)) and all(map(le, ulist, hi_b))):
            return None
        status, u, solver = FilterStatus.ACTIVE, np.array(ulist), "closed_form"
    else:
        return None
    con = c0 + sum(map(mul, lg, ulist))
    active = status is FilterStatus.ACTIVE and con * con <= ACTIVE_TOL**2 * max(
        sum(map(mul, lg, lg)), 1.0
    )
    vals = np.array([h, con, 0.0 if con >= 0.0 else -con, math.sqrt(clearance + r * r) - r0])
    flags = np.array([active, *map(or_, map(le, ulist, lo_b), map(ge, ulist, hi_b))])
    return FilterResult(
        u_safe=u,
        status=status,
        h=vals[0:1],
        constraint=vals[1:2],
        slack=vals[2:3],
        active=flags[0:1],
        bounds_active=flags[1:],
        solver=solver,
        solve_time=time.perf_counter() - t0,
        clearance=vals[3:4],
    )
