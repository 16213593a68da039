"""How well the gait controllers track the filtered command: the error the filter's margins face.

The safety filter plans with the commanded velocity; the robot walks at its own. For every
run folder given (``timeseries.npz`` of a bringup or an evaluation run) this compares the
measured base velocity (/odom, base_link: forward, lateral, yaw rate) with /cmd_vel_safe held
at each odometry sample, both averaged over ``--window`` s (a gait's sway averages out over a
step cycle), and prints per robot the distribution of the error and of the **drift**: how far
the base strays in ``--horizon`` s from where the commanded velocity would have put it (the
distance a margin has to absorb between two looks of the filter at a slow obstacle).

Usage: python benchmarks/velocity_tracking.py RUN_DIR [RUN_DIR ...] [--window 1.0]
       [--horizon 1.0]        (e.g. runs/rq/runs/*)
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def _held(t_cmd: np.ndarray, cmd: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The command in force at each time ``t`` (zero before the first one)."""
    i = np.searchsorted(t_cmd, t, side="right") - 1
    out = np.where(i[:, None] >= 0, cmd[np.maximum(i, 0)], 0.0)
    return out


def _mean_over(t: np.ndarray, x: np.ndarray, window: float) -> np.ndarray:
    """Trailing mean of ``x`` (rows at times ``t``) over ``window`` s, time-weighted."""
    dt = np.diff(t, prepend=t[0])
    cx = np.cumsum(x * dt[:, None], axis=0)
    ct = np.cumsum(dt)
    j = np.searchsorted(t, t - window, side="left")
    span = np.maximum(ct - ct[j], 1e-9)
    return (cx - cx[j]) / span[:, None]


def run_errors(run: Path, window: float, horizon: float):
    """(robot, error rows (vx, vy, wz), drift [m]) of one run folder, or None."""
    try:
        with np.load(run / "timeseries.npz") as z:
            odom, cmd = np.asarray(z["odom"]), np.asarray(z["cmd_vel_safe"])
        robot = json.loads((run / "report.json").read_text())["summary"]["robot"]
    except (OSError, KeyError, ValueError):
        return None
    if len(odom) < 50 or len(cmd) < 10:
        return None
    t = odom[:, 0]
    measured = odom[:, [5, 6, 8]]  # base_link vx, vy, yaw rate
    commanded = _held(cmd[:, 0], cmd[:, [1, 2, 4]], t)
    keep = t >= t[0] + window
    err = (_mean_over(t, measured, window) - _mean_over(t, commanded, window))[keep]
    # Drift over the horizon: the base's displacement against the command's, in the plane.
    yaw = odom[:, 4]
    c, s = np.cos(yaw), np.sin(yaw)
    dv = measured[:, :2] - commanded[:, :2]
    dv_odom = np.column_stack([c * dv[:, 0] - s * dv[:, 1], s * dv[:, 0] + c * dv[:, 1]])
    dt = np.diff(t, prepend=t[0])
    cum = np.cumsum(dv_odom * dt[:, None], axis=0)
    j = np.searchsorted(t, t - horizon, side="left")
    drift = np.linalg.norm(cum - cum[j], axis=1)[t >= t[0] + horizon]
    return robot, err, drift


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--window", type=float, default=1.0, help="averaging window (s)")
    ap.add_argument("--horizon", type=float, default=1.0, help="drift horizon (s)")
    args = ap.parse_args()
    per_robot: dict[str, list] = {}
    for run in args.runs:
        got = run_errors(run, args.window, args.horizon)
        if got is not None:
            per_robot.setdefault(got[0], []).append(got[1:])
    if not per_robot:
        print("no run folder with timeseries.npz and report.json")
        return 1
    print(f"window {args.window:g} s, drift horizon {args.horizon:g} s")
    for robot, parts in sorted(per_robot.items()):
        err = np.concatenate([p[0] for p in parts])
        drift = np.concatenate([p[1] for p in parts])
        print(f"{robot}: {len(parts)} runs, {len(err)} samples")
        for k, name in enumerate(("forward (m/s)", "lateral (m/s)", "yaw rate (rad/s)")):
            a = np.abs(err[:, k])
            print(f"  |error| {name:<17} median {np.median(a):.3f}  p95 {np.percentile(a, 95):.3f}"
                  f"  p99 {np.percentile(a, 99):.3f}  max {a.max():.3f}")
        print(f"  drift in {args.horizon:g} s (m)         median {np.median(drift):.3f}  "
              f"p95 {np.percentile(drift, 95):.3f}  p99 {np.percentile(drift, 99):.3f}  "
              f"max {drift.max():.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
