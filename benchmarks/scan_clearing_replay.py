"""Ghost tracks with and without scan clearing, on recorded sensor runs.

A track whose detections stop coasts on its last velocity; near the walking robot it is kept
up to 5 s (``keep_near_max_coast_time``). When that velocity was a phantom, its ghost crosses
free floor. ``scan_clearing`` (``perception/scan_clearing.py``) deletes a coasting track whose
place the 2-D LiDAR's beams pass right through. This script feeds the ``/odom``, ``/scan``
and ``/obstacles/detections`` of MCAP recordings (``bringup --perception sensors --record
FILE``) to the obstacle tracker node's own callbacks in this process (the node's clock is the
newest stamp), with the sensors configuration and scan clearing off, then on, and prints per
recording and overall, from the confirmed vertical tracks sampled at 10 Hz:

- ghost track-frames: centre more than 0.3 m outside every true obstacle (the recording's
  ``/ground_truth/obstacles``; a true ellipse is taken as its circumscribed circle), all and
  within 1 m of the robot's base;
- tracks cleared, and cleared with their centre inside a true obstacle's circle (a wrong
  clearing).

Usage::

    python benchmarks/scan_clearing_replay.py runs/detector-quality/*.mcap [--robot biped]
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

GHOST_GAP = 0.3  # m outside every true obstacle
NEAR = 1.0  # m from the robot's base
SAMPLE = 0.1  # s between samples


def _t(stamp) -> float:  # noqa: ANN001 - builtin_interfaces/Time
    return stamp.sec + stamp.nanosec * 1e-9


def _gap(truth: list, center: np.ndarray) -> float:
    """m from ``center`` to the nearest true vertical obstacle's circle (< 0 inside)."""
    gaps = [math.hypot(o.center.x - center[0], o.center.y - center[1])
            - max(o.semi_axis_a, o.semi_axis_b) for o in truth]
    return min(gaps, default=math.inf)


def replay(
    path: Path, robot: str, overrides: dict, sample: Callable | None = None,
) -> dict[str, int]:
    """Counts of one recording through a tracker node with these parameter ``overrides``.

    ``sample(tracks, truth, robot_xy, out)`` counts into ``out`` every ``SAMPLE`` s (default:
    the ghost counts below); the scan's clearings are counted here.
    """
    from mcap.reader import make_reader
    from rclpy.parameter import Parameter
    from rclpy.serialization import deserialize_message

    from safe_legged_c3bf.interfaces import topics
    from safe_legged_c3bf.nodes.obstacle_tracker_node import ObstacleTrackerNode
    from safe_legged_c3bf.replay.run import pipeline_parameters

    _, merged = pipeline_parameters(robot)
    settings = {**merged["obstacle_tracker"], **overrides}
    sample = sample or _sample
    settings = {k: v for k, v in settings.items() if k != "use_sim_time"}
    node = ObstacleTrackerNode(parameter_overrides=[
        Parameter(k, value=list(v) if isinstance(v, tuple) else v) for k, v in settings.items()
    ])
    node._pub.publish = lambda _msg: None
    clock = [0.0]
    node._now = lambda: clock[0]
    odom_topic, truth_topic = topics.ODOM.name, topics.GROUND_TRUTH_OBSTACLES.name
    wanted = [odom_topic, topics.SCAN.name, topics.OBSTACLE_DETECTIONS.name, truth_topic]
    classes = {n: topics.by_name(n).msg_class() for n in (odom_topic, truth_topic)}
    out = {"cleared": 0, "wrong": 0}
    truth: list = []
    robot_xy = np.zeros(2)
    next_sample = 0.0
    try:
        with open(path, "rb") as stream:
            for _s, channel, message in make_reader(stream).iter_messages(topics=wanted):
                if channel.topic in classes:
                    msg = deserialize_message(message.data, classes[channel.topic])
                    if channel.topic == truth_topic:
                        truth = [o for o in msg.obstacles if o.plane == 0]
                        continue
                    clock[0] = max(clock[0], _t(msg.header.stamp))
                    robot_xy = np.array([msg.pose.pose.position.x, msg.pose.pose.position.y])
                    node._on_odom(msg)
                elif channel.topic == topics.SCAN.name:
                    before = {trk.track_id: trk.snapshot(clock[0]) for trk in node.tracker.tracks}
                    cleared = node.tracks_cleared
                    node._on_scan(message.data)
                    if node.tracks_cleared > cleared:
                        alive = {trk.track_id for trk in node.tracker.tracks}
                        for track_id, o in before.items():
                            if track_id not in alive:
                                out["cleared"] += 1
                                out["wrong"] += int(_gap(truth, np.asarray(o.center)) < 0.0)
                else:
                    node._on_detections(message.data)
                    if clock[0] >= next_sample and truth:
                        next_sample = clock[0] + SAMPLE
                        sample(node.tracker.tracks_at(clock[0]), truth, robot_xy, out)
    finally:
        node.destroy_node()
    return out


def _sample(tracks: list, truth: list, robot_xy: np.ndarray, out: dict[str, int]) -> None:
    for o in tracks:
        if o.plane != 0:
            continue
        center = np.asarray(o.center, dtype=float)[:2]
        out["frames"] = out.get("frames", 0) + 1
        if _gap(truth, center) > GHOST_GAP:
            out["ghosts"] = out.get("ghosts", 0) + 1
            near = float(np.linalg.norm(center - robot_xy)) - max(o.semi_axes) < NEAR
            out["near_ghosts"] = out.get("near_ghosts", 0) + int(near)


def off_and_on(
    description: str, flag: str, header: str, sample: Callable | None,
    line: Callable[[str, bool, dict[str, int]], None],
) -> int:
    """Replay the command line's recordings with the tracker parameter ``flag`` off, then on.

    Prints ``header``, then ``line(recording, on, counts)`` per recording and both ways, and
    the totals as recording ``all``.
    """
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("recordings", nargs="+", type=Path, help="MCAP files")
    ap.add_argument("--robot", choices=("quadruped", "biped"), default=None,
                    help="robot kind (default: 'biped' if in the file name, else quadruped)")
    args = ap.parse_args()
    import rclpy

    rclpy.init()
    print(header)
    totals: dict[bool, dict[str, int]] = {False: {}, True: {}}
    try:
        for path in args.recordings:
            robot = args.robot or ("biped" if "biped" in path.name else "quadruped")
            for on in (False, True):
                counts = replay(path, robot, {flag: on}, sample)
                for key, value in counts.items():
                    totals[on][key] = totals[on].get(key, 0) + value
                line(path.stem, on, counts)
    finally:
        rclpy.try_shutdown()
    for on in (False, True):
        line("all", on, totals[on])
    return 0


def main() -> int:
    header = (f"{'recording':<24} {'clearing':>8} {'track-frames':>12} {'ghosts':>7} "
              f"{'near robot':>10} {'cleared':>7} {'wrong':>5}")
    return off_and_on(__doc__.split("\n\n")[0], "scan_clearing", header, None, _line)


def _line(name: str, clearing: bool, c: dict[str, int]) -> None:
    share = 100.0 * c.get("ghosts", 0) / max(c.get("frames", 0), 1)
    print(f"{name:<24} {'on' if clearing else 'off':>8} {c.get('frames', 0):>12} "
          f"{c.get('ghosts', 0):>4} ({share:.1f} %) {c.get('near_ghosts', 0):>6} "
          f"{c.get('cleared', 0):>7} {c.get('wrong', 0):>5}")


if __name__ == "__main__":
    raise SystemExit(main())
