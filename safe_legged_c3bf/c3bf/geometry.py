"""Obstacle geometry: inflated radii and the validated obstacle container.

Conventions (SI units, odom frame, REP-103: x forward, y left, z up):

* ``Plane.VERTICAL`` obstacles are vertical pillars/walls seen from above. They live in the
  odom **x-y** plane: in-plane coordinates are ``(x, y)``; the obstacle extends infinitely
  along z.
* ``Plane.HORIZONTAL`` obstacles are horizontal bars across the path. The bar's cross-section
  is an ellipse in the odom **x-z** plane, in-plane coordinates ``(x, z)``; the bar extends
  infinitely along **odom y** (so the robot's y position does not matter for it). A bar at
  another yaw must be expressed in a frame whose x axis crosses it before use.

An ellipse with semi-axes ``(c1, c2)`` is replaced by its circumscribed circle, inflated by
half the robot dimension that faces it (paper: ``r = max(c1, c2) + w/2``): the robot *width*
for vertical obstacles and the robot *height* for horizontal ones.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from enum import IntEnum
from functools import cached_property

import numpy as np

from .domain import MAX_MAGNITUDE, bad_entry, checked
from .errors import InvalidInputError

__all__ = ["EllipseObstacle", "Obstacles", "Plane", "inflated_radius"]


class Plane(IntEnum):
    """Plane in which an obstacle constrains the robot's body point."""

    VERTICAL = 0
    """Vertical obstacle, constraint in the odom x-y plane (in-plane coordinates x, y)."""
    HORIZONTAL = 1
    """Horizontal bar along odom y, constraint in the odom x-z plane (coordinates x, z)."""


def inflated_radius(c1, c2, robot_dim):
    """Return the conservative circle radius ``r = max(c1, c2) + robot_dim / 2`` [m].

    Args:
        c1: First ellipse semi-axis [m] (scalar or array).
        c2: Second ellipse semi-axis [m].
        robot_dim: Robot width [m] for vertical obstacles, robot height [m] for horizontal ones.

    Returns:
        The inflated radius, a float or an array broadcast from the inputs.

    Raises:
        InvalidInputError: if an input is not finite, beyond the domain's magnitude
            (``domain.MAX_MAGNITUDE``) or negative, or the radius is not > 0.

    """
    c1a, c2a, da = (checked(k, v) for k, v in (("c1", c1), ("c2", c2), ("robot_dim", robot_dim)))
    for k, a in (("c1", c1a), ("c2", c2a), ("robot_dim", da)):
        if (a < 0).any():
            raise InvalidInputError(f"{k} = {a.tolist()!r} must be >= 0")
    r = np.maximum(c1a, c2a) + 0.5 * da
    if (r <= 0).any():
        raise InvalidInputError("inflated radius must be > 0")
    return float(r) if r.ndim == 0 else r


@dataclass(frozen=True)
class EllipseObstacle:
    """One elliptical obstacle, moving with constant velocity.

    Attributes:
        center: In-plane centre [m]: odom ``(x, y)`` if VERTICAL, odom ``(x, z)`` if HORIZONTAL.
        semi_axes: Ellipse semi-axes ``(c1, c2)`` [m] in the same in-plane axes.
        velocity: In-plane centre velocity [m/s] (odom frame), constant (zero acceleration).
        plane: :class:`Plane` of the obstacle.

    """

    center: tuple[float, float]
    semi_axes: tuple[float, float]
    velocity: tuple[float, float] = (0.0, 0.0)
    plane: Plane = Plane.VERTICAL

    def __post_init__(self) -> None:
        """Validate and normalise: pairs of floats in the domain, semi-axes > 0, a Plane.

        Raises :class:`InvalidInputError` naming the obstacle and the bad value.
        """
        values = {}
        for name in ("center", "semi_axes", "velocity"):
            raw = getattr(self, name)
            try:
                a = np.asarray(raw, dtype=float)
            except (TypeError, ValueError):
                a = None
            if a is None or a.shape != (2,):
                raise InvalidInputError(f"{self!r}: {name} must be 2 numbers, got {raw!r}")
            problem = bad_entry(name, a, positive=name == "semi_axes")
            if problem:
                raise InvalidInputError(f"{self!r}: {problem}")
            values[name] = (float(a[0]), float(a[1]))
        try:
            values["plane"] = Plane(self.plane)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                f"{self!r}: plane = {self.plane!r} is not Plane.VERTICAL (0) or HORIZONTAL (1)"
            ) from exc
        for name, v in values.items():
            object.__setattr__(self, name, v)

    def radius(self, robot_width: float, robot_height: float) -> float:
        """Inflated radius [m] using the robot width (VERTICAL) or height (HORIZONTAL)."""
        dim = robot_width if Plane(self.plane) is Plane.VERTICAL else robot_height
        return inflated_radius(self.semi_axes[0], self.semi_axes[1], dim)


@dataclass(frozen=True, eq=False)
class Obstacles:
    """A validated, immutable set of ``n`` circular (already inflated) obstacles.

    All arrays are copied, converted to float and made read-only at construction, so the
    filter can use them without re-validation.

    Attributes:
        center: ``(n, 2)`` in-plane centres [m], odom frame (see :class:`Plane`).
        velocity: ``(n, 2)`` in-plane centre velocities [m/s], odom frame, constant.
        radius: ``(n,)`` inflated radii ``r`` [m], all > 0.
        plane: ``(n,)`` integer array of :class:`Plane` values.

    """

    center: np.ndarray
    velocity: np.ndarray
    radius: np.ndarray
    plane: np.ndarray

    def __post_init__(self) -> None:
        c = np.array(self.center, dtype=float)  # copies
        if c.ndim == 1 and c.size == 2:
            c = c.reshape(1, 2)
        if c.ndim != 2 or c.shape[1] != 2:
            raise InvalidInputError(f"center must have shape (n, 2), got {np.shape(self.center)}")
        n = c.shape[0]
        try:
            v = np.array(np.broadcast_to(np.asarray(self.velocity, dtype=float), (n, 2)))
            r = np.array(np.broadcast_to(np.asarray(self.radius, dtype=float), (n,)))
            p = np.array(np.broadcast_to(np.asarray(self.plane), (n,)), dtype=np.intp)
        except (ValueError, TypeError) as exc:
            raise InvalidInputError(
                "velocity must be (n, 2) and radius/plane (n,) for n = len(center)"
            ) from exc
        for name, arr in (("center", c), ("velocity", v), ("radius", r)):
            ok = np.abs(arr) <= MAX_MAGNITUDE  # False for NaN
            if name == "radius":
                ok &= arr > 0.0
            if not ok.all():
                i = int(np.flatnonzero(~ok.reshape(n, -1).all(axis=1))[0])
                problem = bad_entry(name, arr[i], positive=name == "radius")
                raise InvalidInputError(f"obstacle {i}: {problem}")
        wrong = (p != Plane.VERTICAL) & (p != Plane.HORIZONTAL)
        if wrong.any():
            i = int(np.flatnonzero(wrong)[0])
            raise InvalidInputError(
                f"obstacle {i}: plane = {int(p[i])} is not Plane.VERTICAL (0) or HORIZONTAL (1)"
            )
        for name, arr in (("center", c), ("velocity", v), ("radius", r), ("plane", p)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        """Number of obstacles."""
        return self.center.shape[0]

    @cached_property
    def planes_present(self) -> frozenset[Plane]:
        """The set of planes used by at least one obstacle."""
        return frozenset(map(Plane, set(self.plane.tolist())))

    @classmethod
    def empty(cls) -> Obstacles:
        """Return an empty obstacle set."""
        return cls(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.intp))

    @classmethod
    def vertical(cls, center, radius, velocity=None) -> Obstacles:
        """Vertical obstacles: centres ``(n, 2)`` odom (x, y) [m], inflated radii [m].

        ``velocity`` is ``(n, 2)`` odom (vx, vy) [m/s]; ``None`` means static.
        """
        c = np.atleast_2d(np.asarray(center, dtype=float))
        vel = np.zeros_like(c) if velocity is None else velocity
        return cls(c, vel, radius, Plane.VERTICAL)

    @classmethod
    def horizontal(cls, center, radius, velocity=None) -> Obstacles:
        """Horizontal bars along odom y: centres ``(n, 2)`` odom (x, z) [m], inflated radii [m].

        ``velocity`` is ``(n, 2)`` odom (vx, vz) [m/s]; ``None`` means static.
        """
        c = np.atleast_2d(np.asarray(center, dtype=float))
        vel = np.zeros_like(c) if velocity is None else velocity
        return cls(c, vel, radius, Plane.HORIZONTAL)

    @classmethod
    def from_ellipses(
        cls, obstacles: Iterable[EllipseObstacle], robot_width: float, robot_height: float
    ) -> Obstacles:
        """Build from :class:`EllipseObstacle` s, inflating each by the relevant robot size."""
        obs = list(obstacles)
        if not obs:
            return cls.empty()
        for i, o in enumerate(obs):
            if not isinstance(o, EllipseObstacle):
                raise InvalidInputError(f"obstacle {i}: {o!r} is not an EllipseObstacle")
        return cls(
            np.array([o.center for o in obs], dtype=float),
            np.array([o.velocity for o in obs], dtype=float),
            np.array([o.radius(robot_width, robot_height) for o in obs], dtype=float),
            np.array([int(o.plane) for o in obs], dtype=np.intp),
        )

    @classmethod
    def concatenate(cls, *sets: Obstacles) -> Obstacles:
        """Concatenate several obstacle sets (order is kept)."""
        if not sets:
            return cls.empty()
        return cls(
            np.concatenate([s.center for s in sets]),
            np.concatenate([s.velocity for s in sets]),
            np.concatenate([s.radius for s in sets]),
            np.concatenate([s.plane for s in sets]),
        )

    @classmethod
    def from_validated(cls, center, velocity, radius, plane, planes_present=None) -> Obstacles:
        """Wrap arrays whose validity the caller guarantees: no copy, no per-array checks.

        For per-cycle sets derived from inputs validated once (e.g. when a message arrives):
        ``center``/``velocity`` float ``(n, 2)``, ``radius`` float ``(n,)``, all finite and
        within the domain (``|x| <= domain.MAX_MAGNITUDE``), radii > 0, ``plane`` integer
        ``(n,)`` of :class:`Plane` values. The arrays are made read-only (the caller must not
        keep writing to them). ``planes_present``, if given,
        must equal the set of planes in ``plane`` (it then need not be computed).
        """
        new = object.__new__(cls)
        if planes_present is not None:
            new.__dict__["planes_present"] = planes_present
        for name, arr in (
            ("center", center),
            ("velocity", velocity),
            ("radius", radius),
            ("plane", plane),
        ):
            arr.setflags(write=False)
            object.__setattr__(new, name, arr)
        return new

    def advanced(self, dt: float) -> Obstacles:
        """Return the set with centres moved by ``velocity * dt`` (constant-velocity motion)."""
        if not abs(dt) <= MAX_MAGNITUDE:  # False for NaN
            raise InvalidInputError(bad_entry("dt", dt))
        # Inputs already validated: skip re-validation.
        return Obstacles.from_validated(
            self.center + self.velocity * float(dt), self.velocity, self.radius, self.plane
        )
