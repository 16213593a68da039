"""Per-call time of SafetyFilter.filter: closed form and OSQP with 1..50 obstacles.

Run:  .venv/bin/python benchmarks/filter_speed.py [--calls N]

Model: UnicycleHeightModel (state x, y, theta, v, omega, z, vz; input a, alpha, a_z), the
model the filter node uses. Each call perturbs the state slightly (as consecutive odometry
samples would) so warm starts are realistic, and the reference always violates at least one
constraint (an obstacle dead ahead), so the measured path really is the closed form / the QP.
Targets on the 2-core dev machine: closed form median <= 30 us, QP with 10 obstacles
median <= 0.5 ms, 50 obstacles <= 2 ms.
"""

import argparse
import time
from collections import Counter

import numpy as np

from safe_legged_c3bf.c3bf import (
    Obstacles,
    SafetyFilter,
    UnicycleHeightModel,
    c3bf_lie_derivatives,
)

MODEL = UnicycleHeightModel(offset=0.2)
U_MIN = np.array([-2.0, -4.0, -3.0])
U_MAX = np.array([2.0, 4.0, 3.0])
X0 = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.3, 0.0])
U_REF = np.array([1.0, 0.0, 0.0])


def obstacles(n: int, rng) -> Obstacles:
    """One static pillar ahead (the reference violates its constraint) plus n - 1 random
    pillars and bars (a quarter bars), some moving. A candidate is kept only if its
    constraint holds with margin both at the reference and at the input the pillar ahead
    asks for: a feasible clutter where the QP carries every row."""
    first = Obstacles.vertical([[3.0, 0.3]], [0.45])
    u_first = SafetyFilter(MODEL).filter(X0, U_REF, first).u_safe
    probes = np.array([U_REF, u_first, 0.5 * (U_REF + u_first)])
    picked = [first]
    while len(picked) < n:
        if rng.uniform() < 0.25:
            cand = Obstacles.horizontal(
                [[rng.uniform(4.0, 12.0), rng.uniform(0.9, 1.4)]], rng.uniform(0.15, 0.25)
            )
        else:
            cand = Obstacles.vertical(
                [[rng.uniform(1.0, 10.0), rng.uniform(-4.0, 4.0)]],
                rng.uniform(0.3, 0.6),
                rng.uniform(-0.3, 0.3, (1, 2)),
            )
        t = c3bf_lie_derivatives(
            MODEL, X0, cand.center, cand.velocity, cand.radius + 0.01, cand.plane
        )
        if t.h[0] > 0.05 and np.min(probes @ t.lg_h[0] + t.lf_h[0] + t.h[0]) > 0.5:
            picked.append(cand)
    return Obstacles.concatenate(*picked)


def bench(flt: SafetyFilter, obs: Obstacles, calls: int, rng) -> tuple[np.ndarray, Counter]:
    noise = rng.normal(scale=[0.01, 0.01, 0.01, 0.02, 0.02, 0.002, 0.01], size=(calls, 7))
    states = X0 + noise
    for x in states[:20]:  # warm-up (solver setup, caches)
        flt.filter(x, U_REF, obs)
    times = np.empty(calls)
    paths = Counter()
    perf = time.perf_counter
    for i, x in enumerate(states):
        t0 = perf()
        res = flt.filter(x, U_REF, obs)
        times[i] = perf() - t0
        paths[f"{res.status.value}/{res.solver}"] += 1
    return times, paths


def row(name: str, times: np.ndarray, paths: Counter) -> str:
    med, p99 = np.median(times) * 1e6, np.percentile(times, 99) * 1e6
    mix = ", ".join(f"{k} {v / len(times):.0%}" for k, v in paths.most_common())
    return f"{name:<24} {med:>10.1f} {p99:>10.1f}   {mix}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=3000, help="calls per row (default 3000)")
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    print(f"{'case':<24} {'median us':>10} {'p99 us':>10}   paths")
    auto = SafetyFilter(MODEL, u_min=U_MIN, u_max=U_MAX)
    times, paths = bench(auto, obstacles(1, rng), args.calls, rng)
    print(row("closed form (1 obst.)", times, paths))
    for n in (1, 5, 10, 20, 50):
        qp = SafetyFilter(MODEL, u_min=U_MIN, u_max=U_MAX, method="qp")
        times, paths = bench(qp, obstacles(n, rng), max(args.calls // (1 + n // 10), 300), rng)
        print(row(f"OSQP ({n} obst.)", times, paths))
    for n in (10, 50):
        times, paths = bench(auto, obstacles(n, rng), max(args.calls // (1 + n // 10), 300), rng)
        print(row(f"auto ({n} obst.)", times, paths))


if __name__ == "__main__":
    main()
