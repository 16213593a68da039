"""The filter's class-K gain gamma against detour cost and clearance (issue #17).

For each gamma, the same random scenarios (the widened generator) run with the bringup's
robot profile and ``filter: {gamma: g}``, two at a time, in-process; the obstacle-free runs
that give the time-to-goal overhead run once (no obstacle: the filter is inactive, gamma
plays no part). Prints per gamma: collisions, goals among the reachable, the time-to-goal
overhead (mean and median over the runs that reached their goal with every gamma, so each
gamma is timed on the same runs), the least and the median of the runs' least clearance,
the intervention share; draws overhead against clearance over gamma.

The rule the figure checks (doc/evaluation.md, "Choosing gamma"): head-on, the robot walks
inside the obstacle's collision cone, where ``h < 0`` and the constraint asks for a
deceleration ``gamma v + v^2 / d`` at distance ``d`` from any range; with the deceleration
limit ``a`` and the sensing range ``R``, ``gamma <= (a - v^2 / R) / v``.

Usage: python benchmarks/gamma_tradeoff.py [--robot quadruped|biped] [--seeds 20]
       [--gammas 0.5 1 2 4] [--out runs/gamma-<robot>] [--jobs 2]
       [--report-only]   (tabulate and draw the folders already in --out)
About 8 min per gamma for 20 A1 seeds on the 2-core machine (15 with the first gamma's
obstacle-free runs), 4 min for 10 biped seeds.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import subprocess
import sys
from pathlib import Path

from safe_legged_c3bf.evaluation import random_scenario as rs


def scenario_paths(robot: str, seeds: int, gamma: float, folder: Path) -> list[Path]:
    """The random scenarios of ``robot``, seeds 0.., written with ``filter.gamma`` set."""
    paths = []
    for seed in range(seeds):
        data = rs.generate_scenario(robot, seed)
        data["filter"] = {**(data.get("filter") or {}), "gamma": float(gamma)}
        paths.append(rs.write_scenario(folder / f"{data['name']}.yaml", data))
    return paths


def run_gamma(robot: str, seeds: int, gamma: float, out: Path, jobs: int, free: bool) -> int:
    """One campaign (``python -m safe_legged_c3bf.evaluate``) for ``gamma``; its exit code."""
    folder = out / f"gamma_{gamma:g}"
    paths = scenario_paths(robot, seeds, gamma, out / f"scenarios_gamma_{gamma:g}")
    cmd = [sys.executable, "-m", "safe_legged_c3bf.evaluate", "--in-process", "--no-baseline",
           "--jobs", str(jobs), "--out", str(folder), "--no-figures"]
    cmd += [] if free else ["--no-free"]
    for p in paths:
        cmd += ["--scenario", str(p)]
    print(f"gamma {gamma:g}: {len(paths)} scenarios -> {folder}", flush=True)
    return subprocess.run(cmd, stdout=subprocess.DEVNULL, check=False).returncode


def _rows(folder: Path) -> list[dict[str, str]]:
    path = folder / "results.csv"
    if not path.exists():
        return []
    with path.open(encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _true(value: str) -> bool:
    return str(value).strip().lower() == "true"


def summarise(out: Path, gammas: list[float]) -> list[dict[str, float]]:
    """Per gamma: the table's figures (see the module docstring)."""
    free_time: dict[str, float] = {}
    for g in gammas:
        for r in _rows(out / f"gamma_{g:g}"):
            if r["variant"] == "free" and r["goal_time"]:
                free_time[r["case"]] = float(r["goal_time"])
    runs = {g: {r["case"]: r for r in _rows(out / f"gamma_{g:g}")
                if r["variant"] == "obstacles"} for g in gammas}
    timed = set(free_time)
    for by_case in runs.values():
        timed &= {c for c, r in by_case.items() if _true(r["goal_reached"])}
    table = []
    for g in gammas:
        rows = list(runs[g].values())
        if not rows:
            continue
        reach = [r for r in rows if not r["impassable"]]
        over = [100.0 * (float(runs[g][c]["goal_time"]) / free_time[c] - 1.0) for c in timed]
        clear = [float(r["min_clearance"]) for r in rows if r["min_clearance"]]
        table.append({
            "gamma": g, "runs": len(rows),
            "collisions": sum(_true(r["collision"]) for r in rows),
            "reachable": len(reach),
            "reached": sum(_true(r["goal_reached"]) for r in reach),
            "timed": len(timed),
            "overhead_mean": statistics.fmean(over) if over else float("nan"),
            "overhead_median": statistics.median(over) if over else float("nan"),
            "clearance_min": min(clear) if clear else float("nan"),
            "clearance_median": statistics.median(clear) if clear else float("nan"),
            "intervention": statistics.fmean(float(r["intervention_share"] or 0) for r in rows),
        })
    return table


def print_table(table: list[dict[str, float]]) -> None:
    print("| gamma (1/s) | runs | collided | goals of the reachable | overhead mean / median "
          "(same runs) | least / median min clearance (m) | intervened |")
    print("|---|---|---|---|---|---|---|")
    for t in table:
        print(f"| {t['gamma']:g} | {t['runs']} | {t['collisions']} | "
              f"{t['reached']}/{t['reachable']} | {t['overhead_mean']:+.0f} % / "
              f"{t['overhead_median']:+.0f} % (n {t['timed']}) | {t['clearance_min']:.3f} / "
              f"{t['clearance_median']:.3f} | {100 * t['intervention']:.0f} % |")


def draw(table: list[dict[str, float]], path: Path, robot: str) -> None:
    """Overhead (mean, %) against the median of the runs' least clearance, one point a gamma."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    xs = [t["clearance_median"] for t in table]
    ax.plot(xs, [t["overhead_mean"] for t in table], "o-", label="mean")
    ax.plot(xs, [t["overhead_median"] for t in table], "s--", label="median")
    for t in table:
        ax.annotate(f"gamma {t['gamma']:g}", (t["clearance_median"], t["overhead_mean"]),
                    textcoords="offset points", xytext=(5, 5))
    ax.set_xlabel("median of the runs' least clearance (m)")
    ax.set_ylabel("time-to-goal overhead (%)")
    ax.set_title(f"random {robot}: gamma trade-off")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", choices=("quadruped", "biped"), default="quadruped")
    ap.add_argument("--seeds", type=int, default=None, help="default 20 (A1) / 10 (biped)")
    ap.add_argument("--gammas", type=float, nargs="+", default=[0.5, 1.0, 2.0, 4.0])
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--report-only", action="store_true")
    args = ap.parse_args()
    seeds = args.seeds or (20 if args.robot == "quadruped" else 10)
    out = args.out or Path("runs") / f"gamma-{args.robot}"
    out.mkdir(parents=True, exist_ok=True)
    if not args.report_only:
        for k, g in enumerate(args.gammas):
            code = run_gamma(args.robot, seeds, g, out, args.jobs, free=k == 0)
            if code != 0:  # 1: some run could not be executed (it is missing below)
                print(f"gamma {g:g}: the campaign exited with {code}", file=sys.stderr)
    table = summarise(out, args.gammas)
    print_table(table)
    if table:
        draw(table, out / "gamma_tradeoff.png", args.robot)
        print(f"figure: {out / 'gamma_tradeoff.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
