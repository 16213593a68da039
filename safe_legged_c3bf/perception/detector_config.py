"""The obstacle detector's parameters (no ROS): ground, clustering, classification, shapes.

One frozen :class:`~safe_legged_c3bf.interfaces.typed_params.TypedParams` class, validated at
construction with messages that name the parameter. The node declares these fields flat,
beside its own (``perception/detector_params.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from safe_legged_c3bf.interfaces.typed_params import (
    NON_NEGATIVE,
    POSITIVE,
    TypedParams,
    at_least,
    interval,
    param,
)

__all__ = ["DetectorConfig"]


@dataclass(frozen=True)
class DetectorConfig(TypedParams):
    """Detector parameters; every field carries its unit and description."""

    ground_height: float = param(
        0.05, "m", "points lower than this above the ground plane z = 0 of odom are ground "
        "(plus the tilt allowance, see tilt_noise)", POSITIVE,
    )
    tilt_noise: float = param(
        0.02, "rad", "error allowed in the base's pitch and roll from /odom: the ground "
        "threshold grows by tan(tilt_noise) per metre of horizontal distance from the sensor, "
        "so that a ground return seen through a slightly wrong pitch is still ground",
        NON_NEGATIVE,
    )
    ground_touch_height: float = param(
        0.10, "m", "a column of points whose lowest point is within this of the ground "
        "threshold stands on the ground (VERTICAL); it must exceed the vertical spacing of "
        "the 3-D sensor's rows at the longest range of interest", POSITIVE,
    )
    max_height: float = param(
        2.0, "m", "points higher than this above the ground are ignored (ceilings)", POSITIVE
    )
    max_range: float = param(
        8.0, "m", "points farther than this from their sensor (horizontally) are ignored",
        POSITIVE,
    )
    voxel_size: float = param(
        0.04, "m", "edge of the voxels that thin dense returns before clustering", POSITIVE
    )
    cluster_tolerance: float = param(
        0.2, "m", "points (voxels) closer than this belong to one cluster (in 3-D; on x-y "
        "for the points of vertical obstacles); narrower gaps are too narrow for the robots "
        "anyway", POSITIVE,
    )
    scan_link_angle: float = param(
        0.17, "rad", "consecutive returns of the 2-D scan are one cluster when the surface "
        "between them is seen at more than this angle (a wall at a grazing angle is sampled "
        "sparsely along its length)", interval(0.0, 0.5 * math.pi, False, "pi/2"),
    )
    min_cluster_points: int = param(
        3, "-", "clusters with fewer points (a count) are dropped as noise", at_least(1)
    )
    column_cell: float = param(
        0.10, "m", "cell of the x-y grid whose 3 x 3 neighbourhood is a point's column: a "
        "point is grounded when its column reaches down to the ground", POSITIVE,
    )
    free_space_margin: float = param(
        0.05, "m", "a 3-D sensor ray is evidence of free space beneath a floating cluster when "
        "it passes at least this far below the cluster's underside and ends at least this "
        "far beyond it", NON_NEGATIVE,
    )
    free_space_azimuth: float = param(
        0.03, "rad", "a ray passes beneath a cluster point when their azimuths (about the "
        "sensor) differ by less than this; about two columns of the 3-D sensor", POSITIVE,
    )
    min_free_space_rays: int = param(
        3, "-", "rays (a count) passing beneath a floating cluster that make it HORIZONTAL; "
        "with fewer it is VERTICAL (its bottom may just be out of view)", at_least(1),
    )
    cloud_row_spacing: float = param(
        0.02, "rad", "vertical angle between the rows of the 3-D sensor (or more): the true "
        "underside of a floating cluster may lie up to one row below its lowest return, so "
        "the underside reported is that far lower at the cluster's distance (never below the "
        "highest ray seen passing beneath it)", interval(0.0, 0.5, False, "0.5"),
    )
    bar_memory: float = param(
        30.0, "s", "how long (sim time) a HORIZONTAL obstacle the 3-D sensor detected is "
        "remembered in odom after the last frame that detected it; floating points the "
        "frame would make VERTICAL (seen by the 2-D LiDAR alone, e.g. under the bar, where "
        "the forward sensor no longer sees it) that lie in a remembered bar's volume are the "
        "bar, not a wall, unless their column reaches the ground; remembered bars are "
        "reported; 0 forgets them at once (perception/bar_memory.py). 30 s: twice the "
        "longest passage measured (the A1 ducked under quadruped_horizontal's bar 13 s after "
        "the 3-D sensor last saw it); longer keeps a removed bar (the robot ducks for nothing)",
        NON_NEGATIVE,
    )
    bar_memory_keep_near: float = param(
        2.0, "m", "a remembered bar whose x-y box lies within this distance of the sensors is "
        "not forgotten however long ago the 3-D sensor saw it: close to a bar the forward "
        "sensor may not see it (random biped seed 7: stopped 1 m before a bar whose underside "
        "is at 1.15 m, out of view for 30 s, then forgotten: the biped walked on), and a "
        "robot stopped before a bar it cannot pass must not walk into it when the memory "
        "times out. 2 m: more than the 1.5 m before which the forward sensor detects a bar "
        "(benchmarks/detector_quality.py); 0 forgets by age alone", NON_NEGATIVE,
    )
    bar_memory_tolerance: float = param(
        0.05, "m", "growth of a remembered bar's volume (its x-z ellipse's box along x and z, "
        "half its extent along y) within which points are attributed to it; also how close "
        "two detections' x centres are to be the same bar", NON_NEGATIVE,
    )
    max_piece_length: float = param(
        0.5, "m", "vertical clusters longer than this along their major axis (walls, benches) "
        "are split into pieces at most this long; horizontal ones whose depth along x exceeds "
        "it are split along y", POSITIVE,
    )
    min_semi_axis: float = param(
        0.05, "m", "smallest semi-axis reported (a flat face has no measured depth)", POSITIVE
    )
    size_margin: float = param(
        0.02, "m", "added to the fitted semi-axes (gaps between returns, range noise)",
        NON_NEGATIVE,
    )
    circle_max_radius: float = param(
        0.6, "m", "largest radius of a circle fit (pillars, people); larger clusters are "
        "ellipses or pieces", POSITIVE,
    )
    circle_max_rms: float = param(
        0.02, "m", "largest RMS distance of the points from a fitted circle for it to be used",
        POSITIVE,
    )
    circle_min_arc: float = param(
        1.5, "rad", "smallest arc of the fitted circle the points must cover (a short, almost "
        "straight face fits any large circle)", interval(0.0, 2.0 * math.pi, True, "2 pi"),
    )
    position_std: float = param(
        0.02, "m", "floor of the standard deviation of a reported centre, per axis", POSITIVE
    )
    max_points: int = param(
        20000, "-", "most candidate points (a count) used per frame; more are thinned evenly "
        "(bounded work on a flood)", at_least(100),
    )
    max_obstacles: int = param(
        64, "-", "most obstacles (a count) reported per frame, nearest to the sensors first",
        at_least(1),
    )

    def __post_init__(self) -> None:
        """Validate the parameters (raises ``ValueError`` naming the bad one)."""
        self.validate()

    def check_together(self) -> None:
        """The tilt allowance is a small angle; voxels are finer than the cluster tolerance."""
        if self.tilt_noise >= 0.3:
            raise ValueError(f"tilt_noise: must be < 0.3 rad, got {self.tilt_noise!r}")
        if self.voxel_size >= self.cluster_tolerance:
            raise ValueError(
                f"voxel_size: must be smaller than cluster_tolerance ({self.cluster_tolerance}),"
                f" got {self.voxel_size!r}"
            )

    def ground_threshold(self, horizontal_distance: float | np.ndarray) -> float | np.ndarray:
        """Height (m, odom) below which a point this far (m) from its sensor is ground."""
        return self.ground_height + math.tan(self.tilt_noise) * horizontal_distance

    def touch_threshold(self, horizontal_distance: float | np.ndarray) -> float | np.ndarray:
        """Height (m, odom) below which a column this far (m) from its sensor is grounded."""
        return self.ground_threshold(horizontal_distance) + self.ground_touch_height
