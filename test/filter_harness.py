"""A lockstep closed loop for safety filter tests: a simple robot, scripted obstacles, a
scripted reference. No PyBullet: the robot is a unicycle (or holonomic point) whose velocity
follows the command with a first-order lag, with body height following linear.z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from safe_legged_c3bf.interfaces.base_state import BaseState, yaw_to_quaternion
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.obstacle_input import ObstacleInput


@dataclass
class SimpleRobot:
    """Planar robot with first-order velocity lag ``tau`` (s), body height z (m)."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    z: float = 0.28
    vx: float = 0.0
    vy: float = 0.0
    vz: float = 0.0
    wz: float = 0.0
    tau: float = 0.1
    holonomic: bool = False

    def step(self, cmd: VelocityCommand, dt: float) -> None:
        a = min(dt / self.tau, 1.0)
        self.vx += a * (cmd.vx - self.vx)
        self.vy += a * ((cmd.vy if self.holonomic else 0.0) - self.vy)
        self.vz += a * (cmd.vz - self.vz)
        self.wz += a * (cmd.yaw_rate - self.wz)
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        self.x += (c * self.vx - s * self.vy) * dt
        self.y += (s * self.vx + c * self.vy) * dt
        self.z += self.vz * dt
        self.yaw += self.wz * dt

    def base_state(self, t: float) -> BaseState:
        return BaseState(
            position=(self.x, self.y, self.z),
            orientation=yaw_to_quaternion(self.yaw),
            linear_velocity=(self.vx, self.vy, self.vz),
            angular_velocity=(0.0, 0.0, self.wz),
            stamp=t,
        )


@dataclass
class ScriptedObstacle:
    """An obstacle moving with constant velocity (odom frame)."""

    id: str
    center: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    semi_axes: tuple[float, float] = (0.25, 0.25)
    plane: int = 0
    extent: float = 1.0

    def at(self, t: float) -> ObstacleInput:
        return ObstacleInput(
            self.id, self.plane, np.asarray(self.center, float) + t * np.asarray(self.velocity),
            np.asarray(self.velocity, float), np.asarray(self.semi_axes, float), self.extent,
        )


@dataclass
class Walker:
    """A vertical obstacle that walks from ``start`` to ``end`` (odom, m) at ``speed`` (m/s)
    from ``start_time`` (s), then stands; ``end`` None: it always stands."""

    id: str
    start: tuple[float, float]
    end: tuple[float, float] | None = None
    speed: float = 0.0
    start_time: float = 0.0
    semi_axes: tuple[float, float] = (0.25, 0.25)
    extent: float = 1.0
    orientation: float = 0.0
    plane: int = 0

    def at(self, t: float) -> ObstacleInput:
        pos, vel = np.array(self.start, float), np.zeros(2)
        if self.end is not None:
            path = np.subtract(self.end, self.start)
            length = float(np.hypot(*path))
            walked = min(max(t - self.start_time, 0.0) * self.speed, length)
            pos = pos + path * walked / length
            if 0.0 < walked < length:
                vel = path * self.speed / length
        return ObstacleInput(self.id, 0, np.array([*pos, 0.5 * self.extent]),
                             np.array([*vel, 0.0]), np.asarray(self.semi_axes, float),
                             self.extent, self.orientation)


def goal_closed_loop(cycle, planner, robot: SimpleRobot, obstacles, t0: float,
                     seconds: float, watch=None) -> None:  # noqa: ANN001
    """Run ``seconds`` of closed loop from sim time ``t0`` at 50 Hz (the robot at 250 Hz).

    ``cycle``: a ``SafetyFilterCycle``; ``planner``: a ``ReferencePlanner`` with its goal
    set; ``obstacles``: ``ObstacleInput`` or objects with ``at(t)`` (``Walker``,
    ``ScriptedObstacle``); ``watch(t)``: called after each cycle.
    """
    from safe_legged_c3bf.planning.reference_planner import RobotPose

    for k in range(int(round(seconds / 0.02))):
        t = t0 + 0.02 * k
        ref = planner.compute(RobotPose(robot.x, robot.y, robot.yaw, robot.z), t)
        out = cycle.step(t, VelocityCommand(ref.vx, ref.vy, ref.vz, ref.yaw_rate), t,
                         robot.base_state(t),
                         [o.at(t) if hasattr(o, "at") else o for o in obstacles], t)
        for _ in range(5):
            robot.step(out.command, 0.004)
        if watch is not None:
            watch(t)


def clearance(robot: SimpleRobot, ob: ScriptedObstacle, t: float, offset: float) -> float:
    """Distance from the robot's body point to the obstacle's enclosing circle (m)."""
    o = ob.at(t)
    px = robot.x + offset * math.cos(robot.yaw)
    if ob.plane == 0:
        py = robot.y + offset * math.sin(robot.yaw)
        d = math.hypot(o.center[0] - px, o.center[1] - py)
    else:
        d = math.hypot(o.center[0] - px, o.center[2] - robot.z)
    return d - max(o.semi_axes)


def body_gap(robot: SimpleRobot, ob: ScriptedObstacle, t: float, params) -> float:
    """Gap [m] between the obstacle's enclosing circle and what the filter protects.

    ``params.body_model == 'point'``: the paper's circle of radius robot_width/2 (x-y) or
    robot_height/2 (x-z) about the body point ``offset`` ahead; ``'body'``: the robot's cover
    (``c3bf.body``), its nearest circle in the obstacle's plane. Negative: they overlap.
    """
    from safe_legged_c3bf.c3bf import Plane
    from safe_legged_c3bf.c3bf.body import robot_body

    if params.body_model == "point":
        grow = params.robot_width if ob.plane == 0 else params.robot_height
        offset = params.offset if params.model == "unicycle" else 0.0
        return clearance(robot, ob, t, offset) - 0.5 * grow
    o = ob.at(t)
    c, s = math.cos(robot.yaw), math.sin(robot.yaw)
    plane = Plane.VERTICAL if ob.plane == 0 else Plane.HORIZONTAL
    gaps = []
    for p in robot_body(params.robot_body).points_in(plane):
        lx, ly, lz = p.offset
        px = robot.x + lx * c - ly * s
        if ob.plane == 0:
            d = math.hypot(o.center[0] - px, o.center[1] - (robot.y + lx * s + ly * c))
        else:
            d = math.hypot(o.center[0] - px, o.center[2] - (robot.z + lz))
        gaps.append(d - max(o.semi_axes) - p.radius)
    return min(gaps)
