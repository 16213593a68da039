"""Simulated obstacle perception: noisy positions and shapes, no velocities, drop-outs.

A detection frame contains every obstacle within ``max_range`` of the robot base (distance to
the obstacle's bounding cylinder) unless it drops out (independently per obstacle and frame
with ``dropout_probability``). The centre gets Gaussian noise N(bias, std^2) per axis and
each semi-axis N(0, size_noise_std^2) (clipped to stay positive); orientation and extent are
exact. Velocities are zero with ``VELOCITY_UNKNOWN``: estimating them is the tracker's job.
The covariance reported is diag(std^2).

The random stream comes from the scenario seed only, and one frame consumes a fixed number of
draws per obstacle, so the detection sequence is a deterministic function of the seed and the
number of frames taken.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from safe_legged_c3bf.sim.obstacles import VELOCITY_UNKNOWN, KinematicObstacle, ObstacleState
from safe_legged_c3bf.sim.scenario import PerceptionConfig


class PerceptionModel:
    """Turns true obstacle states into detections."""

    def __init__(self, config: PerceptionConfig, seed: int | np.random.SeedSequence) -> None:
        """Create the model with its own random generator seeded from ``seed``."""
        self.config = config
        self.rng = np.random.default_rng(seed)
        self.std = np.asarray(config.position_noise_std, dtype=float)
        self.bias = np.asarray(config.position_noise_bias, dtype=float)
        self.covariance = np.diag(self.std**2)
        self.frames = 0
        self.dropped = 0

    def detect(
        self,
        obstacles: Sequence[KinematicObstacle],
        truth: Sequence[ObstacleState],
        robot_position: np.ndarray,
        include_ids: bool = True,
    ) -> list[ObstacleState]:
        """One detection frame of the obstacles whose true states are ``truth``."""
        cfg = self.config
        out = []
        self.frames += 1
        for obstacle, true in zip(obstacles, truth, strict=True):
            # Fixed number of draws per obstacle, whatever is seen, keeps streams aligned.
            drop_draw = self.rng.random()
            noise = self.rng.standard_normal(3)
            size_noise = self.rng.standard_normal(2)
            distance = obstacle.distance_lower_bound(robot_position, true.center)
            if distance > cfg.max_range:
                continue
            if drop_draw < cfg.dropout_probability:
                self.dropped += 1
                continue
            center = true.center + self.bias + self.std * noise
            axes = np.asarray(true.semi_axes) + cfg.size_noise_std * size_noise
            axes = np.maximum(axes, 0.1 * np.asarray(true.semi_axes))
            out.append(
                ObstacleState(
                    id=true.id if include_ids else "",
                    plane=true.plane,
                    center=center,
                    velocity=np.zeros(3),
                    semi_axes=(float(axes[0]), float(axes[1])),
                    orientation=true.orientation,
                    extent=true.extent,
                    position_covariance=self.covariance.copy(),
                    velocity_covariance=np.zeros((3, 3)),
                    velocity_source=VELOCITY_UNKNOWN,
                )
            )
        return out
