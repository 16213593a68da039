"""How much of the time-to-goal overhead is the detour no controller could avoid (issue #17).

Reads evaluations run with their obstacle-free runs (``python -m safe_legged_c3bf.evaluate
--suite ...`` without ``--no-free``) and, for every filtered run that reached its goal (so
that it has an overhead), bounds from below the part of it that the static obstacles'
geometry alone forces on any robot walking at most the planner's cruise speed
(``safe_legged_c3bf/evaluation/detour_bound.py``: the shortest path round the static
obstacles grown by the trunk's inscribed radius). Prints, per robot and suite, the runs, the
measured overhead, that least detour (both in s and in % of the obstacle-free run's time,
mean and median), the least overhead of a clairvoyant robot that knew the movers' scripts
(``evaluation/reach_bound.py``: the same trunk disc at the cruise speed, waiting allowed;
within 2.7 % of the true least time) and the rest (overhead minus least detour), which is
what the filter, the movers and the gait cost; then the runs with the largest rest.

``--static DIR``: an evaluation of the same scenarios with their movers removed (each
scenario file's ``name`` with ``_static`` appended; ``--no-free``). Its goal times, against
the same obstacle-free runs, add a column between the two: what the static obstacles cost
the filtered robot, so that the rest splits into the filter's cost round static obstacles
and what the movers add. Runs whose static-only run missed its goal are left out of every
column of that table.

``start``: how much later than the obstacle-free run the robot is ``START_DISTANCE`` from
where it started (ground truth, the runs' ``timeseries.npz``), in the static-only run with
``--static``, else in the run itself: the part of the overhead paid before the robot walks.

Usage: python benchmarks/overhead_breakdown.py OUT_DIR [OUT_DIR ...] [--static DIR]
       [--worst 8]
       python benchmarks/overhead_breakdown.py OUT_DIR ... --write-static SCENARIO_DIR
         (writes the filtered runs' scenarios without their movers and prints the
         evaluation command that makes the --static folder)
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np
import yaml

from safe_legged_c3bf.evaluation.detour_bound import detour_bound
from safe_legged_c3bf.evaluation.reach_bound import reach_bound
from safe_legged_c3bf.evaluation.results import read_csv
from safe_legged_c3bf.sim.scenario import load_scenario

#: Distance [m] from the start within which the start's delay is measured.
START_DISTANCE = 0.3


def time_to_leave(run_dir: str | None, distance: float = START_DISTANCE) -> float:
    """Sim time [s] at which the base is first ``distance`` from its start; nan if never."""
    path = Path(str(run_dir or "")) / "timeseries.npz"
    if not path.is_file():
        return float("nan")
    with np.load(path) as z:
        odom = np.asarray(z["odom"])
    away = np.hypot(odom[:, 1] - odom[0, 1], odom[:, 2] - odom[0, 2]) >= distance
    return float(odom[np.argmax(away), 0]) if away.any() else float("nan")


def _scenario(row: dict):
    """The run's scenario: the copy in its run folder, else the named one."""
    copy = Path(str(row.get("run_dir") or "")) / "scenario.yaml"
    return load_scenario(copy if copy.is_file() else str(row["scenario"]))


def breakdown_rows(folders: list[Path], static: Path | None = None) -> list[dict]:
    """One dict per filtered run with an overhead: its ids, overheads and least detour [s].

    With ``static``, only runs whose static-only run reached its goal, with its overhead.
    """
    static_goal, static_dir = {}, {}
    if static is not None:
        for row in read_csv(static / "results.csv"):
            if row.get("filter") == "on" and row.get("goal_reached"):
                case = str(row["case"]).removesuffix("_static")
                static_goal[case], static_dir[case] = float(row["goal_time"]), row["run_dir"]
    out = []
    for folder in folders:
        rows = read_csv(folder / "results.csv")
        free_dir = {r["case"]: r["run_dir"] for r in rows if r.get("variant") == "free"}
        for row in rows:
            if row.get("filter") != "on" or row.get("overhead_s") is None:
                continue
            if static is not None and row["case"] not in static_goal:
                continue
            scenario = _scenario(row)
            bound = detour_bound(scenario)
            free, overhead = float(row["free_goal_time"]), float(row["overhead_s"])
            r = {"group": f"{row['robot']} {row['suite']}", "case": row["case"], "free": free,
                 "overhead": overhead, "detour": bound.extra_time,
                 "clairvoyant": reach_bound(scenario).extra_time,
                 "rest": overhead - bound.extra_time}
            if static is not None:
                r["static"] = static_goal[row["case"]] - free
            walked = static_dir[row["case"]] if static is not None else row["run_dir"]
            r["start"] = time_to_leave(walked) - time_to_leave(free_dir.get(row["case"]))
            out.append(r)
    return out


def _pct(rows: list[dict], key: str) -> tuple[float, float]:
    values = [100.0 * r[key] / r["free"] for r in rows]
    return statistics.fmean(values), statistics.median(values)


def print_table(rows: list[dict], worst: int) -> None:
    """The per-group table and the runs with the largest rest."""
    keys = ["overhead", "detour", "clairvoyant", "static", "start", "rest"] if (
        "static" in rows[0]) else ["overhead", "detour", "clairvoyant", "start", "rest"]
    titles = {"overhead": "overhead", "detour": "least detour",
              "clairvoyant": "least, movers known",
              "static": "static obstacles only",
              "start": f"of it, the first {START_DISTANCE} m"
              + (" (static only)" if "static" in rows[0] else ""),
              "rest": "rest (overhead - least detour)"}
    print("| robot, suite | runs | " + " | ".join(f"{titles[k]} mean / median" for k in keys)
          + " |")
    print("|---" * (len(keys) + 2) + "|")
    for group in sorted({r["group"] for r in rows}):
        g = [r for r in rows if r["group"] == group]
        cells = []
        for key in keys:
            g_key = [r for r in g if np.isfinite(r[key])]
            s_mean = statistics.fmean(r[key] for r in g_key)
            p_mean, p_median = _pct(g_key, key)
            cells.append(f"{s_mean:+.1f} s, {p_mean:+.0f} % / {p_median:+.0f} %")
        print(f"| {group} | {len(g)} | " + " | ".join(cells) + " |")
    print(f"\nLargest rest (overhead minus least detour), {worst} runs:")
    for r in sorted(rows, key=lambda r: -r["rest"])[:worst]:
        static = f", static only {r['static']:+.1f} s" if "static" in r else ""
        print(f"  {r['case']}: free {r['free']:.1f} s, overhead {r['overhead']:+.1f} s, "
              f"least detour {r['detour']:+.1f} s{static}, rest {r['rest']:+.1f} s")


def write_static(folders: list[Path], target: Path) -> list[Path]:
    """Write each filtered run's scenario without its movers, named ``<name>_static``."""
    target.mkdir(parents=True, exist_ok=True)
    paths = []
    for folder in folders:
        for row in read_csv(folder / "results.csv"):
            copy = Path(str(row.get("run_dir") or "")) / "scenario.yaml"
            if row.get("filter") != "on" or row.get("variant") == "free" or not copy.is_file():
                continue
            data = yaml.safe_load(copy.read_text(encoding="utf-8"))
            data["obstacles"] = [o for o in data.get("obstacles") or []
                                 if (o.get("motion") or {}).get("type", "static") == "static"]
            data["name"] = f"{data['name']}_static"
            data["description"] = f"movers removed: {data.get('description', '')}"
            path = target / f"{data['name']}.yaml"
            path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
            paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    """Print the breakdown of the evaluations in the given folders."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--static", type=Path, default=None,
                        help="an evaluation of the same scenarios without their movers")
    parser.add_argument("--worst", type=int, default=8)
    parser.add_argument("--write-static", type=Path, default=None, metavar="SCENARIO_DIR",
                        help="write the runs' scenarios without movers here and stop")
    args = parser.parse_args(argv)
    if args.write_static is not None:
        paths = write_static(args.folders, args.write_static)
        print(f"{len(paths)} scenarios in {args.write_static}; run them with\n"
              "python -m safe_legged_c3bf.evaluate --no-free --no-baseline --out DIR "
              + " ".join(f"--scenario {p}" for p in paths[:2]) + " ...")
        return 0
    rows = breakdown_rows(args.folders, args.static)
    if not rows:
        print("no filtered run with an overhead (run the evaluation without --no-free)")
        return 1
    print_table(rows, args.worst)
    return 0


if __name__ == "__main__":
    sys.exit(main())
