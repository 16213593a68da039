"""Cost of the obstacle detector per scan, per cloud and per fused frame (no ROS).

Run:  .venv/bin/python benchmarks/detector_cost.py [--frames N] [--robot quadruped|biped]

Synthetic data from the test's ray caster (test/detector_scenes.py): a 360-beam 2-D scan and
a 64 x 48 organised float32 cloud (60 x 45 deg) from the robot's default mounts, 1 cm range
noise, a scene with a pillar, a walker, a bar across the path and a wall at an angle. Each
measurement is one full frame as the node handles it: decoding (LaserScan ranges, or the
PointCloud2 bytes), the frame in odom (mount, pose history, self-filter) and the detection.
Prints the median and the 90th percentile in ms of each, and the obstacles found.
"""

import argparse
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "test"))
sys.path.insert(0, os.path.join(HERE, ".."))

from detector_scenes import Bar, Box, Pillar, Pose, cloud, scan, scan_angles  # noqa: E402

from safe_legged_c3bf.interfaces.sensor_mounts import (  # noqa: E402
    DEPTH_FRAME,
    LIDAR_FRAME,
    default_mounts,
)
from safe_legged_c3bf.perception.detector import ObstacleDetector  # noqa: E402
from safe_legged_c3bf.perception.pose_history import PoseHistory  # noqa: E402
from safe_legged_c3bf.perception.self_filter import default_self_box  # noqa: E402
from safe_legged_c3bf.perception.sensor_frame import make_frame  # noqa: E402
from safe_legged_c3bf.perception.sensor_points import (  # noqa: E402
    FLOAT32,
    CloudField,
    cloud_points,
    scan_points,
)

BASE_Z = {"quadruped": 0.28, "biped": 0.81}
FIELDS = [CloudField("x", 0, FLOAT32), CloudField("y", 4, FLOAT32), CloudField("z", 8, FLOAT32)]


def scene(robot: str) -> list:
    bar_z = 0.35 if robot == "quadruped" else 0.95
    return [
        Pillar(3.5, 0.4, 0.3),
        Pillar(2.5, -1.0, 0.2, 1.7),
        Bar(2.0, bar_z, 0.05),
        Box(4.5, -1.2, 2.0, 0.2, 1.0, yaw=0.4),
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--robot", choices=sorted(BASE_Z), default="quadruped")
    args = ap.parse_args()

    mounts = default_mounts(args.robot)
    lidar, depth = mounts[LIDAR_FRAME], mounts[DEPTH_FRAME]
    box = default_self_box(args.robot)
    detector = ObstacleDetector()
    angle_min, inc = scan_angles(360)
    world = scene(args.robot)
    history = PoseHistory(duration=1e9)
    inputs = []
    for k in range(args.frames):  # the robot walks 0.5 m/s toward the bar, swaying a little
        t = 0.1 * k
        pose = Pose(x=0.05 * (k % 20), z=BASE_Z[args.robot], pitch=0.02 * math.sin(t * 9),
                    roll=0.01 * math.cos(t * 9))
        history.add(t, [pose.x, pose.y, pose.z], pose.quaternion())
        ranges = scan(pose, lidar, world, noise=0.01, seed=k).astype(np.float32)
        grid = cloud(pose, depth, world, noise=0.01, seed=k).astype("<f4")
        inputs.append((t, ranges, grid.tobytes(), grid.shape))

    costs = {"scan": [], "cloud": [], "fused": []}
    found = {"scan": [], "cloud": [], "fused": []}
    for t, ranges, data, shape in inputs:
        height, width = shape[0], shape[1]
        start = time.perf_counter()
        sp = scan_points(ranges, angle_min, inc, 0.05, 10.0)
        scan_frame = make_frame("scan", t, sp.points, lidar.matrix(), history, box,
                                beams=sp.beams, angle_increment=inc, beam_count=sp.beam_count)
        report = detector.detect(scan=scan_frame)
        costs["scan"].append(time.perf_counter() - start)
        found["scan"].append(len(report.obstacles))

        start = time.perf_counter()
        pts = cloud_points(data, FIELDS, 12, 12 * width, width, height)
        cloud_frame = make_frame("cloud", t, pts, depth.matrix(), history, box)
        report = detector.detect(cloud=cloud_frame)
        costs["cloud"].append(time.perf_counter() - start)
        found["cloud"].append(len(report.obstacles))

        start = time.perf_counter()
        report = detector.detect(scan=scan_frame, cloud=cloud_frame)
        costs["fused"].append(time.perf_counter() - start)
        found["fused"].append(len(report.obstacles))

    print(f"{args.robot}, {args.frames} frames: 360-beam scan, {width}x{height} cloud, "
          f"{len(world)} objects")
    labels = {
        "scan": "per scan  (decode + frame + detect, scan alone)",
        "cloud": "per cloud (decode + frame + detect, cloud alone)",
        "fused": "fused     (detect on both frames, as published)",
    }
    for key, label in labels.items():
        ms = 1e3 * np.array(costs[key])
        print(f"  {label}: median {np.median(ms):.2f} ms, p90 {np.percentile(ms, 90):.2f} ms,"
              f" obstacles median {int(np.median(found[key]))}")


if __name__ == "__main__":
    main()
