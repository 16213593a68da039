"""Coasting tracks' growth with and without ``hold_growth_inside``, on recorded sensor runs.

A confirmed track without detections grows by ``coast_growth`` (0.3 m/s) and near the walking
robot is kept up to 5 s. ``hold_growth_inside`` (``perception/hidden_tracks.py``) stops the
growth while a detection of the batch covers the track's predicted centre (a piece of an
obstacle now detected with its neighbour). This script feeds the ``/odom``, ``/scan`` and
``/obstacles/detections`` of MCAP recordings (``bringup --perception sensors --record FILE``)
to the obstacle tracker node (as ``benchmarks/scan_clearing_replay.py`` does), with the
sensors configuration and the flag off, then on, and prints per recording and overall, from
the confirmed vertical tracks sampled at 10 Hz:

- oversized near the robot: track-frames within 1 m of the robot's base whose largest
  semi-axis exceeds the largest of the nearest true obstacle (``/ground_truth/obstacles``) by
  more than 0.3 m;
- robot covered: samples in which the robot's base lies in a track's circle (largest
  semi-axis) while no true obstacle's circle comes within 0.3 m of it (the filter then
  escapes from inside nothing);
- true obstacles missed near the robot (the safety side): true obstacles within 1 m of the
  base whose centre lies in no track's circle grown by 0.2 m (equal both ways if the flag
  costs no coverage).

Usage::

    python benchmarks/coast_growth_replay.py REC.mcap [REC.mcap ...] [--robot biped]
"""

from __future__ import annotations

import numpy as np
from scan_clearing_replay import off_and_on

NEAR = 1.0  # m from the robot's base
OVERSIZE = 0.3  # m beyond the nearest true obstacle's largest semi-axis
FREE = 0.3  # m: no true obstacle this close to the base
COVER = 0.2  # m a track's circle is grown by when asking whether it covers a true centre
COLUMNS = ("frames", "oversized_near", "robot_covered", "missed_near")


def _circles(obstacles: list) -> tuple[np.ndarray, np.ndarray]:
    """Centres (n, 2) and largest semi-axes (n,) of vertical obstacles (messages or tracks)."""
    centres, radii = [], []
    for o in obstacles:
        c = o.center
        centres.append((c.x, c.y) if hasattr(c, "x") else (float(c[0]), float(c[1])))
        radii.append(max(o.semi_axis_a, o.semi_axis_b) if hasattr(o, "semi_axis_a")
                     else max(o.semi_axes))
    return np.array(centres, dtype=float).reshape(-1, 2), np.array(radii, dtype=float)


def _sample(tracks: list, truth: list, robot_xy: np.ndarray, out: dict[str, int]) -> None:
    tracks = [o for o in tracks if o.plane == 0]
    t_c, t_r = _circles(tracks)
    g_c, g_r = _circles(truth)
    out["frames"] = out.get("frames", 0) + len(tracks)
    for c, r in zip(t_c, t_r, strict=True):
        if float(np.linalg.norm(c - robot_xy)) - r >= NEAR or not len(g_c):
            continue
        nearest = int(np.argmin(np.linalg.norm(g_c - c, axis=1) - g_r))
        out["oversized_near"] = out.get("oversized_near", 0) + int(r > g_r[nearest] + OVERSIZE)
    truth_gap = np.linalg.norm(g_c - robot_xy, axis=1) - g_r if len(g_c) else np.array([])
    covered = bool(len(t_c)) and bool(np.any(np.linalg.norm(t_c - robot_xy, axis=1) < t_r))
    if covered and not np.any(truth_gap < FREE):
        out["robot_covered"] = out.get("robot_covered", 0) + 1
    for c, gap in zip(g_c, truth_gap, strict=True):
        if gap < NEAR and not np.any(np.linalg.norm(t_c - c, axis=1) < t_r + COVER):
            out["missed_near"] = out.get("missed_near", 0) + 1


def main() -> int:
    header = f"{'recording':<24} {'hold':>5} " + " ".join(f"{c:>14}" for c in COLUMNS)
    return off_and_on(__doc__.split("\n\n")[0], "hold_growth_inside", header, _sample, _line)


def _line(name: str, hold: bool, counts: dict[str, int]) -> None:
    cells = " ".join(f"{counts.get(c, 0):>14}" for c in COLUMNS)
    print(f"{name:<24} {'on' if hold else 'off':>5} {cells}")


if __name__ == "__main__":
    raise SystemExit(main())
