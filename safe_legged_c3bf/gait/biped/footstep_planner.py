"""Footstep planning from a body velocity command.

A nominal *walking frame* sits midway between the feet. Each step advances it by the command
integrated over one step period, (vx T, vy T, yaw_rate T), and the new foot is placed half the
step width to its side. Every footstep is then clamped to the region reachable from the
support foot (forward/backward length, lateral width, outward/inward yaw), so any command
gives feasible, non-colliding footsteps. The planner is stateless: the controller calls it
every tick with the current support foot and command, which is how it re-plans when the
command changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.gait.biped.params import GaitParams, StepLimits
from safe_legged_c3bf.gait.biped.side import Side
from safe_legged_c3bf.interfaces.rotations import wrap_angle


def clamp(x: float, lo: float, hi: float) -> float:
    """Scalar clip (much cheaper than np.clip on a float)."""
    return lo if x < lo else hi if x > hi else x


@dataclass(frozen=True)
class Footstep:
    """A foot placement on flat ground: the sole point below the ankle and the foot heading.

    Attributes:
        side: which foot (a plain 'l' or 'r' is converted to :class:`Side`).
        x: position in odom (m).
        y: position in odom (m).
        yaw: heading about odom z (rad).

    """

    side: Side
    x: float
    y: float
    yaw: float

    def __post_init__(self) -> None:
        if not isinstance(self.side, Side):  # raises ValueError for anything but 'l', 'r'
            object.__setattr__(self, "side", Side(self.side))

    @classmethod
    def from_pose(cls, side: Side, pose: np.ndarray) -> Footstep:
        """The footstep of a sole pose (x, y, z, yaw) in odom (z is dropped)."""
        return cls(side, float(pose[0]), float(pose[1]), float(pose[3]))

    @property
    def xy(self) -> np.ndarray:
        """Position (2,)."""
        return np.array([self.x, self.y])

    def to_world(self, local_xy: np.ndarray) -> np.ndarray:
        """Map a point (2,) from this footstep's frame to odom."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        lx, ly = float(local_xy[0]), float(local_xy[1])
        return np.array([self.x + c * lx - s * ly, self.y + s * lx + c * ly])

    def to_local(self, world_xy: np.ndarray) -> np.ndarray:
        """Map a point (2,) from odom to this footstep's frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = float(world_xy[0]) - self.x, float(world_xy[1]) - self.y
        return np.array([c * dx + s * dy, -s * dx + c * dy])

    def moved(self, dxy: np.ndarray) -> Footstep:
        """The same footstep translated by ``dxy`` (2,) in odom."""
        return Footstep(self.side, self.x + float(dxy[0]), self.y + float(dxy[1]), self.yaw)


class FootstepPlanner:
    """Turns (vx, vy, yaw_rate) into a sequence of feasible footsteps."""

    def __init__(self, gait: GaitParams, limits: StepLimits) -> None:
        """Use the step period and width of ``gait`` and the reachability ``limits``."""
        self.gait = gait
        self.limits = limits

    def relative(self, support: Footstep, step: Footstep) -> np.ndarray:
        """(dx, dy, dyaw) of ``step`` in the frame of ``support``."""
        d = support.to_local(step.xy)
        return np.array([d[0], d[1], wrap_angle(step.yaw - support.yaw)])

    def clamp(self, support: Footstep, step: Footstep) -> Footstep:
        """Project ``step`` into the region reachable from ``support``."""
        lim = self.limits
        sigma = step.side.sign  # +1: the new foot lies to the left of the support
        dx, dy, dyaw = self.relative(support, step)
        dx = clamp(float(dx), -lim.max_backward, lim.max_forward)
        dy = sigma * clamp(sigma * float(dy), lim.min_width, lim.max_width)
        dyaw = sigma * clamp(sigma * float(dyaw), -lim.max_inward_yaw, lim.max_yaw)
        xy = support.to_world(np.array([dx, dy]))
        return Footstep(step.side, float(xy[0]), float(xy[1]), wrap_angle(support.yaw + dyaw))

    def is_feasible(self, support: Footstep, step: Footstep, tol: float = 1e-6) -> bool:
        """Return True when ``step`` lies in the region reachable from ``support``."""
        lim = self.limits
        sigma = step.side.sign
        dx, dy, dyaw = self.relative(support, step)
        return bool(
            -lim.max_backward - tol <= dx <= lim.max_forward + tol
            and lim.min_width - tol <= sigma * dy <= lim.max_width + tol
            and -lim.max_inward_yaw - tol <= sigma * dyaw <= lim.max_yaw + tol
            and step.side != support.side
        )

    def next_step(self, support: Footstep, command: np.ndarray) -> Footstep:
        """The footstep after ``support`` for the command (vx, vy, yaw_rate)."""
        period = self.gait.step_period
        half = 0.5 * self.gait.step_width
        s = support.side.sign
        # walking frame midway between the feet, advanced by one step of the command
        body = support.to_world(np.array([0.0, -s * half]))
        dyaw = float(command[2]) * period
        mid = support.yaw + 0.5 * dyaw
        c, sn = math.cos(mid), math.sin(mid)
        vx, vy = float(command[0]) * period, float(command[1]) * period
        body = body + np.array([c * vx - sn * vy, sn * vx + c * vy])
        yaw = support.yaw + dyaw
        foot = body + (-s * half) * np.array([-math.sin(yaw), math.cos(yaw)])
        step = Footstep(support.side.other, float(foot[0]), float(foot[1]), wrap_angle(yaw))
        return self.clamp(support, step)

    def next_target(self, support: Footstep, command: np.ndarray, moving: bool) -> Footstep:
        """The footstep after ``support``: for ``command`` when ``moving``, else aligning."""
        if moving:
            return self.next_step(support, command)
        return self.aligned_step(support)

    def plan(self, support: Footstep, command: np.ndarray, count: int) -> list[Footstep]:
        """The next ``count`` footsteps after ``support`` (alternating sides)."""
        steps = []
        current = support
        for _ in range(count):
            current = self.next_step(current, command)
            steps.append(current)
        return steps

    def aligned_step(self, support: Footstep) -> Footstep:
        """The footstep that brings the other foot beside ``support`` (standing posture)."""
        return self.next_step(support, np.zeros(3))

    def is_aligned(self, support: Footstep, step: Footstep, tol_xy=0.02, tol_yaw=0.05) -> bool:
        """Return True when ``step`` is (nearly) the standing placement beside ``support``."""
        ref = self.aligned_step(support)
        return bool(
            math.hypot(step.x - ref.x, step.y - ref.y) <= tol_xy
            and abs(wrap_angle(step.yaw - ref.yaw)) <= tol_yaw
        )

    def zmp_point(self, step: Footstep) -> np.ndarray:
        """ZMP reference point (2,) of a foot: sole centre, shifted inwards."""
        inward = -step.side.sign * self.gait.zmp_inward
        return step.to_world(np.array([self.gait.zmp_offset_x, inward]))

    @staticmethod
    def first_swing_side(command: np.ndarray, tol: float = 1e-3) -> Side:
        """Which foot starts a walk: the one on the side the robot moves or turns to."""
        vy, wz = float(command[1]), float(command[2])
        if abs(vy) > tol:
            return Side.LEFT if vy > 0 else Side.RIGHT
        if abs(wz) > tol:
            return Side.LEFT if wz > 0 else Side.RIGHT
        return Side.LEFT


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (k, 2) of 2-D ``points`` (monotone chain)."""
    pts = np.unique(np.asarray(points, dtype=float).round(12), axis=0)
    if len(pts) <= 2:
        return pts

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def clip_to_polygon(point: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """The point of the convex CCW ``polygon`` (k, 2) nearest to ``point`` (2,)."""
    px, py = float(point[0]), float(point[1])
    verts = polygon.tolist()
    n = len(verts)
    inside = True
    best, best_d = None, math.inf
    for i in range(n):
        ax, ay = verts[i]
        bx, by = verts[(i + 1) % n]
        ex, ey = bx - ax, by - ay
        rx, ry = px - ax, py - ay
        if ex * ry - ey * rx < 0.0:
            inside = False
        length2 = ex * ex + ey * ey
        s = clamp((rx * ex + ry * ey) / length2, 0.0, 1.0) if length2 > 0.0 else 0.0
        cx, cy = ax + s * ex, ay + s * ey
        d = (px - cx) ** 2 + (py - cy) ** 2
        if d < best_d:
            best, best_d = (cx, cy), d
    if inside or best is None:
        return np.array([px, py])
    return np.array(best)
