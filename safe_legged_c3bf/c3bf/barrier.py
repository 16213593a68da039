r"""The collision-cone barrier function and its partial derivatives.

For a relative position ``p = p_rel = c - P`` (obstacle centre minus robot body point) and a
relative velocity ``v = v_rel = c_dot - V`` in one plane, and an inflated radius ``r``, the
paper's collision-cone CBF is

.. math::  h(p, v) = \langle p, v\rangle + \|v\|\,\sqrt{\|p\|^2 - r^2},

which is ``>= 0`` exactly when ``v`` does not point into the cone of directions from the
robot that hit the circle of radius ``r`` around the obstacle.

Degenerate relative speed (``||v|| -> 0``)
------------------------------------------
``||v||`` is not differentiable at ``v = 0`` (the gradient of ``h`` w.r.t. ``v`` jumps there).
Below a small speed ``eps`` we replace it by a smooth, *conservative* blend: with
``rho = ||v||`` and ``t = rho / eps``,

.. math::  n_\varepsilon(\rho) = \begin{cases}
               \rho & \rho \ge \varepsilon \\
               \varepsilon\,(\tfrac{15}{8} t^2 - \tfrac{5}{4} t^4 + \tfrac{3}{8} t^6)
               & \rho < \varepsilon \end{cases}

The polynomial matches ``rho`` with value, first and second derivative at ``rho = eps``
(so ``h`` is C2), is even in ``rho`` (smooth at ``v = 0``, ``grad n = 0`` there), increasing,
and ``n_eps <= rho`` (``t - n/eps >= 0`` on ``[0, 1]``, a triple zero at ``t = 1``).
Hence, with ``s = sqrt(||p||^2 - r^2)`` and ``h_eps = <p, v> + n_eps(v) s``:

* ``h_eps == h`` (the paper's barrier, exactly) whenever ``||v_rel|| >= eps``;
* ``h_eps <= h`` everywhere (the safe set ``{h_eps >= 0}`` is inside the paper's: never less
  safe), by at most ``0.15 eps s``;
* at ``v = 0``: ``h_eps = 0`` (like ``h``) and ``dh/dv = p`` (non-zero), so the constraint
  stays well defined and the filter output finite.

``eps = 0`` gives the paper's exact ``h`` (with the sub-gradient ``dn/dv = 0`` at ``v = 0``).

Partial derivatives (``dn/dv = k(rho) v``, ``k = 1/rho`` above ``eps``,
``k = (15/4 - 5 t^2 + 9/4 t^4) / eps`` below)::

    dh/dp = v + n_eps(v) * p / s
    dh/dv = p + s * k * v

All functions are vectorised over leading dimensions (last axis = the 2 in-plane coordinates).
Accuracy: a few ulps of the terms' magnitudes (``|p| |v|``, ``n_eps s``); for vectors below
~1e-154 (where ``||p||^2``, ``||v||^2`` are subnormal) an absolute error up to ~1e-161 times
the other vector's norm as well.
The public ones validate their inputs (finite, ``|x| <= domain.MAX_DERIVED``, radius > 0,
``v_eps`` in ``[0, 1e9]``) and raise :class:`~.errors.InvalidInputError` naming the bad entry;
The Lie derivatives (``lie.cone_rows``, every path of the filter) use the same formulas in
inner-product form.
"""

from __future__ import annotations

import numpy as np

from .domain import MAX_DERIVED, checked, checked_scalar

__all__ = [
    "DEFAULT_V_EPS",
    "c3bf_gradient",
    "c3bf_value",
    "regularized_speed",
]

DEFAULT_V_EPS = 0.05
"""Default relative speed ``eps`` [m/s] below which ``||v_rel||`` is regularised."""


def _speed_terms(vv, v_eps):
    """``(n_eps, k)`` from ``vv = ||v||^2``: regularised speed and ``dn/dv = k v``."""
    rho = np.sqrt(vv)
    if v_eps > 0.0:
        u = np.minimum(vv / (v_eps * v_eps), 1.0)  # t^2 (capped: the blend is unused above)
        small = u < 1.0
        n = np.where(small, v_eps * u * (1.875 + u * (-1.25 + 0.375 * u)), rho)
        k_small = (3.75 + u * (-5.0 + 2.25 * u)) / v_eps
        k = np.where(small, k_small, 1.0 / np.where(small, 1.0, rho))
    else:
        n = rho
        k = np.where(rho > 0.0, 1.0 / np.where(rho > 0.0, rho, 1.0), 0.0)
    return n, k


def _checked(p_rel, v_rel, radius, v_eps):
    """Validated float arrays ``(p, v, r)`` and ``v_eps`` of the public functions."""
    p = checked("p_rel", p_rel, MAX_DERIVED) if p_rel is not None else None
    v = checked("v_rel", v_rel, MAX_DERIVED)
    r = checked("radius", radius, MAX_DERIVED, positive=True) if radius is not None else None
    return p, v, r, checked_scalar("v_eps", v_eps, 0.0)


def regularized_speed(v_rel, v_eps: float = DEFAULT_V_EPS):
    """Return ``n_eps(v)`` over the last axis: ``||v||`` above ``eps``, smooth blend below."""
    _, v, _, v_eps = _checked(None, v_rel, None, v_eps)
    return _speed_terms((v * v).sum(-1), v_eps)[0]


def c3bf_value(p_rel, v_rel, radius, v_eps: float = DEFAULT_V_EPS):
    """Collision-cone barrier ``h`` [m^2/s] for relative position [m] and velocity [m/s].

    Args:
        p_rel: ``(..., 2)`` obstacle centre minus robot body point, in-plane, odom frame [m].
        v_rel: ``(..., 2)`` obstacle velocity minus body-point velocity [m/s].
        radius: ``(...)`` inflated radius ``r`` [m].
        v_eps: Relative-speed regularisation [m/s] (see module docstring).

    Returns:
        ``(...)`` array of ``h``. Where ``||p|| <= r`` (inside the inflated circle) the square
        root is clamped to 0, so the value stays finite; the filter treats that case as an
        emergency and never uses it as a constraint.

    """
    p, v, r, v_eps = _checked(p_rel, v_rel, radius, v_eps)
    s = np.sqrt(np.maximum((p * p).sum(-1) - r * r, 0.0))
    return (p * v).sum(-1) + _speed_terms((v * v).sum(-1), v_eps)[0] * s


def c3bf_gradient(p_rel, v_rel, radius, v_eps: float = DEFAULT_V_EPS, s_min: float = 1e-12):
    """Return ``(h, dh/dp_rel, dh/dv_rel, s)`` for the collision-cone barrier.

    Args:
        p_rel: ``(..., 2)`` relative position [m] (obstacle minus robot body point).
        v_rel: ``(..., 2)`` relative velocity [m/s].
        radius: ``(...)`` inflated radius [m].
        v_eps: Relative-speed regularisation [m/s].
        s_min: Lower clamp of ``s = sqrt(||p||^2 - r^2)`` [m] in the ``p / s`` term, so the
            gradient stays finite (but huge) on or inside the circle; in ``[1e-12, 1]``.
            Where ``s < s_min`` the returned ``dh/dp`` is therefore not the derivative.

    Returns:
        ``h`` ``(...)`` [m^2/s], ``dh/dp`` ``(..., 2)`` [m/s], ``dh/dv`` ``(..., 2)`` [m] and
        ``s`` ``(...)`` [m] (0 where ``||p|| <= r``).

    """
    p, v, r, v_eps = _checked(p_rel, v_rel, radius, v_eps)
    s_min = checked_scalar("s_min", s_min, 1e-12, 1.0)
    return _gradient(p, v, r, v_eps, s_min)


def _gradient(p, v, r, v_eps, s_min=1e-12):
    """Unchecked :func:`c3bf_gradient` on float arrays (for ``barrier_terms``, the filter)."""
    s = np.sqrt(np.maximum((p * p).sum(-1) - r * r, 0.0))
    nv, k = _speed_terms((v * v).sum(-1), v_eps)
    h = (p * v).sum(-1) + nv * s
    dh_dp = v + (nv / np.maximum(s, s_min))[..., None] * p
    dh_dv = p + (s * k)[..., None] * v
    return h, dh_dp, dh_dv, s
