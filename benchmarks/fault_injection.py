"""Run the default scenario under each injected fault and print one row per fault.

Each fault (safe_legged_c3bf/evaluation/faults.py) is injected at sim time --at into a
multi-process bringup of --scenario: a second publisher with wrong clocks, NaN, floods or a
gigantic message on an input topic of the tracker, the filter or the gait controller, or a
node killed (SIGKILL) or frozen (SIGSTOP). Columns: what the graph must do (continue, safe,
stop, end: see faults.py), the run's outcome, collision and goal (ground truth), minimum
clearance, time from the fault until the robot stands (measured speed, sim s), messages the
graph rejected, processes left behind, and whether the expectation held.

    python benchmarks/fault_injection.py                 # every fault (~25 runs, ~20 min)
    python benchmarks/fault_injection.py --faults kill_safety_filter odom_future
    python benchmarks/fault_injection.py --list
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from safe_legged_c3bf.evaluation.fault_runner import run_fault
from safe_legged_c3bf.evaluation.faults import FAULTS


def _fmt(value, spec: str = "") -> str:  # noqa: ANN001
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    return format(value, spec)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--faults", nargs="*", default=list(FAULTS), help="fault names (default all)")
    p.add_argument("--scenario", default="quadruped_default")
    p.add_argument("--at", type=float, default=8.0, help="sim time of the fault (s)")
    p.add_argument("--out", default="runs/fault_injection", help="folder for the runs")
    p.add_argument("--list", action="store_true", help="list the faults and exit")
    opts = p.parse_args()
    if opts.list:
        for f in FAULTS.values():
            where = f.topic or f"node {f.node}"
            print(f"{f.name:40s} {f.expect:8s} {where} {f.payload or f.signal} {f.stamp}")
        return 0
    unknown = [f for f in opts.faults if f not in FAULTS]
    if unknown:
        p.error(f"unknown fault(s): {', '.join(unknown)} (see --list)")
    out = Path(opts.out)
    out.mkdir(parents=True, exist_ok=True)
    header = ("| fault | expect | outcome | collision | goal | min clearance m | "
              "time to stop s | rejected | orphans | held |")
    rows = [header, "|---|---|---|---|---|---|---|---|---|---|"]
    print(header, flush=True)
    results = []
    start = time.monotonic()
    for name in opts.faults:
        r = run_fault(name, out, opts.scenario, opts.at)
        results.append(r.as_dict())
        row = (f"| {r.fault} | {r.expect} | {r.outcome} | {_fmt(r.collision)} | "
               f"{_fmt(r.goal_reached)} | {_fmt(r.min_clearance, '.3f')} | "
               f"{_fmt(r.time_to_stop, '.2f')} | {r.rejected} | {len(r.orphans)} | "
               f"{'yes' if r.passed else 'NO'} |")
        rows.append(row)
        print(row, flush=True)
    (out / "results.json").write_text(json.dumps(results, indent=1))
    (out / "results.md").write_text("\n".join(rows) + "\n")
    held = sum(r["passed"] for r in results)
    collisions = sum(bool(r["collision"]) for r in results)
    print(f"\n{held} of {len(results)} faults handled as expected, {collisions} collision(s); "
          f"{time.monotonic() - start:.0f} s; rows in {out / 'results.md'}")
    return 0 if held == len(results) else 1


if __name__ == "__main__":
    sys.exit(main())
