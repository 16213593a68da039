"""Obstacle detector quality against ground truth, on frames recorded from the running graph.

Run:  .venv/bin/python benchmarks/detector_quality.py [--out DIR] [--scenario NAME ...]

For each scenario the bringup runs as a user runs it with ``--perception sensors --record``
(filter on, the detector node live on the simulated LiDAR and 3-D sensor); then every
``/obstacles/detections`` frame in the recording is compared with ``/ground_truth/obstacles``
at the same stamp and the robot pose from ``/odom``. Recordings already in ``--out`` are
reused (``--rerun`` makes them again).

Printed per scenario and overall:

- recall: share of (frame, true vertical obstacle within ``--range`` of the robot, surface
  distance) pairs with a vertical detection whose centre lies within ``--match`` m of the
  true ellipse (occluded obstacles count as misses);
- visible: the same recall over the pairs whose obstacle is not occluded: more than half of
  its near side hidden from the robot's position behind other true obstacles (straight
  lines of sight in x-y) makes it occluded, a case no range sensor can see, counted apart;
- centre error: distance from a compact true obstacle's centre (larger semi-axis <=
  0.35 m) to the nearest matching detection's centre, median and p90 (m);
- frames without a false obstacle: share of frames in which every detection lies within
  ``--match`` m of some true obstacle of its plane;
- bar first seen: the robot's distance to each true bar (surface, x-y) when a HORIZONTAL
  detection first matches it.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

DEFAULT_SCENARIOS = ("quadruped_default", "quadruped_horizontal", "quadruped_wall",
                     "quadruped_crowd", "quadruped_low_bar", "biped_default", "biped_low_bar")
_CIRCLE = np.linspace(0.0, 2.0 * np.pi, 96, endpoint=False)


def record(scenario: str, out: Path, rerun: bool) -> Path:
    """Run the bringup with sensors and a recording; return the MCAP path."""
    mcap = out / f"{scenario}.mcap"
    if mcap.exists() and not rerun:
        return mcap
    cmd = [sys.executable, "-m", "safe_legged_c3bf.bringup", "--scenario", scenario,
           "--perception", "sensors", "--record", str(mcap), "--out", str(out / scenario),
           "--progress-period", "30"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return mcap


def read_messages(mcap: Path, wanted: list[str]) -> dict[str, list]:
    """The messages of each topic in ``wanted``, deserialised, in the recording's order."""
    from mcap.reader import make_reader
    from rclpy.serialization import deserialize_message

    from safe_legged_c3bf.interfaces import topics

    names: dict[str, list] = {name: [] for name in wanted}
    classes = {n: topics.by_name(n).msg_class() for n in names}
    with open(mcap, "rb") as stream:
        for _s, channel, message in make_reader(stream).iter_messages(topics=list(names)):
            msg = deserialize_message(message.data, classes[channel.topic])
            names[channel.topic].append(msg)
    return names


def read(mcap: Path) -> tuple[list, list, np.ndarray]:
    """(detection frames, truth frames, odom rows t x y) from a recording."""
    from safe_legged_c3bf.interfaces import topics

    names = read_messages(mcap, [topics.OBSTACLE_DETECTIONS.name,
                                 topics.GROUND_TRUTH_OBSTACLES.name, topics.ODOM.name])
    odom = np.array([(_t(m.header.stamp), m.pose.pose.position.x, m.pose.pose.position.y)
                     for m in names[topics.ODOM.name]]).reshape(-1, 3)
    det = [(_t(m.header.stamp), _rows(m)) for m in names[topics.OBSTACLE_DETECTIONS.name]]
    truth = [(_t(m.header.stamp), _rows(m)) for m in names[topics.GROUND_TRUTH_OBSTACLES.name]]
    return det, truth, odom


def _t(stamp) -> float:  # noqa: ANN001
    return stamp.sec + stamp.nanosec * 1e-9


def _rows(msg) -> list[tuple]:  # noqa: ANN001 - ObstacleArray
    """(id, plane, centre (3,), a, b, orientation, extent) per obstacle."""
    return [(o.id, o.plane, np.array([o.center.x, o.center.y, o.center.z]), o.semi_axis_a,
             o.semi_axis_b, o.orientation, o.extent) for o in msg.obstacles]


def _outline(ob: tuple) -> np.ndarray:
    """(96, 2) points on the obstacle's ellipse in its plane (x-y vertical, x-z horizontal)."""
    _id, plane, c, a, b, th, _ext = ob
    ca, sa = np.cos(th), np.sin(th)
    ex, ey = a * np.cos(_CIRCLE), b * np.sin(_CIRCLE)
    u = c[0] + ca * ex - sa * ey
    v = (c[1] if plane == 0 else c[2]) + sa * ex + ca * ey
    return np.stack([u, v], axis=1)


def _distance(point: np.ndarray, ob: tuple) -> float:
    """Distance (m) of an in-plane point to the obstacle's ellipse (0 inside)."""
    _id, plane, c, a, b, th, _ext = ob
    centre = np.array([c[0], c[1] if plane == 0 else c[2]])
    q = point - centre
    ca, sa = np.cos(th), np.sin(th)
    u, v = ca * q[0] + sa * q[1], -sa * q[0] + ca * q[1]
    if (u / a) ** 2 + (v / b) ** 2 <= 1.0:
        return 0.0
    return float(np.min(np.hypot(*(_outline(ob) - point).T)))


def _in_plane(ob: tuple) -> np.ndarray:
    return np.array([ob[2][0], ob[2][1] if ob[1] == 0 else ob[2][2]])


def _sight_blocked(eye: np.ndarray, targets: np.ndarray, ob: tuple) -> np.ndarray:
    """(n,) bool: the segment from ``eye`` (2,) to each target (n, 2) crosses the ellipse.

    In the ellipse's frame scaled to a unit circle, |q0 + s d|^2 = 1 has a root s in (0, 1).
    """
    _id, plane, c, a, b, th, _ext = ob
    centre = np.array([c[0], c[1] if plane == 0 else c[2]])
    rot = np.array([[np.cos(th), np.sin(th)], [-np.sin(th), np.cos(th)]])
    q0 = (rot @ (eye - centre)) / (a, b)
    d = (targets - eye) @ rot.T / (a, b)
    if q0 @ q0 <= 1.0:
        return np.ones(len(targets), dtype=bool)
    A, B, C = (d * d).sum(1), 2.0 * (d @ q0), q0 @ q0 - 1.0
    disc = B * B - 4.0 * A * C
    root = (-B - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * np.maximum(A, 1e-12))
    return (disc > 0.0) & (root > 0.0) & (root < 0.999)


def occluded(eye: np.ndarray, ob: tuple, others: list) -> bool:
    """More than half of the obstacle's near side is hidden from ``eye`` by ``others``."""
    pts = _outline(ob)
    dist = np.hypot(*(pts - eye).T)
    near = pts[dist <= 0.5 * (dist.min() + dist.max())]
    hidden = np.zeros(len(near), dtype=bool)
    for other in others:
        hidden |= _sight_blocked(eye, near, other)
    return bool(hidden.mean() > 0.5)


def _bar_overlaps_y(det: tuple, bar: tuple) -> bool:
    """A horizontal detection spans part of the bar along y (extrusion axis)."""
    lo, hi = bar[2][1] - bar[6] / 2, bar[2][1] + bar[6] / 2
    return lo - 0.3 <= det[2][1] <= hi + 0.3


def score(det: list, truth: list, odom: np.ndarray, opts: argparse.Namespace) -> dict:
    """The figures of one recording (see the module docstring)."""
    t_truth = np.array([t for t, _ in truth])
    pairs = hits = visible = visible_hits = 0
    errors: list[float] = []
    clean = 0
    first_seen: dict[str, float] = {}
    for t, found in det:
        k = int(np.clip(np.searchsorted(t_truth, t), 0, len(truth) - 1))
        true = truth[k][1]
        robot = np.array([np.interp(t, odom[:, 0], odom[:, 1]),
                          np.interp(t, odom[:, 0], odom[:, 2])])
        vert = [o for o in true if o[1] == 0]
        vdet = [d for d in found if d[1] == 0]
        for ob in vert:
            if _distance(robot, ob) > opts.range:
                continue
            pairs += 1
            near = [d for d in vdet if _distance(_in_plane(d), ob) <= opts.match]
            hits += bool(near)
            if not occluded(robot, ob, [o for o in vert if o is not ob]):
                visible += 1
                visible_hits += bool(near)
            if near and max(ob[3], ob[4]) <= 0.35:
                errors.append(min(float(np.hypot(*(_in_plane(d) - _in_plane(ob)))) for d in near))
        false = [d for d in found if not any(
            o[1] == d[1] and _distance(_in_plane(d), o) <= opts.match
            and (d[1] == 0 or _bar_overlaps_y(d, o)) for o in true)]
        clean += not false
        for ob in (o for o in true if o[1] == 1):
            if ob[0] not in first_seen and any(
                    d[1] == 1 and _distance(_in_plane(d), ob) <= opts.match
                    and _bar_overlaps_y(d, ob) for d in found):
                first_seen[ob[0]] = abs(ob[2][0] - robot[0]) - ob[3]
    return {"frames": len(det), "pairs": pairs, "recall": hits / pairs if pairs else None,
            "visible": visible, "visible_hits": visible_hits,
            "visible_recall": visible_hits / visible if visible else None,
            "centre_median": float(np.median(errors)) if errors else None,
            "centre_p90": float(np.percentile(errors, 90)) if errors else None,
            "clean_share": clean / len(det) if det else None,
            "bar_first_seen": first_seen, "errors": errors, "hits": hits, "clean": clean}


def _fmt(x: float | None, spec: str) -> str:
    return "-" if x is None else format(x, spec)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", action="append", help="scenario (repeatable; default: 7)")
    ap.add_argument("--out", type=Path, default=Path("runs/detector_quality"))
    ap.add_argument("--rerun", action="store_true", help="record again")
    ap.add_argument("--range", type=float, default=5.0, help="m, recall range (default 5)")
    ap.add_argument("--match", type=float, default=0.3, help="m, match distance (default 0.3)")
    opts = ap.parse_args()
    opts.out.mkdir(parents=True, exist_ok=True)
    total = {"pairs": 0, "hits": 0, "visible": 0, "visible_hits": 0, "frames": 0, "clean": 0,
             "errors": []}
    print(f"{'scenario':24} {'frames':>6} {'recall':>7} {'visible':>8} "
          f"{'centre med/p90 (cm)':>20} {'no false obstacle':>18}  bars first seen at (m)")
    for name in opts.scenario or DEFAULT_SCENARIOS:
        s = score(*read(record(name, opts.out, opts.rerun)), opts)
        for key in ("pairs", "hits", "visible", "visible_hits", "frames", "clean"):
            total[key] += s[key]
        total["errors"] += s["errors"]
        bars = ", ".join(f"{k} {v:.2f}" for k, v in s["bar_first_seen"].items()) or "-"
        centre = f"{_fmt(s['centre_median'] and 100 * s['centre_median'], '.1f')} / " \
                 f"{_fmt(s['centre_p90'] and 100 * s['centre_p90'], '.1f')}"
        print(f"{name:24} {s['frames']:6d} {_fmt(s['recall'], '7.3f')} "
              f"{_fmt(s['visible_recall'], '8.3f')} {centre:>20} "
              f"{_fmt(s['clean_share'], '18.3f')}  {bars}")
    e = total["errors"]
    print(f"{'all':24} {total['frames']:6d} "
          f"{_fmt(total['hits'] / total['pairs'] if total['pairs'] else None, '7.3f')} "
          f"{_fmt(total['visible_hits'] / total['visible'] if total['visible'] else None, '8.3f')}"
          f" {_fmt(100 * float(np.median(e)) if e else None, '.2f'):>9} / "
          f"{_fmt(100 * float(np.percentile(e, 90)) if e else None, '.1f'):<8} "
          f"{_fmt(total['clean'] / total['frames'] if total['frames'] else None, '18.3f')}")


if __name__ == "__main__":
    main()
