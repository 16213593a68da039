"""The obstacle detector and tracker run again on recorded raw sensor data, with other settings.

``benchmarks/detector_quality.py`` and ``benchmarks/tracker_static_speed.py`` score the
detections a recording holds, so trying a detector setting meant recording the runs again
(minutes each). This script feeds the ``/odom``, ``/scan`` and ``/points`` of MCAP recordings
(``bringup --perception sensors --record FILE``) to the obstacle detector node's own callbacks
in this process (no graph, no executor: the node's clock is the newest odometry stamp), keeps
what it would publish, and prints per recording and overall:

- the detector's figures of ``detector_quality.py`` (recall within 5 m, the same over the
  obstacles a range sensor can see, centre error median / p90, frames without a false
  obstacle) against the recording's ``/ground_truth/obstacles``;
- the tracker's figures of ``tracker_static_speed.py`` on those detections (static
  obstacles' speed: share of track-frames above 0.2 m/s and p95; movers' velocity error
  median / p90), and when true obstacles start moving, how long their tracks take to know it
  (``start_latencies``: half the true speed along the true velocity; median / p90, s).

Settings: ``--param NAME=VALUE`` overrides a detector node parameter
(``config/obstacle_detector.yaml``), ``--track NAME=VALUE`` a tracker ``TrackConfig`` field
(the tracker starts from the sensors layer, ``config/sensors/obstacle_tracker.yaml``);
values are read as YAML. The robot kind (sensor mounts) is guessed from the file name
("biped" in it, else quadruped); ``--param robot_kind=biped`` sets it. About 5 s per 30 s
recording.

Usage::

    python benchmarks/perception_replay.py runs/detector-quality/*.mcap \\
        [--param circle_min_arc=1.2] [--track maneuver_velocity_std=0.5]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import yaml
from detector_quality import _rows, _t, score  # the same folder: benchmarks/
from tracker_static_speed import FAST, start_latencies, track_speeds

from safe_legged_c3bf.perception.track import TrackConfig
from safe_legged_c3bf.perception.tracker import TrackerConfig


def _assignments(items: list[str]) -> dict[str, object]:
    out = {}
    for item in items:
        name, _, value = item.partition("=")
        out[name] = yaml.safe_load(value)
    return out


def redetect(path: Path, overrides: dict[str, object]) -> tuple[list, list, np.ndarray]:
    """(detection messages, (t, ground-truth message) list, odom rows t x y) of a recording."""
    from mcap.reader import make_reader
    from rclpy.parameter import Parameter
    from rclpy.serialization import deserialize_message

    from safe_legged_c3bf.interfaces import topics
    from safe_legged_c3bf.nodes.obstacle_detector_node import ObstacleDetectorNode

    settings = {"robot_kind": "biped" if "biped" in path.name else "quadruped", **overrides}
    params = [Parameter(k, value=v) for k, v in settings.items()]
    node = ObstacleDetectorNode(parameter_overrides=params)
    published: list = []
    node._pub.publish = published.append  # what the node would publish
    clock = [0.0]
    node._now = lambda: clock[0]  # the node's clock: the newest odometry stamp
    odom_topic, truth_topic = topics.ODOM.name, topics.GROUND_TRUTH_OBSTACLES.name
    wanted = [odom_topic, topics.SCAN.name, topics.POINTS.name, truth_topic]
    classes = {odom_topic: topics.ODOM.msg_class(), truth_topic: topics.by_name(truth_topic)
               .msg_class()}
    truth, odom = [], []
    try:
        with open(path, "rb") as stream:
            for _s, channel, message in make_reader(stream).iter_messages(topics=wanted):
                if channel.topic == odom_topic:
                    msg = deserialize_message(message.data, classes[odom_topic])
                    clock[0] = max(clock[0], _t(msg.header.stamp))
                    node._on_odom(msg)
                    p = msg.pose.pose.position
                    odom.append((_t(msg.header.stamp), p.x, p.y))
                elif channel.topic == topics.SCAN.name:
                    node._on_scan(message.data)
                elif channel.topic == topics.POINTS.name:
                    node._on_points(message.data)
                else:
                    msg = deserialize_message(message.data, classes[truth_topic])
                    truth.append((_t(msg.header.stamp), msg))
    finally:
        node.destroy_node()
    return published, truth, np.array(odom).reshape(-1, 3)


def sensors_track_fields() -> dict[str, object]:
    """The ``TrackConfig`` fields the tracker's config files give it with sensors."""
    from safe_legged_c3bf.run.parameters import config_files, merged_parameters
    from safe_legged_c3bf.run.supervisor import NodeSpec

    node = "obstacle_tracker"
    params = merged_parameters(NodeSpec(name=node, module="-",
                                        params_files=config_files(node, "sensors")))
    fields = set(TrackConfig.__dataclass_fields__)
    return {k: v for k, v in params.items() if k in fields}


def _fmt(x: float | None) -> str:
    return "   -" if x is None or not np.isfinite(x) else f"{x:.3f}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("recordings", nargs="+", type=Path, help="MCAP files")
    ap.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                    help="detector node parameter override (repeatable)")
    ap.add_argument("--track", action="append", default=[], metavar="NAME=VALUE",
                    help="tracker TrackConfig field (repeatable)")
    ap.add_argument("--range", type=float, default=5.0, help="m, obstacles counted (recall)")
    ap.add_argument("--match", type=float, default=0.3, help="m, a detection matches within")
    args = ap.parse_args()
    import rclpy

    rclpy.init()
    overrides, track = _assignments(args.param), _assignments(args.track)
    tracker = TrackerConfig(track=TrackConfig(**{**sensors_track_fields(), **track}))
    print(f"detector overrides {overrides or '-'}; tracker overrides {track or '-'} "
          "(on the sensors layer)")
    print(f"{'recording':<22} {'frames':>6} {'recall':>6} {'visible':>7} {'centre p50/p90 (m)':>19}"
          f" {'clean':>6} {'static>0.2':>10} {'p95 m/s':>7} {'movers p50/p90 m/s':>19}")
    total = {"pairs": 0, "hits": 0, "visible": 0, "visible_hits": 0, "clean": 0, "frames": 0}
    errors: list[float] = []
    speeds, movers, latencies = [], [], []
    try:
        for path in args.recordings:
            published, truth, odom = redetect(path, overrides)
            det = [(_t(m.header.stamp), _rows(m)) for m in published]
            s = score(det, [(t, _rows(m)) for t, m in truth], odom, args)
            gt_rows = [(t, m.obstacles) for t, m in truth]
            det_rows = [(_t(m.header.stamp), m) for m in published]
            sp, me = track_speeds(gt_rows, det_rows, tracker)
            latencies.append(start_latencies(gt_rows, det_rows, tracker))
            for key in total:
                total[key] += s[key]
            errors += s["errors"]
            speeds.append(sp)
            movers.append(me)
            _line(path.stem, s["frames"], s["recall"], s["visible_recall"], s["errors"],
                  s["clean_share"], sp, me)
    finally:
        rclpy.try_shutdown()
    _line("all", total["frames"], total["hits"] / max(total["pairs"], 1),
          total["visible_hits"] / max(total["visible"], 1), errors,
          total["clean"] / max(total["frames"], 1), np.concatenate(speeds),
          np.concatenate(movers))
    lat = np.concatenate(latencies)
    known = lat[np.isfinite(lat)]
    print(f"starts of true obstacles: {len(lat)}, known within 3 s {len(known)}; time to know "
          + (f"median {np.median(known):.2f} s, p90 {np.percentile(known, 90):.2f} s"
             if len(known) else "-"))
    return 0


def _line(name, frames, recall, visible, errors, clean, sp, me) -> None:  # noqa: ANN001
    centre = (f"{_fmt(np.median(errors))}/{_fmt(np.percentile(errors, 90))}" if errors
              else "-")
    fast = float(np.mean(sp > FAST)) if len(sp) else None
    p95 = float(np.percentile(sp, 95)) if len(sp) else None
    moving = f"{_fmt(np.median(me))}/{_fmt(np.percentile(me, 90))}" if len(me) else "-"
    print(f"{name:<22} {frames:>6} {_fmt(recall):>6} {_fmt(visible):>7} {centre:>19} "
          f"{_fmt(clean):>6} {_fmt(fast):>10} {_fmt(p95):>7} {moving:>19}")


if __name__ == "__main__":
    sys.exit(main())
