r"""Unicycle models with a lateral (side-step) velocity: legged robots walk sideways too.

The paper's unicycle can only leave a collision cone by braking or turning. A legged robot
can also side-step (the A1's gait controller takes up to 0.5 m/s sideways, the biped's
0.08 m/s), so these models add a body-frame lateral speed ``v_l`` (REP-103: +y, left) and
its rate ``a_l`` to the unicycle, keeping the unicycle's state and input order first:

===============================  ====================================  ====================
class                            state                                 input
===============================  ====================================  ====================
``UnicycleLateralModel``         x, y, theta, v, omega, v_l            a, alpha, a_l
``UnicycleLateralHeightModel``   x, y, theta, v, omega, z, vz, v_l     a, alpha, a_z, a_l
===============================  ====================================  ====================

With ``c, s = cos(theta), sin(theta)``, the body-frame velocity ``(v, v_l)`` turned into odom
and the body point ``l = offset`` ahead (``e = l (c, s)``, ``e_perp = l (-s, c)``)::

    x_dot = v c - v_l s,   y_dot = v s + v_l c,   theta_dot = omega,
    v_dot = a,   omega_dot = alpha,   v_l_dot = a_l   (z_dot = vz, vz_dot = a_z)

    P = (x, y) + e
    V = (v c - v_l s, v s + v_l c) + omega e_perp
    dV/dt = a (c, s) + a_l (-s, c) + alpha e_perp
            + omega (-v s - v_l c, v c - v_l s) - omega^2 e

Derived by hand (the derivative of ``R(theta) (v, v_l)`` is ``R(theta) (a, a_l) + omega
R(theta) (-v_l, v)``; the offset term is the unicycle's); with ``v_l = 0`` and ``a_l`` unused
they are the unicycle models exactly. ``test/test_c3bf_lie.py`` and ``test/test_c3bf_body.py``
check every Lie derivative against finite differences of ``f`` and ``g``. Units: m, s, rad;
odom frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .domain import checked_scalar
from .geometry import Plane
from .models import RobotModel, _offset, _state

__all__ = ["UnicycleLateralHeightModel", "UnicycleLateralModel"]


def _planar_kin(px, py, th, v, w, vl, l, cos, sin):  # noqa: ANN001, E741 - the paper's l
    """``(P_xy, V_xy, A_xy, columns of a, alpha, a_l)`` of the body point (module docstring)."""
    c, s = cos(th), sin(th)
    ex, ey = l * c, l * s
    P = (px + ex, py + ey)
    V = (v * c - vl * s - w * ey, v * s + vl * c + w * ex)
    A = (w * (-v * s - vl * c) - w * w * ex, w * (v * c - vl * s) - w * w * ey)
    return P, V, A, ((c, s), (-ey, ex), (-s, c))


@dataclass(frozen=True)
class _LateralUnicycle(RobotModel):
    """Both lateral models; the subclasses give the state layout (``_HEIGHT``, ``_DRIVEN``).

    Attributes:
        offset: Body-point offset ``l`` [m] ahead along the heading.

    """

    offset: float = 0.0

    #: The state has ``z, vz`` at indices 5, 6 (``v_l`` is always the last entry).
    _HEIGHT: ClassVar[bool] = False
    #: State index each input drives, in input order.
    _DRIVEN: ClassVar[tuple[int, ...]] = ()

    def __post_init__(self) -> None:
        """Validate the offset (finite, ``|l| <= 1e9`` m)."""
        _offset(self)

    def f(self, x, yaw=None):
        """Drift ``(v c - v_l s, v s + v_l c, omega, 0, 0[, vz, 0], 0)``."""
        x = _state(x, self.n_x)
        th, v, w, vl = x[..., 2], x[..., 3], x[..., 4], x[..., -1]
        c, s = np.cos(th), np.sin(th)
        z = np.zeros_like(v)
        height = [x[..., 6], z] if self._HEIGHT else []
        return np.stack([v * c - vl * s, v * s + vl * c, w, z, z, *height, z], axis=-1)

    def g(self, x, yaw=None):
        """Each input drives its own velocity state (``_DRIVEN``)."""
        x = _state(x, self.n_x)
        G = np.zeros(x.shape[:-1] + (self.n_x, self.n_u))
        for j, i in enumerate(self._DRIVEN):
            G[..., i, j] = 1.0
        return G

    def _kin(self, xs, yaw, cos, sin):
        """Body point (module docstring); at height ``z`` with ``V_z = vz`` when it has one."""
        P, V, A, (ca, cw, cl) = _planar_kin(xs[0], xs[1], xs[2], xs[3], xs[4], xs[-1],
                                            self.offset, cos, sin)
        if self._HEIGHT:
            B = ((ca[0], cw[0], 0.0, cl[0]), (ca[1], cw[1], 0.0, cl[1]), (0.0, 0.0, 1.0, 0.0))
            return (*P, xs[5]), (*V, xs[6]), (*A, 0.0), B
        B = ((ca[0], cw[0], cl[0]), (ca[1], cw[1], cl[1]), (0.0, 0.0, 0.0))
        return (*P, 0.0), (*V, 0.0), (*A, 0.0), B

    def brake_input(self, x, yaw=None, gain=2.0):
        """``-gain`` times every velocity an input drives, in input order."""
        gain = checked_scalar("gain", gain, 0.0)
        x = _state(x, self.n_x)
        return -gain * x[..., list(self._DRIVEN)]


@dataclass(frozen=True)
class UnicycleLateralModel(_LateralUnicycle):
    """Unicycle with a lateral body-frame speed (x-y plane, vertical obstacles).

    State ``(x, y, theta, v, omega, v_l)`` [m, m, rad, m/s, rad/s, m/s]; input
    ``(a, alpha, a_l)`` [m/s^2, rad/s^2, m/s^2]. Body point ``l = offset`` [m] ahead.
    """

    state_names: ClassVar[tuple[str, ...]] = ("x", "y", "theta", "v", "omega", "v_l")
    input_names: ClassVar[tuple[str, ...]] = ("a", "alpha", "a_l")
    planes: ClassVar[frozenset[Plane]] = frozenset({Plane.VERTICAL})
    _DRIVEN: ClassVar[tuple[int, ...]] = (3, 4, 5)


@dataclass(frozen=True)
class UnicycleLateralHeightModel(_LateralUnicycle):
    """Unicycle with a lateral speed plus a vertical axis, for x-y and x-z obstacles.

    State ``(x, y, theta, v, omega, z, vz, v_l)``; input ``(a, alpha, a_z, a_l)``: the
    :class:`~.models.UnicycleHeightModel`'s with the lateral speed and its rate appended.
    Body point ``(P_xy, z)`` with ``P_xy`` of the module docstring, ``V_z = vz``.
    """

    state_names: ClassVar[tuple[str, ...]] = ("x", "y", "theta", "v", "omega", "z", "vz", "v_l")
    input_names: ClassVar[tuple[str, ...]] = ("a", "alpha", "a_z", "a_l")
    planes: ClassVar[frozenset[Plane]] = frozenset({Plane.VERTICAL, Plane.HORIZONTAL})
    _HEIGHT: ClassVar[bool] = True
    _DRIVEN: ClassVar[tuple[int, ...]] = (3, 4, 6, 7)
