"""Kinematic obstacles: elliptic cylinders moved by motion scripts.

Every obstacle is an elliptic cylinder: an ellipse with semi-axes (a, b) extruded by
``extent``. Vertical obstacles (pillars, people) have the ellipse in the odom x-y plane and
extend along z; horizontal obstacles (bars across the path) have it in the x-z plane and extend
along odom y. The PyBullet body is a mass-0 (kinematic) convex hull of a polygon inscribed in
the ellipse (``segments`` vertices per ring; the polygon lies at most a (1 - cos(pi/segments))
inside the ellipse, 0.5 % of a for 32 segments), so the robot cannot push it.

Motion scripts are pure functions of sim time (:class:`MotionScript`), so the true obstacle
state at any time is exact and deterministic. The body's velocity is set together with its
pose: PyBullet integrates mass-0 bodies at their set velocity, which lets the contact solver
see the motion and keeps the body on the script between re-synchronisations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pybullet

from safe_legged_c3bf.interfaces.rotations import matrix_to_quaternion
from safe_legged_c3bf.sim.scenario import MotionConfig, ObstacleConfig

#: Obstacle planes (values of safe_legged_c3bf_msgs/Obstacle.plane).
VERTICAL = 0
HORIZONTAL = 1
#: Velocity sources (values of safe_legged_c3bf_msgs/Obstacle.velocity_source).
VELOCITY_UNKNOWN = 0
VELOCITY_ESTIMATED = 1
VELOCITY_MEASURED = 2

PLANE_CODES = {"vertical": VERTICAL, "horizontal": HORIZONTAL}


@dataclass
class ObstacleState:
    """An obstacle as the messages carry it (odom frame, SI units).

    Attributes:
        id: identifier ('' when unknown / stripped).
        plane: VERTICAL (0) or HORIZONTAL (1).
        center: (3,) centre of the elliptic cylinder (m).
        velocity: (3,) velocity (m/s); zero for raw detections.
        semi_axes: (a, b) semi-axes of the ellipse (m).
        orientation: angle of axis a from odom x within the ellipse's plane (rad).
        extent: length along the extrusion axis (m).
        position_covariance: (3, 3) covariance of ``center`` (m^2).
        velocity_covariance: (3, 3) covariance of ``velocity`` (m^2/s^2).
        velocity_source: VELOCITY_UNKNOWN, VELOCITY_ESTIMATED or VELOCITY_MEASURED.

    """

    id: str
    plane: int
    center: np.ndarray
    velocity: np.ndarray
    semi_axes: tuple[float, float]
    orientation: float
    extent: float
    position_covariance: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    velocity_covariance: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    velocity_source: int = VELOCITY_MEASURED


class MotionScript:
    """Position and velocity of an obstacle as a function of sim time.

    * ``static``: stays at the start position.
    * ``constant_velocity``: start + velocity * (t - start_time) after ``start_time``.
    * ``waypoints``: from the start position through the waypoints at ``speed``; ``pingpong``
      then goes back along the same path and repeats, ``cycle`` returns straight to the start
      and repeats, ``stop`` stays at the last waypoint.

    Before ``start_time`` every script is at its start position with zero velocity.
    """

    def __init__(self, start: tuple[float, float, float], motion: MotionConfig) -> None:
        """Build the script of an obstacle starting at ``start`` (m, odom)."""
        self.motion = motion
        self.start = np.asarray(start, dtype=float)
        self.start_time = float(motion.start_time)
        self.kind = motion.type
        self.velocity = np.asarray(motion.velocity, dtype=float)
        #: largest speed of the script (m/s).
        self.max_speed = 0.0
        if self.kind == "constant_velocity":
            self.max_speed = float(np.linalg.norm(self.velocity))
        elif self.kind == "waypoints":
            self.max_speed = float(motion.speed)
        self.moving = self.kind == "waypoints" or (
            self.kind == "constant_velocity" and bool(np.any(self.velocity != 0.0))
        )
        if self.kind == "waypoints":
            points = [self.start] + [np.asarray(p, dtype=float) for p in motion.waypoints]
            if motion.mode == "pingpong":
                points = points + points[-2::-1]
            elif motion.mode == "cycle":
                points = points + [self.start]
            self._vertices = np.array(points)
            legs = np.diff(self._vertices, axis=0)
            lengths = np.linalg.norm(legs, axis=1)
            self._directions = legs / lengths[:, None]
            self._cumulative = np.concatenate([[0.0], np.cumsum(lengths)])
            self._length = float(self._cumulative[-1])
            self._periodic = motion.mode in ("pingpong", "cycle")
            self.speed = float(motion.speed)

    @property
    def period(self) -> float:
        """Duration of one repetition of a periodic waypoint script (s); inf otherwise."""
        if self.kind == "waypoints" and self._periodic:
            return self._length / self.speed
        return math.inf

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Return (position (3,), velocity (3,)) at sim time ``t``."""
        tau = t - self.start_time
        if self.kind == "static" or tau < 0.0:
            return self.start.copy(), np.zeros(3)
        if self.kind == "constant_velocity":
            return self.start + self.velocity * tau, self.velocity.copy()
        s = self.speed * tau
        if self._periodic:
            s = math.fmod(s, self._length)
        elif s >= self._length:
            return self._vertices[-1].copy(), np.zeros(3)
        i = int(np.searchsorted(self._cumulative, s, side="right")) - 1
        i = min(max(i, 0), len(self._directions) - 1)
        direction = self._directions[i]
        position = self._vertices[i] + direction * (s - self._cumulative[i])
        return position, direction * self.speed

    def next_change(self, t: float) -> float:
        """Earliest sim time > ``t`` at which the velocity jumps (inf if never)."""
        if self.kind == "static":
            return math.inf
        if t < self.start_time:
            return self.start_time
        if self.kind == "constant_velocity":
            return math.inf
        s = self.speed * (t - self.start_time)
        cycles = 0.0
        if self._periodic:
            cycles = math.floor(s / self._length)
            s -= cycles * self._length
        elif s >= self._length:
            return math.inf
        j = int(np.searchsorted(self._cumulative, s, side="right"))
        j = min(j, len(self._cumulative) - 1)
        return self.start_time + (cycles * self._length + self._cumulative[j]) / self.speed


def obstacle_rotation(plane: int, orientation: float) -> np.ndarray:
    """Rotation (3x3, local -> odom) of an obstacle body.

    Local x is the ellipse's axis a, local y its axis b, local z the extrusion axis. For a
    vertical obstacle that is a yaw by ``orientation``; for a horizontal one local x is
    (cos o, 0, sin o) in odom (from +x towards +z) and the extrusion axis is odom -y.
    """
    c, s = math.cos(orientation), math.sin(orientation)
    if plane == VERTICAL:
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    x_axis = np.array([c, 0.0, s])
    y_axis = np.array([-s, 0.0, c])
    return np.column_stack([x_axis, y_axis, np.cross(x_axis, y_axis)])


def ellipse_prism(
    a: float, b: float, extent: float, segments: int = 32
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangle mesh of an elliptic cylinder in its local frame.

    Returns (vertices (m, 3), triangle indices (k,), vertex normals (m, 3)). The side and the
    two caps have separate vertices so that flat shading looks right.
    """
    theta = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    ring = np.column_stack([a * np.cos(theta), b * np.sin(theta)])
    half = extent / 2.0
    n = segments
    normals_xy = np.column_stack([b * np.cos(theta), a * np.sin(theta)])
    normals_xy /= np.linalg.norm(normals_xy, axis=1)[:, None]
    side_bottom = np.column_stack([ring, np.full(n, -half)])
    side_top = np.column_stack([ring, np.full(n, half)])
    vertices = np.vstack([side_bottom, side_top, side_bottom, side_top])
    normals = np.vstack(
        [
            np.column_stack([normals_xy, np.zeros(n)]),
            np.column_stack([normals_xy, np.zeros(n)]),
            np.tile([0.0, 0.0, -1.0], (n, 1)),
            np.tile([0.0, 0.0, 1.0], (n, 1)),
        ]
    )
    tris = []
    for i in range(n):
        j = (i + 1) % n
        tris += [(i, j, n + j), (i, n + j, n + i)]  # side, counter-clockwise seen from outside
    for i in range(1, n - 1):
        tris.append((2 * n, 2 * n + i + 1, 2 * n + i))  # bottom cap faces -z
        tris.append((3 * n, 3 * n + i, 3 * n + i + 1))  # top cap faces +z
    return vertices, np.array(tris, dtype=int).reshape(-1), normals


class KinematicObstacle:
    """One obstacle body in a PyBullet client, driven by its motion script."""

    def __init__(self, client: int, config: ObstacleConfig, segments: int = 32) -> None:
        """Create the body of ``config`` at its t = 0 pose in ``client``."""
        self.client = client
        self.config = config
        self.id = config.id
        self.plane = PLANE_CODES[config.plane]
        self.semi_axes = (float(config.semi_axes[0]), float(config.semi_axes[1]))
        self.extent = float(config.extent)
        self.orientation = float(config.orientation)
        self.script = MotionScript(config.position, config.motion)
        self.rotation = obstacle_rotation(self.plane, self.orientation)
        self.quaternion = matrix_to_quaternion(self.rotation)
        self.bounding_radius = max(self.semi_axes)
        vertices, indices, normals = ellipse_prism(*self.semi_axes, self.extent, segments)
        collision = pybullet.createCollisionShape(
            pybullet.GEOM_MESH, vertices=vertices[: 2 * segments].tolist(), physicsClientId=client
        )
        visual = pybullet.createVisualShape(
            pybullet.GEOM_MESH,
            vertices=vertices.tolist(),
            indices=indices.tolist(),
            normals=normals.tolist(),
            rgbaColor=list(config.color),
            physicsClientId=client,
        )
        position, velocity = self.script.state(0.0)
        self.body_id = pybullet.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=collision,
            baseVisualShapeIndex=visual,
            basePosition=position.tolist(),
            baseOrientation=list(self.quaternion),
            physicsClientId=client,
        )
        self._synced_velocity = np.zeros(3)
        self.sync(0.0)

    @property
    def moving(self) -> bool:
        """Whether the script ever moves the obstacle."""
        return self.script.moving

    @property
    def max_speed(self) -> float:
        """Largest speed of the obstacle (m/s)."""
        return self.script.max_speed

    def sync(self, t: float) -> None:
        """Put the body at its scripted pose and velocity for time ``t``."""
        position, velocity = self.script.state(t)
        pybullet.resetBasePositionAndOrientation(
            self.body_id, position.tolist(), self.quaternion, physicsClientId=self.client
        )
        pybullet.resetBaseVelocity(
            self.body_id, velocity.tolist(), [0.0, 0.0, 0.0], physicsClientId=self.client
        )
        self._synced_velocity = velocity

    def body_position(self) -> tuple[float, float, float]:
        """Position of the PyBullet body now (m); equals the script up to one physics step."""
        pos, _ = pybullet.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)
        return pos

    def state(self, t: float) -> ObstacleState:
        """True state at sim time ``t`` (velocity measured, zero covariances)."""
        position, velocity = self.script.state(t)
        return ObstacleState(
            id=self.id,
            plane=self.plane,
            center=position,
            velocity=velocity,
            semi_axes=self.semi_axes,
            orientation=self.orientation,
            extent=self.extent,
            velocity_source=VELOCITY_MEASURED,
        )

    def distance_lower_bound(self, point: Sequence[float], center: Sequence[float]) -> float:
        """Lower bound (m) of the distance from ``point`` to the obstacle centred at ``center``.

        Uses the circumscribed circular cylinder (radius max(a, b), same extent and axis),
        so the orientation of the ellipse does not matter.
        """
        dx = float(point[0]) - float(center[0])
        dy = float(point[1]) - float(center[1])
        dz = float(point[2]) - float(center[2])
        if self.plane == VERTICAL:
            radial, axial = math.hypot(dx, dy), abs(dz)
        else:
            radial, axial = math.hypot(dx, dz), abs(dy)
        radial -= self.bounding_radius
        axial -= self.extent / 2.0
        return math.hypot(max(radial, 0.0), max(axial, 0.0))
