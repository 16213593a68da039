r"""Inside an inflated circle: keep leaving, never go deeper.

Where the body point is inside an obstacle's inflated circle (``||p_rel||^2 - r^2 <
1e-9 r^2``, :data:`INSIDE_REL_CLEARANCE`) the collision-cone barrier is undefined. The filter
then reports EMERGENCY and replaces that obstacle's cone constraint by one on the *radial
speed*, the rate of the distance ``d = ||p_rel||`` between the body point and the centre::

    b = d d/dt = <e, v_rel>,    e = p_rel / d          [m/s], > 0: leaving

(``p_rel = c - P``, ``v_rel = c_dot - V`` and ``d p_rel/dt = v_rel`` as in ``lie``). With the
obstacle at constant velocity, ``d v_rel/dt = -(a_drift + B u)`` and
``d e/dt = (v_rel - b e) / d``, so::

    db/dt = Lf b + Lg b u,   Lf b = (||v_rel||^2 - b^2) / d - <e, a_drift>   [m/s^2]
                             Lg b = -e^T B

and the constraint is ``Lf b + Lg b u + gamma (b - exit_speed) >= 0``: the radial speed may
fall towards ``exit_speed`` (default 0: "never deeper") at most at the rate ``gamma``, and is
never pushed down by the filter: an outward motion is not braked. Per model (``e = (e_1,
e_2)`` in the obstacle's plane, ``c, s = cos, sin`` of the heading or yaw ``theta``)::

    XZDoubleIntegratorModel (x-z):   Lf b = |v_perp|^2 / d        Lg b = -(e_1, e_2)
    HolonomicModel (x-y, yaw th):    Lf b = |v_perp|^2 / d        Lg b = -(e_1 c + e_2 s,
                                                                            -e_1 s + e_2 c)
    UnicycleModel(l) (x-y):          Lf b = |v_perp|^2 / d + v w (e_1 s - e_2 c)
                                            + l w^2 (e_1 c + e_2 s)
                                     Lg b = -(e_1 c + e_2 s, l (-e_1 s + e_2 c))
    UnicycleHeightModel(l):          x-y: as UnicycleModel, 0 on a_z;
                                     x-z: Lf b = |v_perp|^2 / d + e_1 (v w s + l w^2 c)
                                          Lg b = -(e_1 c, -e_1 l s, e_2)
    HolonomicHeightModel:            x-y: as HolonomicModel, 0 on a_z;
                                     x-z: Lf b = |v_perp|^2 / d,  Lg b = -(e_1 c, -e_1 s, e_2)

with ``|v_perp|^2 = ||v_rel||^2 - b^2``. The code evaluates the generic form from the body-point
kinematics of each model (the tests check ``Lf b``, ``Lg b`` against finite differences).

The filter uses the radial constraint only while the robot is leaving every circle it is
inside (``b > 0`` for each): it then solves its usual QP with these rows. Otherwise (at
rest, or moving deeper into one of them) it takes the escape action: brake and accelerate
the body point away from those centres (:func:`escape_input`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .lie import PLANE_AXES, plane_take
from .models import PointKinematics

if TYPE_CHECKING:
    from .rows import Terms

__all__ = [
    "INSIDE_REL_CLEARANCE",
    "InsideRows",
    "RadialTerms",
    "escape_input",
    "inside_rows",
    "radial_terms",
    "rows_of",
    "signed_h",
]

INSIDE_REL_CLEARANCE = 1e-9
"""A body point is inside (or numerically on) a circle when ``||p||^2 - r^2 < 1e-9 r^2``."""


class RadialTerms(NamedTuple):
    """Radial speed and its Lie derivatives for ``k`` obstacles (see module docstring)."""

    p_rel: np.ndarray
    """``(k, 2)`` obstacle centre minus body point, in-plane [m]."""
    speed: np.ndarray
    """``(k,)`` radial speed ``b = d||p_rel||/dt`` [m/s] (> 0: leaving; 0 at the centre)."""
    lf: np.ndarray
    """``(k,)`` ``Lf b`` [m/s^2] (0 at the centre)."""
    lg: np.ndarray
    """``(k, m)`` ``Lg b`` [m/s^2 per input unit] (0 at the centre)."""


def radial_terms(kin: PointKinematics, center, velocity, plane) -> RadialTerms:
    """:class:`RadialTerms` of one state (``kin`` unbatched arrays) for ``k`` obstacles.

    ``kin`` is one body point's (arrays ``(3,)``) or row-wise (``(k, 3)``: row ``i`` its own
    point, the whole-body filter's ``body_rows``).

    Args:
        kin: Body-point kinematics (:meth:`~.models.RobotModel.point_kinematics`), odom.
        center: ``(k, 2)`` in-plane obstacle centres [m].
        velocity: ``(k, 2)`` in-plane obstacle velocities [m/s].
        plane: ``(k,)`` :class:`~.geometry.Plane` values.

    """
    axes = PLANE_AXES[np.asarray(plane, dtype=np.intp)]
    rowwise = np.ndim(kin.position) == 2
    p = np.asarray(center, dtype=float) - plane_take(kin.position, axes, rowwise)
    v = np.asarray(velocity, dtype=float) - plane_take(kin.velocity, axes, rowwise)
    a = plane_take(kin.accel_drift, axes, rowwise)
    B = plane_take(kin.accel_input, axes, rowwise)  # (k, 2, m)
    d = np.sqrt((p * p).sum(-1))
    at_centre = d == 0.0
    e = p / np.where(at_centre, 1.0, d)[:, None]  # 0 at the centre
    b = (e * v).sum(-1)
    lf = np.where(at_centre, 0.0, ((v * v).sum(-1) - b * b) / np.where(at_centre, 1.0, d))
    lf = lf - (e * a).sum(-1)
    lg = -(e[:, :, None] * B).sum(-2)
    return RadialTerms(p, b, lf, lg)


def rows_of(kin: PointKinematics, idx) -> PointKinematics:
    """``kin`` of the rows ``idx``: row-wise kinematics indexed, one point's unchanged."""
    if np.ndim(kin.position) == 2:
        return PointKinematics(*(np.asarray(a)[idx] for a in kin))
    return kin


def signed_h(h, clearance, radius, gamma: float):
    """Barrier value reported for rows inside their circle: always < 0 [m^2/s].

    ``min(h, gamma (||p||^2 - r^2 - 1e-9 r^2))``: the cone value (``sqrt`` clamped to 0, so
    ``<p_rel, v_rel>``, negative when moving deeper) or ``gamma`` times the negative squared
    clearance, whichever is smaller; strictly negative for every inside row (``gamma > 0``).
    """
    r2 = np.asarray(radius, dtype=float) ** 2
    return np.minimum(h, gamma * (np.asarray(clearance) - INSIDE_REL_CLEARANCE * r2))


class InsideRows(NamedTuple):
    """The filter's rows with radial rows for the circles the body point is inside."""

    idx: np.ndarray
    """``(k,)`` indices of those obstacles."""
    rad: RadialTerms
    """Their radial terms."""
    terms: Terms
    """Every obstacle's terms; for those, ``h`` by :func:`signed_h` and the true gap."""
    G: np.ndarray
    """``(n, m)`` rows ``G u + c0 >= 0``: ``Lg b`` for those obstacles, else ``Lg h``."""
    c0: np.ndarray
    """``(n,)`` ``Lf b + gamma (b - exit_speed)`` for those obstacles, else ``Lf h + gamma h``."""


def inside_rows(
    kin: PointKinematics, obs, radius, terms: Terms, inside, gamma: float, exit_speed: float
) -> InsideRows:
    """Replace the cone rows of the obstacles flagged ``inside`` by their radial rows.

    Args:
        kin: Body-point kinematics (unbatched arrays).
        obs: The :class:`~.geometry.Obstacles`.
        radius: ``(n,)`` the radius each row uses [m].
        terms: The barrier terms of every obstacle (``rows.obstacle_terms``).
        inside: ``(n,)`` bool, the body point is inside that circle.
        gamma: The filter's class-K gain [1/s].
        exit_speed: Radial speed [m/s] kept (at least) while leaving.

    """
    idx = np.flatnonzero(inside)
    rad = radial_terms(rows_of(kin, idx), obs.center[idx], obs.velocity[idx], obs.plane[idx])
    G = terms.G.copy()
    c0 = terms.c0.copy()
    G[idx] = rad.lg
    c0[idx] = rad.lf + gamma * (rad.speed - exit_speed)
    h, gap = terms.h.copy(), terms.gap.copy()
    h[idx] = signed_h(h[idx], terms.clearance[idx], radius[idx], gamma)
    gap[idx] = np.sqrt((rad.p_rel * rad.p_rel).sum(-1)) - obs.radius[idx]
    return InsideRows(idx, rad, terms._replace(h=h, gap=gap), G, c0)


def escape_input(
    kin: PointKinematics, p_rel, plane, brake_u, brake_gain: float, escape_accel: float
) -> np.ndarray:
    """Input that brakes and accelerates the body point away from the centres it is inside.

    Desired body-point acceleration ``-brake_gain V + escape_accel * away`` (``away``: the
    normalised sum of the unit vectors from each centre to the body point; exactly at a
    centre, back off along ``-V``); realised by the least-squares input, plus ``brake_u``
    (the model's brake input) in the null space of ``B``. Unclipped, possibly non-finite.

    Args:
        kin: Body-point kinematics (unbatched arrays).
        p_rel: ``(k, 2)`` centre minus body point of the circles the robot is inside [m].
        plane: ``(k,)`` their planes.
        brake_u: ``(m,)`` the model's brake input.
        brake_gain: Velocity damping [1/s].
        escape_accel: Acceleration away from the centres [m/s^2].

    """
    plane_axes = PLANE_AXES[np.asarray(plane, dtype=np.intp)]
    away_2d = -np.array(p_rel, dtype=float)  # body point minus obstacle centre, in-plane
    dist = np.linalg.norm(away_2d, axis=1)
    v3 = kin.velocity
    for i in np.flatnonzero(dist < 1e-9):  # exactly at the centre: back off along -V
        back = -v3[plane_axes[i]]
        nb = np.linalg.norm(back)
        away_2d[i] = back / nb if nb > 1e-9 else np.array([-1.0, 0.0])
        dist[i] = 1.0
    away = np.zeros(3)
    np.add.at(away, plane_axes, away_2d / dist[:, None])
    na = np.linalg.norm(away)
    if na > 1e-12:
        away /= na
    a_des = -brake_gain * v3 + escape_accel * away
    B = kin.accel_input
    B_pinv = np.linalg.pinv(B)
    u = B_pinv @ (a_des - kin.accel_drift)
    return u + (np.eye(B.shape[1]) - B_pinv @ B) @ np.asarray(brake_u, dtype=float)
