"""Benchmark of the quadruped convex-MPC gait controller in PyBullet (flat ground, A1).

Measures what the quadruped controller issue asks for:

* steady-state tracking (mean over 5 s after a 2 s settle) of vx = 0.5 m/s, vy = 0.2 m/s,
  yaw rate = 0.5 rad/s;
* body height following a 0.08 m drop and return while walking at 0.3 m/s;
* random piecewise-constant commands within the limits, 60 s per seed: no fall;
* MPC solve time (update + solve), controller cost per simulated second and the real-time
  factor of physics + controller (this harness: 1 kHz physics, MotorDriver at every step).

Usage::

    .venv/bin/python benchmarks/quadruped_tracking.py              # everything (~3-5 min)
    .venv/bin/python benchmarks/quadruped_tracking.py --quick      # 1 seed x 20 s
    .venv/bin/python benchmarks/quadruped_tracking.py --json out.json

Wall-clock numbers depend on the machine's load; CPU times (this thread) are printed too.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "test"))
sys.path.insert(0, os.path.join(HERE, ".."))

import quadruped_harness as harness  # noqa: E402

from safe_legged_c3bf.gait.quadruped.controller import QuadrupedMpcController  # noqa: E402
from safe_legged_c3bf.gait.quadruped.params import QuadrupedParams  # noqa: E402

LIMITS = {"vx": 0.10, "vy": 0.15, "yaw_rate": 0.15}


def physics_only_rate(seconds: float = 2.0) -> float:
    """Physics steps per wall second with the robot standing under constant joint PD."""
    from safe_legged_c3bf.gait.quadruped import a1_kinematics as kin
    from safe_legged_c3bf.interfaces.joint_command import JointCommand

    with harness.QuadrupedSim() as sim:
        cmd = JointCommand(sim.robot.joint_names, kin.STANDING_POSE, 0.0, 60.0, 2.0, 0.0)
        sim.driver.set_command(cmd, 0.0)
        n = int(seconds / harness.PHYSICS_DT)
        start = time.perf_counter()
        for i in range(n):
            sim.driver.set_command(cmd, i * harness.PHYSICS_DT)
            sim.driver.apply(i * harness.PHYSICS_DT)
            harness.pybullet.stepSimulation(physicsClientId=sim.client)
        return n / (time.perf_counter() - start)


def summarize_costs(results: list[harness.ScenarioResult]) -> dict[str, float]:
    """Aggregate solve times and per-simulated-second costs over scenario results."""
    solves = np.concatenate([r.mpc_solve_times for r in results]) * 1e3
    sim_time = sum(r.sim_time for r in results)
    return {
        "mpc_solves": int(solves.size),
        "mpc_failures": int(sum(r.mpc_failures for r in results)),
        "mpc_solve_ms_median": float(np.median(solves)),
        "mpc_solve_ms_p90": float(np.percentile(solves, 90)),
        "mpc_solve_ms_p99": float(np.percentile(solves, 99)),
        "mpc_solve_ms_max": float(np.max(solves)),
        "controller_ms_per_sim_s": 1e3 * sum(r.controller_time for r in results) / sim_time,
        "controller_cpu_ms_per_sim_s": 1e3 * sum(r.controller_cpu for r in results) / sim_time,
        "physics_ms_per_sim_s": 1e3 * sum(r.physics_time for r in results) / sim_time,
        "physics_cpu_ms_per_sim_s": 1e3 * sum(r.physics_cpu for r in results) / sim_time,
        "real_time_factor": sim_time / sum(r.wall_time for r in results),
        "sim_seconds": sim_time,
    }


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; return 0 when every 'done when' number is met."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--random-duration", type=float, default=60.0)
    parser.add_argument("--quick", action="store_true", help="one seed, 20 s")
    parser.add_argument("--skip-tracking", action="store_true")
    parser.add_argument("--skip-random", action="store_true")
    parser.add_argument("--json", help="write the numbers to this file")
    args = parser.parse_args(argv)
    if args.quick:
        args.seeds, args.random_duration = args.seeds[:1], 20.0
    params = QuadrupedParams()
    report: dict[str, object] = {"params": params.to_dict()}
    passed = True
    results: list[harness.ScenarioResult] = []

    rate = physics_only_rate()
    print(f"physics alone (driver + stepSimulation): {rate:,.0f} steps/s")
    report["physics_only_steps_per_s"] = rate

    if not args.skip_tracking:
        print("\n== tracking (mean over 5 s after a 2 s settle)")
        for kind in ("vx", "vy", "yaw_rate"):
            res = harness.run_tracking(kind, QuadrupedMpcController(params))
            results.append(res)
            v = res.values
            ok = res.ok and v["relative_error"] <= LIMITS[kind]
            passed &= ok
            print(
                f"{kind:9s} target {v['target']:.3f} "
                f"measured {v.get('measured', float('nan')):.3f} "
                f"error {100 * v.get('relative_error', float('nan')):5.1f}% "
                f"(limit {100 * LIMITS[kind]:.0f}%) cross-axis {v.get('cross_axis_max', 0):.3f} "
                f"{'PASS' if ok else 'FAIL'}"
            )
            report[f"tracking_{kind}"] = v
        res = harness.run_height(QuadrupedMpcController(params))
        results.append(res)
        v = res.values
        ok = res.ok and v["max_abs_error"] <= 0.015
        passed &= ok
        print(
            f"height    0.08 m drop + return at 0.3 m/s: max |error| "
            f"{100 * v.get('max_abs_error', float('nan')):.2f} cm, mean "
            f"{100 * v.get('mean_abs_error', float('nan')):.2f} cm (limit 1.5 cm), lowest "
            f"{v.get('lowest_mean', float('nan')):.3f} m, vx {v.get('forward_speed', 0):.3f} m/s "
            f"{'PASS' if ok else 'FAIL'}"
        )
        report["height"] = v

    if not args.skip_random:
        print(f"\n== random piecewise-constant commands, {args.random_duration:.0f} s per seed")
        for seed in args.seeds:
            res = harness.run_random(seed, args.random_duration, QuadrupedMpcController(params))
            results.append(res)
            v = res.values
            passed &= res.ok
            print(
                f"seed {seed}: {'no fall' if res.ok else 'FELL'} after {res.sim_time:.1f} s, "
                f"max |roll| {v['max_abs_roll']:.3f} rad, max |pitch| {v['max_abs_pitch']:.3f} "
                f"rad, min height {v['min_height']:.3f} m, path {v['distance']:.1f} m, "
                f"RTF {res.sim_time / res.wall_time:.2f}"
            )
            report[f"random_seed_{seed}"] = {"ok": res.ok, "sim_time": res.sim_time, **v}

    costs = summarize_costs(results)
    report["costs"] = costs
    print("\n== cost")
    print(
        f"MPC solve (update + solve) median {costs['mpc_solve_ms_median']:.2f} ms, p90 "
        f"{costs['mpc_solve_ms_p90']:.2f}, p99 {costs['mpc_solve_ms_p99']:.2f}, max "
        f"{costs['mpc_solve_ms_max']:.2f} ms over {costs['mpc_solves']} solves "
        f"({costs['mpc_failures']} fallbacks)"
    )
    print(
        f"controller per simulated second: {costs['controller_ms_per_sim_s']:.0f} ms wall, "
        f"{costs['controller_cpu_ms_per_sim_s']:.0f} ms CPU; physics + driver "
        f"{costs['physics_ms_per_sim_s']:.0f} ms wall, {costs['physics_cpu_ms_per_sim_s']:.0f} "
        f"ms CPU; real-time factor {costs['real_time_factor']:.2f} over "
        f"{costs['sim_seconds']:.0f} sim s"
    )
    ok = costs["mpc_solve_ms_median"] <= 5.0 and costs["real_time_factor"] >= 1.0
    passed &= ok
    print("ALL PASS" if passed else "SOME FAIL")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as stream:
            json.dump(report, stream, indent=2)
    return 0 if passed else 1


if __name__ == "__main__":
    sys.exit(main())
