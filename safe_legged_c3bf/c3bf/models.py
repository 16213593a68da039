r"""Robot models: state layout, control-affine dynamics and body-point kinematics.

Every model is control affine, ``x_dot = f(x) + g(x) u``, in SI units and the odom frame
(REP-103: x forward, y left, z up; yaw ``theta`` counter-clockwise from odom x).

The barrier only needs the robot's *body point* ``P(x)`` (3-D, odom) and its derivatives:

* ``V(x) = dP/dx f(x)`` (the body-point velocity; ``dP/dx g(x) = 0``, i.e. the point has
  relative degree 2 w.r.t. every input);
* ``dV/dt = dV/dx (f + g u) = a_drift(x) + B(x) u``.

:meth:`RobotModel.point_kinematics` returns ``(P, V, a_drift, B)``. Each obstacle uses two of
the three coordinates (``Plane.VERTICAL``: x, y; ``Plane.HORIZONTAL``: x, z). Pure planar
models fill the unused coordinate with 0 (zero velocity, zero input rows) and reject
obstacles in the other plane.

Models
------
===========================  ============================  ===============  ========
class                        state                         input            planes
===========================  ============================  ===============  ========
``UnicycleModel``            x, y, theta, v, omega         a, alpha         x-y
``XZDoubleIntegratorModel``  x, z, vx, vz                  a, a_z           x-z
``HolonomicModel``           x, y, vx, vy                  a_x, a_y (body)  x-y
``UnicycleHeightModel``      x, y, theta, v, omega, z, vz  a, alpha, a_z    x-y, x-z
``HolonomicHeightModel``     x, y, vx, vy, z, vz           a_x, a_y, a_z    x-y, x-z
===========================  ============================  ===============  ========

``v`` is the forward speed [m/s] along the heading, ``omega`` the yaw rate [rad/s], ``a``
[m/s^2] and ``alpha`` [rad/s^2] their rates; ``vx, vy, vz`` are odom-frame velocities. The
holonomic models take body-frame accelerations ``(a_x, a_y)`` rotated into odom by the yaw
``theta``, which is a *given parameter* (argument ``yaw``, treated as constant over the
filter step), not a state.

The unicycle body point sits ``l = offset`` metres ahead of ``(x, y)`` along the heading
(paper eq. pos_ver/vel_ver); with ``l != 0`` the yaw acceleration ``alpha`` acts on the
body-point acceleration, which gives the filter a steering input.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from .domain import checked, checked_scalar
from .errors import InvalidInputError
from .geometry import Plane

__all__ = [
    "HolonomicHeightModel",
    "HolonomicModel",
    "PointKinematics",
    "RobotModel",
    "UnicycleHeightModel",
    "UnicycleModel",
    "XZDoubleIntegratorModel",
]


class PointKinematics(NamedTuple):
    """Body-point kinematics in the odom frame (leading batch dims allowed).

    The body-point acceleration is ``accel_drift + accel_input @ u``.
    """

    position: np.ndarray
    """``(..., 3)`` odom (x, y, z) of the body point [m]."""
    velocity: np.ndarray
    """``(..., 3)`` odom velocity of the body point [m/s]."""
    accel_drift: np.ndarray
    """``(..., 3)`` input-independent body-point acceleration [m/s^2]."""
    accel_input: np.ndarray
    """``(..., 3, m)`` input matrix of the body-point acceleration."""


def _state(x, n: int) -> np.ndarray:
    """``x`` as a float array with last dimension ``n``, every entry in the domain."""
    a = checked("state", x)
    if a.shape[-1:] != (n,):
        raise InvalidInputError(f"state must have last dimension {n}, got shape {a.shape}")
    return a


def _offset(model) -> None:
    """Validate a model's body-point offset ``l`` [m] (finite, ``|l| <= 1e9``)."""
    object.__setattr__(model, "offset", checked_scalar("offset", model.offset))


class RobotModel(ABC):
    """Abstract control-affine robot model with a body point (see module docstring)."""

    state_names: ClassVar[tuple[str, ...]]
    """Names of the state entries, in order."""
    input_names: ClassVar[tuple[str, ...]]
    """Names of the input entries, in order."""
    planes: ClassVar[frozenset[Plane]]
    """Obstacle planes this model supports."""
    needs_yaw: ClassVar[bool] = False
    """True if ``yaw`` must be passed (holonomic models: yaw is a parameter, not a state)."""

    @property
    def n_x(self) -> int:
        """State dimension."""
        return len(self.state_names)

    @property
    def n_u(self) -> int:
        """Input dimension."""
        return len(self.input_names)

    def _yaw(self, yaw):
        if not self.needs_yaw:
            return None
        if yaw is None:
            raise InvalidInputError(f"{type(self).__name__} needs the yaw angle (yaw=...)")
        return checked("yaw", yaw)

    @abstractmethod
    def f(self, x, yaw=None) -> np.ndarray:
        """Drift ``f(x)``, shape ``(..., n_x)``."""

    @abstractmethod
    def g(self, x, yaw=None) -> np.ndarray:
        """Input matrix ``g(x)``, shape ``(..., n_x, n_u)``."""

    @abstractmethod
    def _kin(self, xs, yaw, cos, sin):
        """Body-point kinematics as nested tuples ``(P, V, A, B)`` of components.

        ``xs`` is a sequence of the state components (floats or equally shaped arrays) and
        ``cos``/``sin`` the matching functions (``math`` or ``numpy``), so the formulas are
        written once and serve both the scalar fast path and the batched evaluation.
        """

    def point_kinematics(self, x, yaw=None) -> PointKinematics:
        """Body-point position, velocity, drift acceleration and input matrix (odom, SI).

        Args:
            x: ``(..., n_x)`` state(s).
            yaw: Yaw [rad] (scalar or ``(...)``) for models with ``needs_yaw``.

        Returns:
            :class:`PointKinematics` with arrays of shapes ``(..., 3)`` and ``(..., 3, m)``.

        """
        x = _state(x, self.n_x)
        shape = x.shape[:-1]
        th = self._yaw(yaw)
        if x.ndim == 1:  # single state: scalar formulas, then arrays
            th = None if th is None else float(th)
            P, V, A, B = self._kin(x.tolist(), th, math.cos, math.sin)
            return PointKinematics(np.array(P), np.array(V), np.array(A), np.array(B))
        if th is not None:
            th = np.broadcast_to(th, shape)
        P, V, A, B = self._kin([x[..., i] for i in range(self.n_x)], th, np.cos, np.sin)

        def col(items):
            return np.stack([np.broadcast_to(np.asarray(c, dtype=float), shape) for c in items], -1)

        return PointKinematics(col(P), col(V), col(A), np.stack([col(row) for row in B], -2))

    def point_kinematics_tuple(self, x: list[float], yaw: float | None = None) -> PointKinematics:
        """Scalar fast path of :meth:`point_kinematics`: ``x`` a list of floats, tuples out.

        No validation (the filter validates first); ``accel_input`` is a tuple of 3 rows.
        """
        return PointKinematics(*self._kin(x, yaw, math.cos, math.sin))

    @abstractmethod
    def brake_input(self, x, yaw=None, gain: float = 2.0) -> np.ndarray:
        """Input that drives every velocity state to zero at rate ``gain`` [1/s] (unclipped)."""


@dataclass(frozen=True)
class UnicycleModel(RobotModel):
    """Acceleration-controlled unicycle of the paper (vertical obstacles, x-y plane).

    State ``(x, y, theta, v, omega)`` [m, m, rad, m/s, rad/s]; input ``(a, alpha)``
    [m/s^2, rad/s^2]. ``f = (v cos th, v sin th, omega, 0, 0)``, ``g = [e_v, e_omega]``.
    Body point ``P = (x + l cos th, y + l sin th)``, ``V = (v cos th - l w sin th,
    v sin th + l w cos th)``.

    Attributes:
        offset: Body-point offset ``l`` [m] ahead of ``(x, y)`` along the heading.

    """

    offset: float = 0.0

    def __post_init__(self) -> None:
        """Validate the offset (finite, ``|l| <= 1e9`` m)."""
        _offset(self)

    state_names: ClassVar[tuple[str, ...]] = ("x", "y", "theta", "v", "omega")
    input_names: ClassVar[tuple[str, ...]] = ("a", "alpha")
    planes: ClassVar[frozenset[Plane]] = frozenset({Plane.VERTICAL})

    def f(self, x, yaw=None):
        """Drift (see class docstring)."""
        x = _state(x, 5)
        th, v, w = x[..., 2], x[..., 3], x[..., 4]
        z = np.zeros_like(v)
        return np.stack([v * np.cos(th), v * np.sin(th), w, z, z], axis=-1)

    def g(self, x, yaw=None):
        """Input matrix: ``a`` drives ``v``, ``alpha`` drives ``omega``."""
        x = _state(x, 5)
        G = np.zeros(x.shape[:-1] + (5, 2))
        G[..., 3, 0] = 1.0
        G[..., 4, 1] = 1.0
        return G

    def _kin(self, xs, yaw, cos, sin):
        """Body point; acceleration ``a_drift = (-v w s - l w^2 c, v w c - l w^2 s, 0)``."""
        px, py, th, v, w = xs[0], xs[1], xs[2], xs[3], xs[4]
        c, s = cos(th), sin(th)
        l = self.offset  # noqa: E741 - the paper's symbol
        P = (px + l * c, py + l * s, 0.0)
        V = (v * c - l * w * s, v * s + l * w * c, 0.0)
        A = (-v * w * s - l * w * w * c, v * w * c - l * w * w * s, 0.0)
        B = ((c, -l * s), (s, l * c), (0.0, 0.0))
        return P, V, A, B

    def brake_input(self, x, yaw=None, gain=2.0):
        """``(-gain v, -gain omega)``."""
        gain = checked_scalar("gain", gain, 0.0)
        x = _state(x, 5)
        return -gain * x[..., 3:5]


@dataclass(frozen=True)
class XZDoubleIntegratorModel(RobotModel):
    """Double integrator in the odom x-z plane of the paper (horizontal obstacles).

    State ``(x, z, vx, vz)`` [m, m, m/s, m/s]; input ``(a, a_z)`` [m/s^2] (forward and vertical
    acceleration; the paper assumes yaw ~ 0 so forward = odom x). Body point ``(x, z)``.
    """

    state_names: ClassVar[tuple[str, ...]] = ("x", "z", "vx", "vz")
    input_names: ClassVar[tuple[str, ...]] = ("a", "a_z")
    planes: ClassVar[frozenset[Plane]] = frozenset({Plane.HORIZONTAL})

    def f(self, x, yaw=None):
        """Drift ``(vx, vz, 0, 0)``."""
        x = _state(x, 4)
        return np.concatenate([x[..., 2:4], np.zeros_like(x[..., 2:4])], axis=-1)

    def g(self, x, yaw=None):
        """Input matrix ``[0; I]``."""
        x = _state(x, 4)
        G = np.zeros(x.shape[:-1] + (4, 2))
        G[..., 2, 0] = 1.0
        G[..., 3, 1] = 1.0
        return G

    def _kin(self, xs, yaw, cos, sin):
        """Body point ``(x, 0, z)``, velocity ``(vx, 0, vz)``, no drift acceleration."""
        P = (xs[0], 0.0, xs[1])
        V = (xs[2], 0.0, xs[3])
        B = ((1.0, 0.0), (0.0, 0.0), (0.0, 1.0))
        return P, V, (0.0, 0.0, 0.0), B

    def brake_input(self, x, yaw=None, gain=2.0):
        """``(-gain vx, -gain vz)``."""
        gain = checked_scalar("gain", gain, 0.0)
        x = _state(x, 4)
        return -gain * x[..., 2:4]


@dataclass(frozen=True)
class HolonomicModel(RobotModel):
    """Holonomic double integrator in the odom x-y plane (legged robots can side-step).

    State ``(x, y, vx, vy)`` [m, m/s] in odom; input ``(a_x, a_y)`` [m/s^2] in the BODY frame,
    rotated into odom by the yaw (a parameter: pass ``yaw=theta`` [rad]):
    ``d(vx, vy)/dt = R(theta) (a_x, a_y)``. Body point ``(x, y)``.
    """

    state_names: ClassVar[tuple[str, ...]] = ("x", "y", "vx", "vy")
    input_names: ClassVar[tuple[str, ...]] = ("a_x", "a_y")
    planes: ClassVar[frozenset[Plane]] = frozenset({Plane.VERTICAL})
    needs_yaw: ClassVar[bool] = True

    def f(self, x, yaw=None):
        """Drift ``(vx, vy, 0, 0)``."""
        x = _state(x, 4)
        return np.concatenate([x[..., 2:4], np.zeros_like(x[..., 2:4])], axis=-1)

    def g(self, x, yaw=None):
        """Input matrix ``[0; R(yaw)]``."""
        x = _state(x, 4)
        th = np.broadcast_to(self._yaw(yaw), x.shape[:-1])
        c, s = np.cos(th), np.sin(th)
        G = np.zeros(x.shape[:-1] + (4, 2))
        G[..., 2, 0] = c
        G[..., 2, 1] = -s
        G[..., 3, 0] = s
        G[..., 3, 1] = c
        return G

    def _kin(self, xs, yaw, cos, sin):
        """Body point ``(x, y, 0)``; ``B = [R(yaw); 0]``, no drift acceleration."""
        c, s = cos(yaw), sin(yaw)
        P = (xs[0], xs[1], 0.0)
        V = (xs[2], xs[3], 0.0)
        B = ((c, -s), (s, c), (0.0, 0.0))
        return P, V, (0.0, 0.0, 0.0), B

    def brake_input(self, x, yaw=None, gain=2.0):
        """Body-frame ``R(yaw)^T (-gain (vx, vy))``."""
        gain = checked_scalar("gain", gain, 0.0)
        x = _state(x, 4)
        th = np.broadcast_to(self._yaw(yaw), x.shape[:-1])
        c, s = np.cos(th), np.sin(th)
        vx, vy = x[..., 2], x[..., 3]
        return -gain * np.stack([c * vx + s * vy, -s * vx + c * vy], axis=-1)


@dataclass(frozen=True)
class UnicycleHeightModel(RobotModel):
    """Unicycle plus a vertical double-integrator axis, for x-y AND x-z obstacles in one QP.

    State ``(x, y, theta, v, omega, z, vz)``; input ``(a, alpha, a_z)``. ``z`` is the body
    height [m] (odom), ``vz`` its rate. Body point
    ``P = (x + l cos th, y + l sin th, z)``, ``V = (v cos th - l w sin th,
    v sin th + l w cos th, vz)``.

    Vertical obstacles use ``(P_x, P_y)``; horizontal bars (along odom y) use ``(P_x, P_z)``,
    so a bar's constraint depends on ``a`` *and* ``alpha`` (when ``l != 0``) through
    ``dV_x/dt = a cos th - l alpha sin th - v w sin th - l w^2 cos th`` and on ``a_z``.
    With ``theta = 0`` and ``l = 0`` it reduces exactly to :class:`UnicycleModel` (x-y) and
    :class:`XZDoubleIntegratorModel` (x-z, ``vx = v``).

    Attributes:
        offset: Body-point offset ``l`` [m] ahead along the heading.

    """

    offset: float = 0.0

    def __post_init__(self) -> None:
        """Validate the offset (finite, ``|l| <= 1e9`` m)."""
        _offset(self)

    state_names: ClassVar[tuple[str, ...]] = ("x", "y", "theta", "v", "omega", "z", "vz")
    input_names: ClassVar[tuple[str, ...]] = ("a", "alpha", "a_z")
    planes: ClassVar[frozenset[Plane]] = frozenset({Plane.VERTICAL, Plane.HORIZONTAL})

    def f(self, x, yaw=None):
        """Drift ``(v cos th, v sin th, omega, 0, 0, vz, 0)``."""
        x = _state(x, 7)
        th, v, w, vz = x[..., 2], x[..., 3], x[..., 4], x[..., 6]
        z = np.zeros_like(v)
        return np.stack([v * np.cos(th), v * np.sin(th), w, z, z, vz, z], axis=-1)

    def g(self, x, yaw=None):
        """``a`` drives ``v``, ``alpha`` drives ``omega``, ``a_z`` drives ``vz``."""
        x = _state(x, 7)
        G = np.zeros(x.shape[:-1] + (7, 3))
        G[..., 3, 0] = 1.0
        G[..., 4, 1] = 1.0
        G[..., 6, 2] = 1.0
        return G

    def _kin(self, xs, yaw, cos, sin):
        """3-D body point (see class docstring)."""
        px, py, th, v, w, z, vz = xs[0], xs[1], xs[2], xs[3], xs[4], xs[5], xs[6]
        c, s = cos(th), sin(th)
        l = self.offset  # noqa: E741 - the paper's symbol
        P = (px + l * c, py + l * s, z)
        V = (v * c - l * w * s, v * s + l * w * c, vz)
        A = (-v * w * s - l * w * w * c, v * w * c - l * w * w * s, 0.0)
        B = ((c, -l * s, 0.0), (s, l * c, 0.0), (0.0, 0.0, 1.0))
        return P, V, A, B

    def brake_input(self, x, yaw=None, gain=2.0):
        """``(-gain v, -gain omega, -gain vz)``."""
        gain = checked_scalar("gain", gain, 0.0)
        x = _state(x, 7)
        return -gain * np.stack([x[..., 3], x[..., 4], x[..., 6]], axis=-1)


@dataclass(frozen=True)
class HolonomicHeightModel(RobotModel):
    """Holonomic x-y double integrator plus a vertical axis, for x-y and x-z obstacles.

    State ``(x, y, vx, vy, z, vz)`` in odom; input ``(a_x, a_y, a_z)`` where ``(a_x, a_y)`` are
    BODY-frame accelerations rotated by the yaw parameter (``yaw=theta``) and ``a_z`` is
    vertical. Body point ``(x, y, z)``. With ``theta = 0`` it reduces exactly to
    :class:`HolonomicModel` (x-y) and :class:`XZDoubleIntegratorModel` (x-z, inputs
    ``(a_x, a_z)``).
    """

    state_names: ClassVar[tuple[str, ...]] = ("x", "y", "vx", "vy", "z", "vz")
    input_names: ClassVar[tuple[str, ...]] = ("a_x", "a_y", "a_z")
    planes: ClassVar[frozenset[Plane]] = frozenset({Plane.VERTICAL, Plane.HORIZONTAL})
    needs_yaw: ClassVar[bool] = True

    def f(self, x, yaw=None):
        """Drift ``(vx, vy, 0, 0, vz, 0)``."""
        x = _state(x, 6)
        z = np.zeros_like(x[..., 0])
        return np.stack([x[..., 2], x[..., 3], z, z, x[..., 5], z], axis=-1)

    def g(self, x, yaw=None):
        """``d(vx, vy)/dt = R(yaw) (a_x, a_y)``, ``d vz/dt = a_z``."""
        x = _state(x, 6)
        th = np.broadcast_to(self._yaw(yaw), x.shape[:-1])
        c, s = np.cos(th), np.sin(th)
        G = np.zeros(x.shape[:-1] + (6, 3))
        G[..., 2, 0] = c
        G[..., 2, 1] = -s
        G[..., 3, 0] = s
        G[..., 3, 1] = c
        G[..., 5, 2] = 1.0
        return G

    def _kin(self, xs, yaw, cos, sin):
        """Body point ``(x, y, z)``; ``B = blockdiag(R(yaw), 1)``, no drift acceleration."""
        c, s = cos(yaw), sin(yaw)
        P = (xs[0], xs[1], xs[4])
        V = (xs[2], xs[3], xs[5])
        B = ((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))
        return P, V, (0.0, 0.0, 0.0), B

    def brake_input(self, x, yaw=None, gain=2.0):
        """``(R^T (-gain (vx, vy)), -gain vz)``."""
        gain = checked_scalar("gain", gain, 0.0)
        x = _state(x, 6)
        th = np.broadcast_to(self._yaw(yaw), x.shape[:-1])
        c, s = np.cos(th), np.sin(th)
        vx, vy = x[..., 2], x[..., 3]
        return -gain * np.stack([c * vx + s * vy, -s * vx + c * vy, x[..., 5]], axis=-1)
