"""CPU time of one safety filter cycle, back to back and paced at the filter's rate.

The node's latency (``benchmarks/filter_node_latency.py``) is measured on cycles that follow
each other closely (its driver spins between them). A robot runs the filter at ``rate`` Hz
and the process sleeps between cycles; on a shared virtual machine a cycle after a sleep
finds cold caches and a slower core, and costs more CPU time for the same work. This script
runs :class:`~safe_legged_c3bf.safety.safety_cycle.SafetyFilterCycle` (no ROS) on the node
benchmark's inputs (10 obstacles ahead, odometry driving through them at 0.4 m/s, reference
0.5 m/s) three ways, interleaved ``--rounds`` times, and prints the median thread CPU time
per cycle (ms) of each:

- ``back to back``: the next cycle starts at once;
- ``busy gap``: the thread computes for the filter period between cycles (caches churned,
  core kept busy);
- ``paced``: the thread sleeps for the filter period between cycles (what a robot does).

Usage: python benchmarks/filter_cycle_pacing.py [--cycles 300] [--rounds 3]
       [--body-model body] [--model unicycle_lateral]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from safe_legged_c3bf.interfaces.base_state import BaseState
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand
from safe_legged_c3bf.safety.obstacle_input import ObstacleSet
from safe_legged_c3bf.safety.params import BODY_MODELS, MODELS, FilterParams
from safe_legged_c3bf.safety.safety_cycle import SafetyFilterCycle


def scripted_obstacles(n: int) -> ObstacleSet:
    """The node benchmark's obstacles: ``n`` circles of 0.2 m, 1.5-8 m ahead, drifting."""
    rng = np.random.default_rng(0)
    center, velocity = [], []
    for _ in range(n):
        center.append((rng.uniform(1.5, 8), rng.uniform(-2, 2), 0.5))
        velocity.append((rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0.0))
    return ObstacleSet.from_arrays(
        [f"o{i}" for i in range(n)], [0] * n, center, velocity, [(0.2, 0.2)] * n, [1.0] * n
    )


def base(t: float) -> BaseState:
    """Odometry of the scripted drive: x = 0.4 t (m), facing +x, 0.28 m high."""
    return BaseState(position=(0.4 * t, 0.0, 0.28), orientation=(0.0, 0.0, 0.0, 1.0),
                     linear_velocity=(0.4, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0),
                     stamp=t)


def _spin(seconds: float) -> None:
    end = time.perf_counter() + seconds
    junk = 0
    while time.perf_counter() < end:
        junk += sum(range(2000))


def run(params: FilterParams, obstacles: ObstacleSet, cycles: int, gap: str) -> np.ndarray:
    """Thread CPU time (s) of each cycle; ``gap``: 'none', 'busy' or 'sleep' between them."""
    cycle = SafetyFilterCycle(params)
    period = 1.0 / params.rate
    reference = VelocityCommand(0.5, 0.0, 0.0, 0.0)
    times = []
    for k in range(1, cycles + 1):
        t = k * period
        start = time.thread_time()
        cycle.step(t, reference, t, base(t), obstacles, t)
        times.append(time.thread_time() - start)
        if gap == "busy":
            _spin(period)
        elif gap == "sleep":
            time.sleep(period)
    return np.asarray(times[20:])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--obstacles", type=int, default=10)
    ap.add_argument("--cycles", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--body-model", choices=BODY_MODELS, default="body")
    ap.add_argument("--model", choices=MODELS, default="unicycle_lateral")
    args = ap.parse_args()
    params = FilterParams(body_model=args.body_model, model=args.model)
    obstacles = scripted_obstacles(args.obstacles)
    print(f"{args.obstacles} obstacles, {args.cycles} cycles x {args.rounds} rounds, "
          f"body_model {args.body_model}, model {args.model}, rate {params.rate:g} Hz")
    labels = {"none": "back to back", "busy": "busy gap", "sleep": "paced (sleep)"}
    medians: dict[str, list[float]] = {g: [] for g in labels}
    for _ in range(args.rounds):
        for gap in labels:
            medians[gap].append(1e3 * float(np.median(run(params, obstacles, args.cycles, gap))))
    for gap, label in labels.items():
        runs = ", ".join(f"{m:.3f}" for m in medians[gap])
        print(f"{label:<16} median CPU per cycle {np.median(medians[gap]):7.3f} ms  "
              f"(rounds: {runs})")
    ratio = np.median(medians["sleep"]) / np.median(medians["none"])
    print(f"paced / back to back: {ratio:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
