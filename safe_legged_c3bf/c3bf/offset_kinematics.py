r"""Kinematics of body points at fixed offsets in the robot's base frame, for every model.

A whole-body filter protects several points of a rigid body (``body``). Point ``k`` sits at
``(lx, ly, lz)`` [m] in the base frame (REP-103: x forward, y left, z up) of the model's
reference point ``(x, y[, z])``; the yaw ``theta`` turns ``(lx, ly)`` into odom:

.. math::  P = (x + l_x c - l_y s,\; y + l_x s + l_y c,\; z + l_z),
           \quad c = \cos\theta,\; s = \sin\theta .

Hand-derived, per model (``v`` forward speed, ``w`` yaw rate, ``e = (l_x c - l_y s,
l_x s + l_y c)`` the rotated offset and ``e^\perp = (-(l_x s + l_y c), l_x c - l_y s)``):

* unicycle (``UnicycleModel``, ``UnicycleHeightModel``): ``V = v (c, s) + w e^\perp``,
  ``dV/dt = a (c, s) + alpha e^\perp + v w (-s, c) - w^2 e``: drift ``v w (-s, c) - w^2 e``,
  input columns ``(c, s)`` for ``a`` and ``e^\perp`` for ``alpha``. With ``l_y = 0`` this is the
  paper's body point of offset ``l_x`` (``models.UnicycleModel``).
* unicycle with lateral speed (``lateral_models``): as the unicycle, plus ``v_l (-s, c)`` in
  ``V``, ``-w v_l (c, s)`` in the drift and the input column ``(-s, c)`` for ``a_l``.
* holonomic (``HolonomicModel``, ``HolonomicHeightModel``): the yaw is a parameter held
  constant over a filter step, so the offset is a constant shift: ``V = (vx, vy)``, no drift,
  ``B = R(theta)``; no steering authority (the yaw rate is not in the model).
* x-z double integrator (``XZDoubleIntegratorModel``, yaw ~ 0 as in the paper): ``P = (x +
  l_x, 0, z + l_z)``, ``V = (vx, 0, vz)``.

The vertical coordinate of a height model moves every point with the base (``vz``, ``a_z``):
a crouch lowers the whole body cover (see ``body``). Pure planar models ignore ``l_z`` (x-y
models put every point at z = 0; the x-z model at y = 0). The model's own ``offset`` is not
used here: the body points carry their offsets. ``test/test_c3bf_body.py`` checks ``V = dP/dt``
and ``dV/dt = a_drift + B u`` against central finite differences of ``f`` and ``g``.
"""

from __future__ import annotations

import numpy as np

from .lateral_models import UnicycleLateralHeightModel, UnicycleLateralModel
from .models import (
    HolonomicHeightModel,
    HolonomicModel,
    PointKinematics,
    RobotModel,
    UnicycleHeightModel,
    UnicycleModel,
    XZDoubleIntegratorModel,
)

__all__ = ["offset_point_kinematics"]


def _unicycle(x, offsets, height: bool, lateral: bool = False):
    """Offset points of a unicycle (``height``: state has ``z, vz`` at indices 5, 6).

    ``lateral`` (``lateral_models``): the state's last entry is the side-step speed ``v_l``,
    which adds ``v_l (-s, c)`` to ``V`` and ``-w v_l (c, s)`` to the drift, and the last input
    ``a_l`` has the column ``(-s, c)``.
    """
    th, v, w = x[2], x[3], x[4]
    c, s = np.cos(th), np.sin(th)
    lx, ly, lz = offsets[:, 0], offsets[:, 1], offsets[:, 2]
    ex, ey = lx * c - ly * s, lx * s + ly * c  # rotated offset e
    k = len(offsets)
    m = (3 if height else 2) + int(lateral)
    vl = x[-1] if lateral else 0.0
    P = np.empty((k, 3))
    V = np.zeros((k, 3))
    A = np.zeros((k, 3))
    B = np.zeros((k, 3, m))
    P[:, 0], P[:, 1] = x[0] + ex, x[1] + ey
    P[:, 2] = x[5] + lz if height else 0.0
    V[:, 0], V[:, 1] = v * c - vl * s - w * ey, v * s + vl * c + w * ex
    A[:, 0] = -v * w * s - w * vl * c - w * w * ex
    A[:, 1] = v * w * c - w * vl * s - w * w * ey
    B[:, 0, 0], B[:, 1, 0] = c, s
    B[:, 0, 1], B[:, 1, 1] = -ey, ex
    if height:
        V[:, 2] = x[6]
        B[:, 2, 2] = 1.0
    if lateral:
        B[:, 0, -1], B[:, 1, -1] = -s, c
    return P, V, A, B


def _holonomic(x, yaw, offsets, height: bool):
    """Offset points of a holonomic model (``height``: ``z, vz`` at indices 4, 5)."""
    c, s = np.cos(yaw), np.sin(yaw)
    lx, ly, lz = offsets[:, 0], offsets[:, 1], offsets[:, 2]
    k = len(offsets)
    m = 3 if height else 2
    P = np.empty((k, 3))
    V = np.zeros((k, 3))
    B = np.zeros((k, 3, m))
    P[:, 0], P[:, 1] = x[0] + lx * c - ly * s, x[1] + lx * s + ly * c
    P[:, 2] = x[4] + lz if height else 0.0
    V[:, 0], V[:, 1] = x[2], x[3]
    B[:, 0, 0], B[:, 0, 1], B[:, 1, 0], B[:, 1, 1] = c, -s, s, c
    if height:
        V[:, 2] = x[5]
        B[:, 2, 2] = 1.0
    return P, V, np.zeros((k, 3)), B


def _xz(x, offsets):
    """Offset points of the x-z double integrator (yaw ~ 0: ``l_x`` along odom x)."""
    k = len(offsets)
    P = np.zeros((k, 3))
    V = np.zeros((k, 3))
    B = np.zeros((k, 3, 2))
    P[:, 0], P[:, 2] = x[0] + offsets[:, 0], x[1] + offsets[:, 2]
    V[:, 0], V[:, 2] = x[2], x[3]
    B[:, 0, 0], B[:, 2, 1] = 1.0, 1.0
    return P, V, np.zeros((k, 3)), B


def offset_point_kinematics(model: RobotModel, x, offsets, yaw=None) -> PointKinematics:
    """Kinematics of ``k`` body points at base-frame ``offsets`` ``(k, 3)`` [m] (one state).

    Args:
        model: One of the five models of ``models`` or the two of ``lateral_models``
            (exact type).
        x: ``(n_x,)`` state, validated by the caller (the filter).
        offsets: ``(k, 3)`` base-frame offsets ``(l_x, l_y, l_z)`` [m].
        yaw: Yaw [rad] for the holonomic models (a parameter there).

    Returns:
        :class:`~.models.PointKinematics` with arrays ``(k, 3)`` and ``(k, 3, m)`` (odom).

    """
    x = np.asarray(x, dtype=float)
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 3)
    kind = type(model)
    if kind is UnicycleHeightModel or kind is UnicycleModel:
        parts = _unicycle(x, offsets, kind is UnicycleHeightModel)
    elif kind is UnicycleLateralHeightModel or kind is UnicycleLateralModel:
        parts = _unicycle(x, offsets, kind is UnicycleLateralHeightModel, lateral=True)
    elif kind is HolonomicHeightModel or kind is HolonomicModel:
        parts = _holonomic(x, float(yaw), offsets, kind is HolonomicHeightModel)
    elif kind is XZDoubleIntegratorModel:
        parts = _xz(x, offsets)
    else:
        raise TypeError(f"no offset-point kinematics for {kind.__name__}")
    return PointKinematics(*parts)
