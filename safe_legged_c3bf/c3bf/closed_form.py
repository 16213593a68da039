"""The paper's closed-form C3BF-QP solution for one constraint.

:func:`cbf_closed_form` is the public, checked formula (no input limits). The safety
filter evaluates the same formula on its one row (``fast_path``) and answers with it only
when it is the exact optimum within the input limits.
"""

from __future__ import annotations

import numpy as np

from .domain import MAX_DERIVED, checked, checked_scalar
from .errors import InvalidInputError

__all__ = ["cbf_closed_form"]


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
