"""Obstacles as the safety filter receives them, and their conversion to C3BF circles.

Frames and units: odom, m, m/s. A VERTICAL obstacle is an ellipse in x-y (extruded along z);
a HORIZONTAL one an ellipse in x-z extruded along odom y (a bar across the path).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.c3bf import Obstacles, Plane


@dataclass(frozen=True)
class ObstacleInput:
    """One obstacle from /obstacles.

    Attributes:
        id: identifier (may be empty).
        plane: 0 = VERTICAL, 1 = HORIZONTAL (Obstacle.msg constants).
        center: (3,) centre in odom (m).
        velocity: (3,) velocity in odom (m/s).
        semi_axes: (2,) ellipse semi-axes (m).
        extent: length along the extrusion axis (m): z for VERTICAL, y for HORIZONTAL.

    """

    id: str
    plane: int
    center: np.ndarray
    velocity: np.ndarray
    semi_axes: np.ndarray
    extent: float

    def is_valid(self) -> bool:
        """True when every number is finite, sizes are positive and the plane is known."""
        return bool(
            self.plane in (0, 1)
            and np.all(np.isfinite(self.center))
            and np.all(np.isfinite(self.velocity))
            and np.all(np.isfinite(self.semi_axes))
            and np.all(np.asarray(self.semi_axes) > 0)
            and np.isfinite(self.extent)
        )


def to_c3bf_obstacles(
    obstacles: list[ObstacleInput],
    dt_predict: float,
    robot_y: float,
    robot_width: float,
    robot_height: float,
    safety_margin: float,
    horizontal_y_margin: float,
    robot_yaw: float = 0.0,
    tie_break: float = 0.0,
) -> tuple[Obstacles, list[str]]:
    """Inflated circles for the C3BF filter, predicted ``dt_predict`` s ahead.

    A horizontal bar is kept only while the robot's y lies within its extent along y, grown
    by half the robot width and ``horizontal_y_margin``: beside the bar there is nothing to
    duck under. Returns the circles and the ids of the obstacles kept, in order.

    Symmetry breaking: dead ahead of a unicycle the barrier's sensitivity to steering is
    exactly zero, so a head-on obstacle can only be braked for (and a faster mover cannot be
    escaped). Each vertical circle is therefore moved ``tie_break`` m to the robot's right and
    grown by ``tie_break``: the new circle encloses the old one (still safe), and the robot
    consistently passes obstacles on their left.
    """
    centers, velocities, radii, planes, ids = [], [], [], [], []
    for ob in obstacles:
        c = np.asarray(ob.center, dtype=float) + dt_predict * np.asarray(ob.velocity, dtype=float)
        v = np.asarray(ob.velocity, dtype=float)
        a = float(np.max(ob.semi_axes))
        if ob.plane == int(Plane.VERTICAL):
            right = (np.sin(robot_yaw), -np.cos(robot_yaw))
            centers.append((c[0] + tie_break * right[0], c[1] + tie_break * right[1]))
            velocities.append((v[0], v[1]))
            radii.append(a + 0.5 * robot_width + safety_margin + tie_break)
            planes.append(int(Plane.VERTICAL))
        else:
            half_span = 0.5 * ob.extent + 0.5 * robot_width + horizontal_y_margin
            if abs(robot_y - c[1]) > half_span:
                continue
            centers.append((c[0], c[2]))
            velocities.append((v[0], v[2]))
            radii.append(a + 0.5 * robot_height + safety_margin)
            planes.append(int(Plane.HORIZONTAL))
        ids.append(ob.id)
    if not centers:
        return Obstacles.empty(), []
    return (
        Obstacles(
            center=np.array(centers),
            velocity=np.array(velocities),
            radius=np.array(radii),
            plane=np.array(planes),
        ),
        ids,
    )
