"""Real time on this machine: the whole graph, per pacing mode, robot and launcher.

Starts the bringup as a user does (``python -m safe_legged_c3bf.bringup``) for N sim seconds
(``--full-duration``, so every run lasts the same) in each mode and prints, per run:

- the achieved real-time factor (sim seconds per wall second, first to last message) and
  the simulator's own (``achieved_real_time_factor``);
- driver timeouts (a state the gait controller did not answer in time), lockstep timeouts,
  and whether the robot fell;
- CPU per node in core-seconds per sim second, and in total (in-process: one figure);
- the safety filter's period in sim time: median, p99 and longest gap between its
  /c3bf/state messages, and the share of gaps longer than 1.5 periods (missed cycles).

Modes: ``lockstep`` (the simulator waits for each state's command, paced by the wall clock
at RTF 1) and ``wallclock`` (``--no-lockstep``: paced by the wall clock alone; a late
controller misses states). ``--in-process`` adds the same runs with all nodes in one
process. ``--body-model body`` runs the whole-body filter (``filter: {body_model: body}``).

Usage: python benchmarks/realtime.py [--seconds 20] [--robots quadruped biped]
       [--modes lockstep wallclock] [--in-process] [--body-model point|body] [--repeat 1]
       [--perception oracle|sensors]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from safe_legged_c3bf.sim.scenario import resolve_scenario

SCENARIOS = {"quadruped": "quadruped_default", "biped": "biped_default"}
NODES = ("simulator", "gait_controller", "safety_filter", "obstacle_tracker",
         "reference_planner", "bringup")


def scenario_file(robot: str, body_model: str | None, folder: Path) -> str:
    """The robot's default scenario, with the filter's body model set when asked."""
    name = SCENARIOS[robot]
    if not body_model:
        return name
    raw = yaml.safe_load(resolve_scenario(name).read_text(encoding="utf-8"))
    raw.setdefault("filter", {})["body_model"] = body_model
    raw["name"] = f"{name}_{body_model}"
    path = folder / f"{raw['name']}.yaml"
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    return str(path)


def run_once(scenario: str, seconds: float, mode: str, in_process: bool, out: Path,
             perception: str | None = None) -> dict:
    """One bringup run (it leases its own private ROS domain); its report's figures."""
    cmd = [sys.executable, "-m", "safe_legged_c3bf.bringup", "--scenario", scenario,
           "--duration", str(seconds), "--full-duration", "--out", str(out),
           "--progress-period", "60"]
    if perception:
        cmd += ["--perception", perception]
    if mode == "wallclock":
        cmd.append("--no-lockstep")
    if in_process:
        cmd.append("--in-process")
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120 + 10 * seconds,
                          check=False)
    report_path = out / "report.json"
    if not report_path.is_file():
        return {"error": f"exit {proc.returncode}: {proc.stderr.strip()[-300:]}"}
    report = json.loads(report_path.read_text())
    return figures(report, out)


def figures(report: dict, out: Path) -> dict:
    """RTF, timeouts, fall, CPU per node and the filter period from a run folder."""
    s, sim = report["summary"], report.get("simulator") or {}
    row = {
        "rtf": s.get("real_time_factor"),
        "sim_rtf": sim.get("achieved_real_time_factor"),
        "driver_timeouts": sim.get("driver_timeouts"),
        "driver_timeout_times": sim.get("driver_timeout_times") or [],
        "driver_timeout_details": sim.get("driver_timeout_details") or [],
        "lockstep_timeouts": sim.get("lockstep_timeouts"),
        "pacing_resets": sim.get("pacing_resets"),
        "pacing_lost": sim.get("pacing_lost"),
        "fell": s.get("fallen"),
        "sim_time": s.get("sim_time"),
        "cpu": s["cpu"]["per_sim_second"],
        "cpu_total": s["cpu"]["total_per_sim_second"],
    }
    state = np.load(out / "timeseries.npz")["filter_state"]
    gaps = np.diff(state[:, 0]) * 1e3 if len(state) > 2 else np.zeros(1)
    period = float(np.median(gaps))
    row["filter_period_ms"] = {
        "median": round(period, 2), "p99": round(float(np.percentile(gaps, 99)), 2),
        "max": round(float(gaps.max()), 2),
        "missed_share": round(float(np.mean(gaps > 1.5 * period)), 4),
    }
    return row


def print_row(label: str, row: dict) -> None:
    """One line per run."""
    if "error" in row:
        print(f"{label:<38} FAILED {row['error']}")
        return
    cpu = row["cpu"]
    nodes = " ".join(f"{k.removeprefix('obstacle_')[:4]} {cpu[k]:.2f}"
                     for k in sorted(cpu, key=lambda k: -cpu[k]))
    p = row["filter_period_ms"]
    print(f"{label:<38} RTF {row['rtf']:.2f} (sim {row['sim_rtf'] or 0:.2f}) | driver "
          f"timeouts {row['driver_timeouts']} lockstep {row['lockstep_timeouts']} fell "
          f"{row['fell']} | CPU {row['cpu_total']:.2f} core-s/sim-s ({nodes}) | filter "
          f"period {p['median']:.1f} ms p99 {p['p99']:.1f} max {p['max']:.1f} missed "
          f"{100 * p['missed_share']:.1f} %")
    if row.get("pacing_resets"):
        print(f"{'':<38} physics gave up catching up {row['pacing_resets']} times, "
              f"{row['pacing_lost']:.2f} s (wall) in all")
    if row["driver_timeout_times"]:
        print(f"{'':<38} driver timeouts at t = {row['driver_timeout_times']} s (sim)")
        for d in row["driver_timeout_details"]:
            print(f"{'':<38} t {d['t']:.3f} s: {1e3 * d['wall_since_command']:.0f} ms (wall) "
                  f"since the last command, physics {1e3 * d['behind_schedule']:.0f} ms "
                  "behind schedule")


def main() -> int:
    """Run every (robot, launcher, mode) combination ``--repeat`` times and print a line each."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="sim seconds per run")
    ap.add_argument("--robots", nargs="+", choices=tuple(SCENARIOS), default=list(SCENARIOS))
    ap.add_argument("--modes", nargs="+", choices=("lockstep", "wallclock"),
                    default=["lockstep", "wallclock"])
    ap.add_argument("--in-process", action="store_true", help="also run every node in one process")
    ap.add_argument("--body-model", choices=("point", "body"), help="the filter's body model")
    ap.add_argument("--perception", choices=("oracle", "sensors"),
                    help="obstacle perception (default: the scenario's, oracle)")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--json", type=Path, help="also write every row to this file")
    opts = ap.parse_args()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{os.cpu_count()} cores, load average {load:.2f}; {opts.seconds:g} sim s per run")
    rows = []
    launchers = (False, True) if opts.in_process else (False,)
    with tempfile.TemporaryDirectory(prefix="realtime-") as tmp:
        folder = Path(tmp)
        for robot in opts.robots:
            scenario = scenario_file(robot, opts.body_model, folder)
            for in_process in launchers:
                for mode in opts.modes:
                    for k in range(opts.repeat):
                        label = (f"{robot} {'in-process' if in_process else 'processes'} "
                                 f"{mode} #{k + 1}")
                        out = folder / label.replace(" ", "_").replace("#", "")
                        row = run_once(scenario, opts.seconds, mode, in_process, out,
                                       opts.perception)
                        print_row(label, row)
                        rows.append({"label": label, **row})
    if opts.json:
        opts.json.write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
