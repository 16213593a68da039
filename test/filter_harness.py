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
