"""Speeds the tracker gives static obstacles, on the detector's output from recorded runs.

The detector's clusters change shape as the robot moves (a walker seen from another side, a
wall cut into other pieces, a bar coming into the 3-D sensor's view), so their centres jump
without the obstacle moving. This benchmark feeds the ``/obstacles/detections`` of MCAP
recordings (``bringup --perception sensors --record FILE``; ``benchmarks/detector_quality.py``
writes seven) through the tracker with several configurations, matches every confirmed track
with an estimated velocity to the nearest true obstacle of ``/ground_truth/obstacles`` and
prints, for the tracks of static obstacles, their speed in the obstacle's plane (x-y for a
vertical obstacle, x-z for a bar: the velocity the filter uses) with its median, 95th
percentile and maximum
(m/s) and the share of track-frames above 0.2 m/s, and for the tracks of moving obstacles
the median and 90th percentile of their velocity error (m/s).

Usage::

    python benchmarks/tracker_static_speed.py runs/detector-quality/*.mcap
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from detector_quality import read_messages  # the same folder: benchmarks/

from safe_legged_c3bf.nodes.obstacle_tracker_node import detections_from_msg
from safe_legged_c3bf.perception.track import ObstaclePlane, TrackConfig, plane_axes
from safe_legged_c3bf.perception.tracker import MultiObstacleTracker, TrackerConfig

#: Configurations compared (label, tracker config). "s10-16": the sensors configuration of
#: sessions 10 to 16 (manoeuvre detector off, accel_psd 1e-3); since session 17 sensors use
#: the default.
CONFIGS = (
    ("default (also sensors, s17)", TrackerConfig()),
    ("default, detection covariance", TrackerConfig(
        track=TrackConfig(use_detection_covariance=True))),
    ("no manoeuvre detector", TrackerConfig(track=TrackConfig(maneuver_detection=False))),
    ("sensors s10-16 (no manoeuvre)", TrackerConfig(
        track=TrackConfig(maneuver_detection=False, accel_psd=1e-3))),
    ("s10-16, velocity after 10 hits", TrackerConfig(track=TrackConfig(
        maneuver_detection=False, accel_psd=1e-3, velocity_min_hits=10))),
    ("s10-16, detection covariance", TrackerConfig(track=TrackConfig(
        maneuver_detection=False, accel_psd=1e-3, use_detection_covariance=True))),
)
FAST = 0.2  # m/s: a speed counted as "looks like it moves"


def load(path: Path) -> tuple[list, list]:
    """``(ground truth, detections)`` from a recording: (t in s, obstacles) per ground-truth
    message, (t in s, ObstacleArray) per detection message."""
    from safe_legged_c3bf.interfaces import topics

    truth, detections = topics.GROUND_TRUTH_OBSTACLES.name, topics.OBSTACLE_DETECTIONS.name
    names = read_messages(path, [truth, detections])

    def stamp(m) -> float:  # noqa: ANN001 - a message with a header
        return m.header.stamp.sec + m.header.stamp.nanosec * 1e-9

    return ([(stamp(m), m.obstacles) for m in names[truth]],
            [(stamp(m), m) for m in names[detections]])


def _distance(truth, center: np.ndarray) -> float:  # noqa: ANN001 - Obstacle message
    """Distance (m) in the true obstacle's plane: x-y (vertical) or x-z (horizontal)."""
    other = truth.center.y if truth.plane == ObstaclePlane.VERTICAL else truth.center.z
    mine = center[1] if truth.plane == ObstaclePlane.VERTICAL else center[2]
    return math.hypot(truth.center.x - center[0], other - mine)


def track_speeds(gt: list, det: list, config: TrackerConfig) -> tuple[np.ndarray, np.ndarray]:
    """Static obstacles' speeds and moving obstacles' velocity errors (m/s), per track-frame.

    Every confirmed, velocity-estimated track is matched to the nearest true obstacle.
    """
    tracker = MultiObstacleTracker(config)
    speeds, errors, k = [], [], 0
    for t, message in det:
        tracker.update(detections_from_msg(message), t)
        while k + 1 < len(gt) and gt[k + 1][0] <= t:
            k += 1
        truths = gt[k][1]
        for track in tracker.tracks_at(t):
            if not track.velocity_estimated or not truths:
                continue
            center = np.asarray(track.center, dtype=float)
            near = min(truths, key=lambda q, c=center: _distance(q, c))
            v = np.array([near.velocity.x, near.velocity.y, near.velocity.z])
            axes = list(plane_axes(track.plane))  # what the filter uses: the plane's velocity
            estimate = np.asarray(track.velocity, dtype=float)[axes]
            if np.linalg.norm(v) < 1e-6:
                speeds.append(float(np.linalg.norm(estimate)))
            else:
                errors.append(float(np.linalg.norm(estimate - v[axes])))
    return np.array(speeds), np.array(errors)


def start_latencies(gt: list, det: list, config: TrackerConfig, window: float = 3.0
                    ) -> np.ndarray:
    """Seconds from each start of a true vertical obstacle to its track knowing it (NaN: not
    within ``window`` s).

    A start: the obstacle's true speed goes from below 0.02 m/s to above 0.1 m/s. Known: the
    nearest confirmed, velocity-estimated track within 0.5 m has half the true speed or more
    along the true velocity (in x-y). An obstacle already moving in the first ground-truth
    message has no start; one out of view when it starts counts from its start.
    """
    starts, before = {}, {}
    for t, truths in gt:
        for o in truths:
            speed = math.hypot(o.velocity.x, o.velocity.y)
            if o.plane == ObstaclePlane.VERTICAL and o.id not in starts \
                    and before.get(o.id, 1.0) < 0.02 and speed > 0.1:
                starts[o.id] = t
            before[o.id] = speed
    tracker, k, found = MultiObstacleTracker(config), 0, {}
    for t, message in det:
        tracker.update(detections_from_msg(message), t)
        while k + 1 < len(gt) and gt[k + 1][0] <= t:
            k += 1
        now = {o.id: o for o in gt[k][1]}
        for oid, t0 in starts.items():
            if oid in found or not t0 <= t <= t0 + window or oid not in now:
                continue
            o = now[oid]
            v = np.array([o.velocity.x, o.velocity.y])
            near = [(math.hypot(tr.center[0] - o.center.x, tr.center[1] - o.center.y), tr)
                    for tr in tracker.tracks_at(t) if tr.plane == ObstaclePlane.VERTICAL
                    and tr.velocity_estimated]
            near = [n for n in near if n[0] < 0.5]
            if near and np.asarray(min(near, key=lambda n: n[0])[1].velocity)[:2] @ v \
                    >= 0.5 * float(v @ v):
                found[oid] = t - t0
    return np.array([found.get(oid, math.nan) for oid in starts])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("recordings", nargs="+", type=Path, help="MCAP files")
    args = parser.parse_args(argv)
    print(f"{'recording':<22} {'tracker':<40} {'frames':>6} {'p50':>6} {'p95':>6} "
          f"{'max':>6} {'>0.2':>6}  (m/s)  movers' error p50 / p90 (m/s)")
    for path in args.recordings:
        gt, det = load(path)
        for label, config in CONFIGS:
            s, e = track_speeds(gt, det, config)
            moving = (f"{np.median(e):.3f} / {np.percentile(e, 90):.3f} ({len(e)})"
                      if len(e) else "-")
            if not len(s):
                print(f"{path.stem:<22} {label:<40} no static-obstacle tracks; movers {moving}")
                continue
            print(f"{path.stem:<22} {label:<40} {len(s):>6} {np.median(s):>6.3f} "
                  f"{np.percentile(s, 95):>6.3f} {s.max():>6.3f} {np.mean(s > FAST):>6.1%}  "
                  f"{moving}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
