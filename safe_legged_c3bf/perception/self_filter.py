"""Self-filter: drop the points a range sensor returns from the robot's own body (no ROS).

The robot's footprint is an axis-aligned box in base_link (REP-103: x forward, y left,
z up) that holds the trunk and the legs through their whole swing. Points inside it are the
robot itself (or something already in contact with it, which no detection can help with).
The boxes per robot kind come from the collision geometry (``sim/robots.py``,
``description/biped.urdf``) with a few centimetres of margin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["SelfBox", "default_self_box", "outside_self_box", "resolve_self_box"]


@dataclass(frozen=True)
class SelfBox:
    """The robot's footprint box in base_link.

    Attributes:
        lower: (3,) lowest x, y, z corner (m, base_link).
        upper: (3,) highest x, y, z corner (m, base_link).

    """

    lower: tuple[float, float, float]
    upper: tuple[float, float, float]

    def __post_init__(self) -> None:
        """Validate: finite corners with lower < upper on every axis (ValueError)."""
        lo, hi = np.asarray(self.lower, float), np.asarray(self.upper, float)
        if lo.shape != (3,) or hi.shape != (3,):
            raise ValueError("self box corners must have three values each")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError(f"self box corners must be finite, got {self.lower}, {self.upper}")
        if not np.all(lo < hi):
            raise ValueError(f"self box lower corner {self.lower} not below upper {self.upper}")


# A1: trunk 0.267 x 0.194 x 0.114 m about the base origin; hips at x = +-0.183 m and the
# feet within about +-0.30 m in x and +-0.17 m in y while trotting; feet ~0.3 m below.
_A1_BOX = SelfBox((-0.36, -0.21, -0.45), (0.36, 0.21, 0.12))
# Biped: torso 0.16 x 0.28 x 0.3 m centred 0.08 m above the base origin; feet 0.22 x 0.12 m
# at y = +-0.1 m, up to ~0.25 m ahead of or behind the base while walking, ~0.81 m below.
_BIPED_BOX = SelfBox((-0.30, -0.24, -0.95), (0.30, 0.24, 0.29))


def default_self_box(robot_kind: str) -> SelfBox:
    """The footprint box of a robot kind ('quadruped' or 'biped'); ValueError otherwise."""
    table = {"quadruped": _A1_BOX, "biped": _BIPED_BOX}
    if robot_kind not in table:
        raise ValueError(f"no self-filter box for robot kind {robot_kind!r}")
    return table[robot_kind]


def resolve_self_box(
    robot_kind: str, lower: tuple[float, ...], upper: tuple[float, ...]
) -> SelfBox:
    """The robot kind's box with each NaN-free corner given replacing its default."""
    box = default_self_box(robot_kind)
    lo = box.lower if any(math.isnan(v) for v in lower) else tuple(float(v) for v in lower)
    hi = box.upper if any(math.isnan(v) for v in upper) else tuple(float(v) for v in upper)
    return SelfBox(lo, hi)  # type: ignore[arg-type]


def outside_self_box(points_base: np.ndarray, box: SelfBox) -> np.ndarray:
    """(n,) True for the points (n, 3) in base_link (m) that lie outside ``box``."""
    p = np.asarray(points_base, dtype=float).reshape(-1, 3)
    inside = np.all((p >= np.asarray(box.lower)) & (p <= np.asarray(box.upper)), axis=1)
    return ~inside
