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
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "DEFAULT_V_EPS",
    "c3bf_gradient",
    "c3bf_gradient_scalar",
    "c3bf_value",
    "regularized_speed",
]

DEFAULT_V_EPS = 0.05
"""Default relative speed ``eps`` [m/s] below which ``||v_rel||`` is regularised."""


def _speed_terms(vv, v_eps):
    """``(n_eps, k)`` from ``vv = ||v||^2``: regularised speed and ``dn/dv = k v``."""
    rho = np.sqrt(vv)
    if v_eps > 0.0:
        u = vv / (v_eps * v_eps)  # t^2
        small = u < 1.0
        n = np.where(small, v_eps * u * (1.875 + u * (-1.25 + 0.375 * u)), rho)
        k_small = (3.75 + u * (-5.0 + 2.25 * u)) / v_eps
        k = np.where(small, k_small, 1.0 / np.where(small, 1.0, rho))
    else:
        n = rho
        k = np.where(rho > 0.0, 1.0 / np.where(rho > 0.0, rho, 1.0), 0.0)
    return n, k


def regularized_speed(v_rel, v_eps: float = DEFAULT_V_EPS):
    """Return ``n_eps(v)`` over the last axis: ``||v||`` above ``eps``, smooth blend below."""
    v = np.asarray(v_rel, dtype=float)
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
    p = np.asarray(p_rel, dtype=float)
    v = np.asarray(v_rel, dtype=float)
    r = np.asarray(radius, dtype=float)
    s = np.sqrt(np.maximum((p * p).sum(-1) - r * r, 0.0))
    return (p * v).sum(-1) + regularized_speed(v, v_eps) * s


def c3bf_gradient(p_rel, v_rel, radius, v_eps: float = DEFAULT_V_EPS, s_min: float = 1e-12):
    """Return ``(h, dh/dp_rel, dh/dv_rel, s)`` for the collision-cone barrier.

    Args:
        p_rel: ``(..., 2)`` relative position [m] (obstacle minus robot body point).
        v_rel: ``(..., 2)`` relative velocity [m/s].
        radius: ``(...)`` inflated radius [m].
        v_eps: Relative-speed regularisation [m/s].
        s_min: Lower clamp of ``s = sqrt(||p||^2 - r^2)`` [m] in the ``p / s`` term, so the
            gradient stays finite (but huge) on or inside the circle.

    Returns:
        ``h`` ``(...)`` [m^2/s], ``dh/dp`` ``(..., 2)`` [m/s], ``dh/dv`` ``(..., 2)`` [m] and
        ``s`` ``(...)`` [m] (0 where ``||p|| <= r``).

    """
    p = np.asarray(p_rel, dtype=float)
    v = np.asarray(v_rel, dtype=float)
    r = np.asarray(radius, dtype=float)
    s = np.sqrt(np.maximum((p * p).sum(-1) - r * r, 0.0))
    nv, k = _speed_terms((v * v).sum(-1), v_eps)
    h = (p * v).sum(-1) + nv * s
    dh_dp = v + (nv / np.maximum(s, s_min))[..., None] * p
    dh_dv = p + (s * k)[..., None] * v
    return h, dh_dp, dh_dv, s


def c3bf_gradient_scalar(px, py, vx, vy, r, v_eps=DEFAULT_V_EPS, s_min=1e-12):
    """Scalar (pure Python float) version of :func:`c3bf_gradient` for one obstacle.

    Returns:
        ``(h, dh_dpx, dh_dpy, dh_dvx, dh_dvy, s)`` as floats (same formulas and clamps).

    """
    s = math.sqrt(max(px * px + py * py - r * r, 0.0))
    vv = vx * vx + vy * vy
    ee = v_eps * v_eps
    if vv < ee:
        u = vv / ee
        nv = v_eps * u * (1.875 + u * (-1.25 + 0.375 * u))
        k = (3.75 + u * (-5.0 + 2.25 * u)) / v_eps
    else:
        nv = math.sqrt(vv)
        k = 1.0 / nv if nv > 0.0 else 0.0
    h = px * vx + py * vy + nv * s
    q = nv / max(s, s_min)
    ratio = s * k
    return h, vx + q * px, vy + q * py, px + ratio * vx, py + ratio * vy, s
