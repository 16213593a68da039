"""The robot's progress to the scenario goal: distance and when it was first reached.

Distances are in the x-y plane of odom (m) between ``base_link`` and the goal position;
times are sim time (s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence


class GoalProgress:
    """Distance to the goal after every update, its minimum, and when it came within tolerance.

    Attributes:
        goal: (x, y) of the goal in odom (m).
        tolerance: the goal counts as reached within this distance (m).
        distance: distance at the last update (m; inf before any).
        min_distance: least distance so far (m; inf before any update).
        reached_time: sim time (s) of the first update within ``tolerance`` (None before).

    """

    def __init__(self, goal: Sequence[float], tolerance: float) -> None:
        """Start with no update: nothing reached, distances infinite."""
        self.goal = tuple(float(v) for v in goal)
        self.tolerance = tolerance
        self.distance = math.inf
        self.min_distance = math.inf
        self.reached_time: float | None = None

    @property
    def reached(self) -> bool:
        """Whether the goal has been reached (it stays reached)."""
        return self.reached_time is not None

    def update(self, t: float, position: Sequence[float]) -> None:
        """Record the robot at ``position`` (x, y[, z] in odom, m) at sim time ``t`` (s)."""
        distance = math.hypot(position[0] - self.goal[0], position[1] - self.goal[1])
        self.min_distance = min(self.min_distance, distance)
        if self.reached_time is None and distance <= self.tolerance:
            self.reached_time = t
        self.distance = distance
