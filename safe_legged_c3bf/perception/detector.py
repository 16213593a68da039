"""Obstacle detector: a 2-D scan and a 3-D cloud in odom -> obstacle ellipses (no ROS).

Usage::

    detector = ObstacleDetector(DetectorConfig())
    report = detector.detect(scan=scan_frame, cloud=cloud_frame)   # either may be None
    report.obstacles  # DetectedObstacle list: no ids, VELOCITY_UNKNOWN

One frame, in order:

1. **Ground and range** (``ground.py``): ground returns, points above ``max_height`` and
   points farther than ``max_range`` from their sensor are dropped (the self-filter already
   ran when the frames were made, ``sensor_frame.py``). The scan and the cloud are fused
   point by point from here on; more than ``max_points`` candidates are thinned evenly.
2. **Standing or floating** (``free_space.py``): candidates whose x-y column reaches the
   ground are *grounded*. The others are clustered; a floating cluster becomes
   **HORIZONTAL** only if the 3-D cloud saw part of it *and* at least
   ``min_free_space_rays`` cloud rays pass beneath it and end beyond it. Otherwise it joins
   the vertical points: something seen only by the 2-D LiDAR (outside the 3-D sensor's view)
   is VERTICAL, as is anything whose foot is merely out of view. Scan returns of a
   horizontal cluster outside the cloud's view stay with it only on the bar's line, and not
   in a column seen standing under a remembered bar (step 3).
3. **Remembered bars** (``bar_memory.py``): the HORIZONTAL obstacles are remembered in odom
   for ``bar_memory`` s after the last frame that detected them. Candidates about to be
   VERTICAL whose column does not reach the ground and that lie in a remembered bar's volume
   (grown by ``bar_memory_tolerance``) are that bar's: under a bar the forward sensor no
   longer sees it, while the LiDAR plane of a ducked body cuts it. Not those in a column seen
   standing up into the bar within ``bar_memory`` (its posts), off the line of the bar's cut
   or next to a point that stays VERTICAL: what stands under a bar stays VERTICAL. Every
   remembered bar is reported, once (a bar detected again is merged with its memory).
4. **Clusters and shapes** (``clustering.py``, ``shapes.py``): the vertical points are
   clustered on x-y (a vertical obstacle is extruded along z: what a bar's shadow splits
   into an upper and a lower part of a pillar is one pillar) and each cluster becomes a
   circle, an ellipse or several pieces; each horizontal cluster (clustered in 3-D) an x-z
   ellipse whose underside is one row of the 3-D sensor below its lowest return (never
   below the highest ray seen passing beneath it, ``free_space.underside``). Consecutive
   scan returns on one surface are joined whatever their spacing (``scan_link_angle``).

How the scan and the cloud fuse: a LiDAR whose plane cuts a bar returns points on the bar;
they cluster with the cloud's points of the same bar, their columns hold no ground-reaching
point, and the cloud's rays beneath the bar make the whole cluster HORIZONTAL. So a bar cut
by the scan plane is never reported as a vertical obstacle while the cloud sees the bar
above free space, nor, for ``bar_memory`` s after it last did, where the cloud no longer sees
it (under it, or right before it). A LiDAR point on a pillar shares its column with the
cloud's points of the pillar's foot and is grounded, and stays VERTICAL under a bar too.

Before the cloud has seen a bar (the first frame, a robot with a LiDAR only), the LiDAR's cut
through it is a floating cluster seen by the scan alone: VERTICAL, the safe default.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from safe_legged_c3bf.perception.bar_memory import BarMemory
from safe_legged_c3bf.perception.clustering import cluster_labels, scan_links
from safe_legged_c3bf.perception.detector_config import DetectorConfig
from safe_legged_c3bf.perception.free_space import (
    covered_by_cloud,
    grounded_mask,
    rays_beneath,
    underside,
)
from safe_legged_c3bf.perception.ground import split_by_height
from safe_legged_c3bf.perception.sensor_frame import SensorFrame
from safe_legged_c3bf.perception.shapes import DetectedObstacle, fit_horizontal, fit_vertical
from safe_legged_c3bf.safety import cap_nearest

__all__ = ["DetectionReport", "ObstacleDetector"]


@dataclass(frozen=True)
class DetectionReport:
    """What one frame gave.

    Attributes:
        obstacles: the detected obstacles (odom), nearest to the sensors first at most
            ``max_obstacles``.
        points: returns received (outside the self box).
        ground: returns removed as ground.
        candidates: returns kept as possible obstacles.
        thinned: candidates dropped by ``max_points``.
        vertical_clusters: vertical clusters found.
        horizontal_clusters: horizontal (floating, free space beneath) clusters found.
        dropped_obstacles: obstacles beyond ``max_obstacles``.
        remembered_bars: bars reported from the memory (not detected in this frame).
        absorbed: candidates attributed to remembered bars (not VERTICAL).

    """

    obstacles: list[DetectedObstacle] = field(default_factory=list)
    points: int = 0
    ground: int = 0
    candidates: int = 0
    thinned: int = 0
    vertical_clusters: int = 0
    horizontal_clusters: int = 0
    dropped_obstacles: int = 0
    remembered_bars: int = 0
    absorbed: int = 0


@dataclass(frozen=True)
class _Candidates:
    """Candidate points of one frame (positions, sensor origins, cloud flags, touch heights).

    ``links``: pairs of consecutive scan returns on one surface (indices into these arrays).
    """

    points: np.ndarray
    origins: np.ndarray
    from_cloud: np.ndarray
    touch: np.ndarray
    links: np.ndarray

    def links_within(self, subset: np.ndarray) -> np.ndarray:
        """The links between members of ``subset`` (sorted indices), as positions in it."""
        position = np.full(self.points.shape[0], -1, dtype=np.int64)
        position[subset] = np.arange(subset.size)
        pairs = position[self.links]
        return pairs[np.all(pairs >= 0, axis=1)]


class ObstacleDetector:
    """Detects obstacles in fused scan and cloud frames (see the module doc)."""

    def __init__(self, config: DetectorConfig | None = None) -> None:
        """A detector with ``config`` (defaults if None) and an empty bar memory."""
        self.config = config or DetectorConfig()
        self.memory = BarMemory()

    def configure(self, config: DetectorConfig) -> None:
        """Use ``config`` from the next frame on; the remembered bars are kept."""
        self.config = config

    def clear(self) -> None:
        """Forget the remembered bars (a new run, odometry reset)."""
        self.memory.clear()

    def detect(
        self, scan: SensorFrame | None = None, cloud: SensorFrame | None = None
    ) -> DetectionReport:
        """Obstacles in a scan frame and/or a cloud frame (both in odom)."""
        frames = [f for f in (scan, cloud) if f is not None]
        if not frames:
            return DetectionReport()
        points = np.vstack([f.points for f in frames])
        origins = np.vstack([f.origins for f in frames])
        from_cloud = np.concatenate([np.full(len(f.points), f.is_cloud) for f in frames])
        beams = np.concatenate([f.beam_index() for f in frames])
        split = split_by_height(points, origins, self.config)
        keep = np.flatnonzero(split.candidate)
        thinned = 0
        if keep.size > self.config.max_points:  # flood: an even stride, deterministic
            chosen = np.linspace(0, keep.size - 1, self.config.max_points).astype(np.int64)
            thinned = keep.size - chosen.size
            keep = keep[chosen]
        links = np.zeros((0, 2), dtype=np.int64)
        if scan is not None:
            links = scan_links(
                beams[keep], points[keep], origins[keep], scan.angle_increment,
                scan.beam_count, self.config.scan_link_angle,
            )
        cand = _Candidates(
            points[keep], origins[keep], from_cloud[keep],
            np.asarray(self.config.touch_threshold(split.distance[keep])), links,
        )
        grounded = grounded_mask(cand.points, cand.touch, self.config.column_cell)
        vertical, horizontal = self._classify(cand, grounded, cloud)
        fresh: list[DetectedObstacle] = []
        for members, bottom in horizontal:
            view = cand.origins[members].mean(axis=0)
            fresh.extend(fit_horizontal(cand.points[members], view, self.config, bottom))
        newest = max(frames, key=lambda f: f.stamp)
        now = newest.stamp
        sensors_xy = np.asarray(newest.origin[:2], dtype=float)
        vertical, absorbed = self._remember(cand, grounded, vertical, fresh, now, sensors_xy)
        obstacles = self.memory.obstacles(now, absorbed)
        remembered = sum(b.last_seen != now for b in self.memory.bars)
        labels = cluster_labels(
            cand.points[vertical], self.config.voxel_size, self.config.cluster_tolerance,
            self.config.min_cluster_points, planar=True, links=cand.links_within(vertical),
        )
        n_vertical = int(labels.max()) + 1 if labels.size else 0
        for k in range(n_vertical):  # one fit per cluster
            members = vertical[labels == k]
            view = cand.origins[members].mean(axis=0)
            obstacles.extend(fit_vertical(cand.points[members], view, self.config))
        viewpoint = np.vstack([f.origin for f in frames]).mean(axis=0)
        kept = self._nearest(obstacles, viewpoint)
        return DetectionReport(
            obstacles=kept,
            points=int(points.shape[0]),
            ground=int(np.count_nonzero(split.ground)),
            candidates=int(keep.size),
            thinned=thinned,
            vertical_clusters=n_vertical,
            horizontal_clusters=len(horizontal),
            dropped_obstacles=len(obstacles) - len(kept),
            remembered_bars=remembered,
            absorbed=int(absorbed.sum()),
        )

    def _classify(
        self, cand: _Candidates, grounded: np.ndarray, cloud: SensorFrame | None
    ) -> tuple[np.ndarray, list[tuple[np.ndarray, float]]]:
        """Vertical candidates' indices; each horizontal cluster's members and underside (m).

        ``grounded``: (n,) the candidates whose column reaches the ground.
        """
        n = cand.points.shape[0]
        if n == 0:
            return np.zeros(0, dtype=np.int64), []
        floating = np.flatnonzero(~grounded)
        if floating.size == 0 or cloud is None or not np.any(cand.from_cloud[floating]):
            return np.arange(n), []
        labels = cluster_labels(
            cand.points[floating], self.config.voxel_size, self.config.cluster_tolerance,
            self.config.min_cluster_points, links=cand.links_within(floating),
        )
        overhead = np.zeros(n, dtype=bool)
        horizontal: list[tuple[np.ndarray, float]] = []
        for k in range(int(labels.max()) + 1 if labels.size else 0):  # per cluster
            members = floating[labels == k]
            if not np.any(cand.from_cloud[members]):
                continue  # seen by the scan alone: its height is unknown, it stays vertical
            members = members[covered_by_cloud(
                cand.points[members], cand.from_cloud[members], cloud.origin,
                self.config.free_space_margin,
            )]
            # Scan returns in a column seen standing under a remembered bar (its posts)
            # are not the bar, even on its line.
            standing = self.memory.standing(cand.points[members, :2], self.config.column_cell)
            members = members[cand.from_cloud[members] | ~standing]
            free = rays_beneath(cand.points[members], cloud.origin, cloud.points, self.config)
            if free.rays >= self.config.min_free_space_rays:
                overhead[members] = True
                bottom = underside(cand.points[members], cloud.origin, free, self.config)
                horizontal.append((members, bottom))
        return np.flatnonzero(~overhead), horizontal

    def _remember(
        self,
        cand: _Candidates,
        grounded: np.ndarray,
        vertical: np.ndarray,
        fresh: list[DetectedObstacle],
        now: float,
        sensors_xy: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Remember ``fresh`` bars; the vertical candidates left and points absorbed per bar.

        ``sensors_xy``: x, y (m, odom) of the newest frame's sensor (bars near it are kept).

        Only the floating (not grounded) vertical candidates in a remembered bar's volume,
        on the line of its cut, may be absorbed, none whose column was seen standing up into
        the bar's band within ``bar_memory``, and none within ``cluster_tolerance`` (x-y) of
        a vertical point that stays (``BarMemory.absorb``): what stands under or beside a
        bar stays VERTICAL.
        """
        c = self.config
        self.memory.update(fresh, now, c.bar_memory, c.bar_memory_tolerance, sensors_xy,
                           c.bar_memory_keep_near)
        self.memory.stand(
            cand.points[grounded], now, c.column_cell, c.bar_memory_tolerance,
            c.bar_memory_tolerance + c.cluster_tolerance,
        )
        is_vertical = np.zeros(cand.points.shape[0], dtype=bool)
        is_vertical[vertical] = True
        owner = self.memory.absorb(
            cand.points, is_vertical & ~grounded, is_vertical & grounded,
            c.bar_memory_tolerance, c.cluster_tolerance, c.column_cell,
        )
        absorbed = np.bincount(owner[owner >= 0], minlength=len(self.memory))
        return np.flatnonzero(is_vertical & (owner < 0)), absorbed

    def _nearest(
        self, obstacles: list[DetectedObstacle], viewpoint: np.ndarray
    ) -> list[DetectedObstacle]:
        """At most ``max_obstacles``, the nearest to ``viewpoint`` (x, y), nearest first."""
        if not obstacles:
            return []
        centers = np.array([o.center for o in obstacles])
        keep = cap_nearest(centers[:, :2], viewpoint[:2], self.config.max_obstacles)
        d = np.hypot(*(centers[keep, :2] - viewpoint[:2]).T)
        return [obstacles[i] for i in keep[np.argsort(d, kind="stable")]]
