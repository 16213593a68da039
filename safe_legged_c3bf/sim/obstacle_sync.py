"""Keeping the moving obstacles on their scripts while PyBullet steps the world.

A moving :class:`~safe_legged_c3bf.sim.obstacles.KinematicObstacle` is re-placed on its
script (pose and velocity) at least every ``sync_steps`` physics steps and at the step of
every scripted velocity change; PyBullet integrates its velocity in between. Positions are
obstacle centres (x, y, z) in odom (m); times are sim time (s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from safe_legged_c3bf.sim.obstacles import KinematicObstacle


class ObstacleSync:
    """Re-places the moving obstacles around each physics step and tracks all centres.

    Attributes:
        obstacles: all obstacles of the world, in scenario order.
        moving: indices of the obstacles whose script moves them.
        centers: every obstacle's centre after the last step (the script's at t = 0 before).

    """

    def __init__(
        self, obstacles: Sequence[KinematicObstacle], sync_steps: int, physics_dt: float
    ) -> None:
        """Track ``obstacles``; re-place each at least every ``sync_steps`` steps."""
        self.obstacles = list(obstacles)
        self.moving = [i for i, o in enumerate(self.obstacles) if o.moving]
        self.centers = [o.script.state(0.0)[0] for o in self.obstacles]
        self._next_sync = {i: 0 for i in self.moving}
        self._sync_steps = int(sync_steps)
        self._dt = physics_dt

    def before_step(self, k: int, t: float) -> None:
        """Re-place the obstacles due at step ``k`` (sim time ``t`` = k * physics_dt)."""
        next_sync = self._next_sync
        for i in self.moving:
            if k >= next_sync[i]:
                self._sync(i, k, t)

    def after_step(self) -> None:
        """Read the moving obstacles' centres back from PyBullet."""
        obstacles, centers = self.obstacles, self.centers
        for i in self.moving:
            centers[i] = obstacles[i].body_position()

    def _sync(self, i: int, k: int, t: float) -> None:
        obstacle = self.obstacles[i]
        obstacle.sync(t)
        change = obstacle.script.next_change(t)
        next_step = k + self._sync_steps
        if math.isfinite(change):
            next_step = min(next_step, max(k + 1, math.ceil(change / self._dt - 1e-9)))
        self._next_sync[i] = next_step
