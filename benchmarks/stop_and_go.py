"""Stop-and-go commands on the biped or the A1: how often it falls (no ROS, test harnesses).

A safety filter holds and releases the robot: the command is a component at a given size for
``duty`` of every ``period`` s and zero the rest of it (the 'noise' size, 3e-4 m/s, is what a
held robot's filter output hovers at). Prints the falls out of the runs, per component.

    .venv/bin/python benchmarks/stop_and_go.py              # biped: 96 runs of 15 s, ~5 min
    .venv/bin/python benchmarks/stop_and_go.py --robot a1   # the A1's trot, ~5 min
    .venv/bin/python benchmarks/stop_and_go.py --duration 8 --periods 0.9
"""

from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(
    0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "test")
)

from biped_harness import BipedSim, stop_and_go  # noqa: E402
from quadruped_harness import QuadrupedSim  # noqa: E402

from safe_legged_c3bf.gait.biped.controller import BipedZmpController  # noqa: E402
from safe_legged_c3bf.gait.quadruped.controller import QuadrupedMpcController  # noqa: E402

START = 1.0  # s of standing before the first command
#: component -> command sizes (m/s or rad/s)
SIZES = {
    "noise": ("vx", (3e-4,)),
    "vx": ("vx", (0.02, 0.1, 0.2)),
    "vy": ("vy", (0.03, 0.08)),
    "yaw_rate": ("yaw_rate", (0.05, 0.3)),
}
DUTIES = (0.3, 0.5, 0.7)


def run_one(robot: str, field: str, size: float, period: float, duty: float,
            duration: float):
    """One run; returns the fall time (s) or None."""
    command_fn = stop_and_go(period, duty, start=START, **{field: size})
    if robot == "a1":
        with QuadrupedSim() as sim:
            upright = sim.run(QuadrupedMpcController(), command_fn, duration)
            return None if upright else sim.t
    sim = BipedSim()
    try:
        log = sim.run(BipedZmpController(), duration, command_fn)
    finally:
        sim.close()
    return log.fall_time if log.fell else None


def main() -> None:
    """Run the sweep and print the falls."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", choices=("biped", "a1"), default="biped")
    parser.add_argument("--duration", type=float, default=15.0, help="sim s per run")
    parser.add_argument("--periods", default="0.4,0.6,0.9,1.3", help="stop-and-go periods (s)")
    parser.add_argument("--only", choices=sorted(SIZES), action="append", help="components")
    opts = parser.parse_args()
    periods = [float(p) for p in opts.periods.split(",")]
    total = falls = 0
    for name in opts.only or list(SIZES):
        field, sizes = SIZES[name]
        fell = []
        for size in sizes:
            for period in periods:
                for duty in DUTIES:
                    t = run_one(opts.robot, field, size, period, duty, opts.duration)
                    if t is not None:
                        fell.append(f"{size:g}@{period:g}s/{duty:g}: {t:.1f} s")
        runs = len(sizes) * len(periods) * len(DUTIES)
        total, falls = total + runs, falls + len(fell)
        print(f"{name:9s} falls {len(fell):2d} of {runs:2d}  {'; '.join(fell)}", flush=True)
    print(f"all       falls {falls:2d} of {total:2d}")


if __name__ == "__main__":
    main()
