"""Biped walking benchmark: scripted and random velocity commands in PyBullet.

Runs the BipedZmpController on the minimal test harness (plane + biped + motor drivers) and
prints, per scenario, whether the robot fell, the mean body-frame velocity against the
command, and the controller's wall-clock cost per simulated second.

    .venv/bin/python benchmarks/biped_walk.py                 # all scripted scenarios
    .venv/bin/python benchmarks/biped_walk.py --random 5      # 5 random-command seeds, 60 s
    .venv/bin/python benchmarks/biped_walk.py --only forward --duration 60
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(
    0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "test")
)

from biped_harness import BipedSim, constant, random_piecewise  # noqa: E402

from safe_legged_c3bf.gait.biped.controller import BipedZmpController  # noqa: E402
from safe_legged_c3bf.gait.biped.params import BipedParams  # noqa: E402
from safe_legged_c3bf.interfaces.gait_controller import VelocityCommand  # noqa: E402

START = 1.0  # s of standing before the command starts
SETTLE = 3.0  # s after the start excluded from the speed averages


def mean_rates(log, t_from: float, t_to: float) -> dict:
    """Mean body-frame velocity and yaw rate between two times, from odometry positions."""
    d = log.arrays()
    m = (d["t"] >= t_from) & (d["t"] <= t_to)
    if m.sum() < 2:
        return {"vx": np.nan, "vy": np.nan, "yaw_rate": np.nan}
    t = d["t"][m]
    yaw = np.unwrap(d["rpy"][m][:, 2])
    vb = d["velocity_body"][m]
    return {
        "vx": float(vb[:, 0].mean()),
        "vy": float(vb[:, 1].mean()),
        "yaw_rate": float((yaw[-1] - yaw[0]) / (t[-1] - t[0])),
    }


def run(command_fn, duration: float, params: BipedParams | None = None):
    """Run one simulation; return (log, controller)."""
    sim = BipedSim()
    try:
        ctrl = BipedZmpController(params)
        log = sim.run(ctrl, duration, command_fn)
    finally:
        sim.close()
    return log, ctrl


def scenario_report(name, log, ctrl, cmd: VelocityCommand | None, t_from, t_to) -> dict:
    """Print and return the metrics of one run."""
    rates = mean_rates(log, t_from, t_to)
    per_s = log.controller_seconds / max(log.sim_seconds, 1e-9)
    phys = log.physics_seconds / max(log.sim_seconds, 1e-9)
    line = (
        f"{name:<10} fell={log.fell!s:<5} sim={log.sim_seconds:6.1f}s "
        f"vx={rates['vx']:+.3f} vy={rates['vy']:+.3f} yaw_rate={rates['yaw_rate']:+.3f}"
    )
    if cmd is not None:
        line += f"  (cmd {cmd.vx:+.3f} {cmd.vy:+.3f} {cmd.yaw_rate:+.3f})"
    per_tick = per_s * ctrl.control_period
    line += (
        f"  ctrl {per_s * 1e3:.0f} ms/sim-s ({per_tick * 1e6:.0f} us/tick)"
        f"  physics {phys * 1e3:.0f} ms/sim-s  RTF {1.0 / (per_s + phys):.2f}"
        f"  steps={ctrl.status.steps_taken}"
    )
    print(line, flush=True)
    return {"fell": log.fell, **rates, "ctrl_per_s": per_s, "phys_per_s": phys}


def scripted(duration: float, only: str | None) -> bool:
    """Forward, turn, side-step and stop scenarios; return True when all pass."""
    cases = {
        "forward": VelocityCommand(vx=0.15),
        "turn": VelocityCommand(yaw_rate=0.3),
        "side": VelocityCommand(vy=0.05),
        "backward": VelocityCommand(vx=-0.08),
        "arc": VelocityCommand(vx=0.12, yaw_rate=0.2),
    }
    ok = True
    for name, cmd in cases.items():
        if only and name != only:
            continue
        log, ctrl = run(constant(cmd.vx, cmd.vy, cmd.yaw_rate, start=START), START + duration)
        r = scenario_report(name, log, ctrl, cmd, START + SETTLE, START + duration)
        for key, want in (("vx", cmd.vx), ("vy", cmd.vy), ("yaw_rate", cmd.yaw_rate)):
            if abs(want) > 1e-9 and abs(r[key] - want) > 0.2 * abs(want):
                ok = False
        ok = ok and not r["fell"]
    if not only or only == "stop":
        # walk, then a zero command: the robot must stop stepping and stand still
        walk_until = START + 6.0

        def stop_fn(t: float) -> VelocityCommand:
            return VelocityCommand(vx=0.15) if START <= t < walk_until else VelocityCommand()

        log, ctrl = run(stop_fn, walk_until + 6.0)
        r = scenario_report("stop", log, ctrl, None, walk_until + 3.0, walk_until + 6.0)
        d = log.arrays()
        tail = d["t"] >= walk_until + 3.0
        drift = np.linalg.norm(d["position"][tail][-1, :2] - d["position"][tail][0, :2])
        print(f"           mode={ctrl.mode} drift over the last 3 s = {drift * 1e3:.1f} mm")
        ok = ok and not r["fell"] and ctrl.mode == "stand" and drift < 0.01
    return ok


def random_runs(seeds: int, duration: float, first_seed: int = 0) -> bool:
    """Random piecewise-constant commands inside the limits; return True when none fell."""
    limits = BipedParams().command
    falls = 0
    for seed in range(first_seed, first_seed + seeds):
        fn = random_piecewise(seed, limits, start=START)
        log, ctrl = run(fn, START + duration)
        scenario_report(f"random#{seed}", log, ctrl, None, START, START + duration)
        falls += int(log.fell)
    print(f"random commands: {seeds - falls}/{seeds} seeds without a fall")
    return falls == 0


def main() -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=20.0, help="walking time per run (s)")
    parser.add_argument("--only", default=None, help="run only this scripted scenario")
    parser.add_argument("--random", type=int, default=0, help="number of random-command seeds")
    parser.add_argument("--random-duration", type=float, default=60.0)
    parser.add_argument("--first-seed", type=int, default=0)
    args = parser.parse_args()
    wall = time.perf_counter()
    ok = True
    if args.random:
        ok = random_runs(args.random, args.random_duration, args.first_seed) and ok
    else:
        ok = scripted(args.duration, args.only) and ok
    print(f"{'PASS' if ok else 'FAIL'} in {time.perf_counter() - wall:.0f} s wall")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
