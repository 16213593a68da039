"""Cost of one simulated range-sensor cast on this machine (physics-thread time per message).

For each scenario, builds the world (the robot standing at its spawn pose, the scenario's
obstacles at t = 0) and times, with ``timeit`` over ``--casts`` casts each:

- one LiDAR scan (``Simulation.lidar_scan``: the ray batch, noise, REP-117 values);
- one 3-D cast (``Simulation.depth_cloud``: the ray batch, noise, the valid points);
- filling the LaserScan and PointCloud2 messages the simulator node publishes.

Prints the median and the 90th percentile (ms) and the rays per cast.

Usage: python benchmarks/range_sensors.py [--scenarios quadruped_default biped_default]
       [--casts 200]
"""

from __future__ import annotations

import argparse
import array
import timeit

import numpy as np

from safe_legged_c3bf.sim.world import Simulation


def _stats(times: list[float]) -> str:
    ms = np.asarray(times) * 1e3
    return f"median {np.median(ms):6.3f} ms  p90 {np.percentile(ms, 90):6.3f} ms"


def measure(scenario: str, casts: int) -> None:
    """Print the cast costs in ``scenario``."""
    from safe_legged_c3bf.nodes.simulator.sensor_publisher import empty_cloud, fill_cloud

    with Simulation(scenario) as sim:
        scan, cloud = sim.lidar_scan(), sim.depth_cloud()
        msg = empty_cloud("depth_link")
        rows = [
            (f"lidar scan ({sim.lidar.ray_count} rays)", sim.lidar_scan),
            (f"3-D cast ({sim.depth.ray_count} rays, {len(cloud)} points)", sim.depth_cloud),
            ("LaserScan ranges", lambda: array.array("f", scan.tobytes())),
            ("PointCloud2 fill", lambda: fill_cloud(msg, cloud)),
        ]
        print(f"{scenario}:")
        for name, func in rows:
            print(f"  {name:42s} {_stats(timeit.repeat(func, number=1, repeat=casts))}")


def main() -> None:
    """Command line (see the module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="+",
                        default=["quadruped_default", "biped_default"])
    parser.add_argument("--casts", type=int, default=200)
    args = parser.parse_args()
    for scenario in args.scenarios:
        measure(scenario, args.casts)


if __name__ == "__main__":
    main()
