"""Run summary and ``report.json`` from what the monitor collected.

``summarize`` reduces :class:`~safe_legged_c3bf.run.monitor.RunData` to the numbers a user
asks first (goal reached? collision? minimum clearance? how often did the filter step in? how
fast did it solve?); ``write_run_folder`` writes ``report.json``, ``timeseries.npz`` and the
PNG plots (:mod:`.plots`). ``python -m safe_legged_c3bf.run.report RUN_DIR`` redraws the
plots of a finished run from its ``timeseries.npz``.
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from safe_legged_c3bf.run.cpu_usage import cpu_summary
from safe_legged_c3bf.run.monitor import INTERVENING, STATUS_NAMES, ObstacleTrack, RunData
from safe_legged_c3bf.run.plots import write_plots


@dataclass
class RunContext:
    """Facts about the run that the monitor does not see.

    Attributes:
        scenario: scenario name.
        robot: robot kind ('quadruped' / 'biped').
        goal: goal (x, y) in odom, or None.
        goal_tolerance: distance at which the goal counts as reached (m).
        duration: scenario duration (s, sim time).
        robot_width: robot width used to inflate vertical obstacles (m).
        robot_height: body height used to inflate horizontal obstacles (m).
        safety_margin: extra inflation of every obstacle (m), as in the filter.
        filter_enabled: whether the safety filter was enabled.
        mode: 'processes' or 'in-process'.
        perception: 'oracle' (the simulator's detections) or 'sensors' (the detector node).
        wall_time: wall seconds from start of the nodes to the end of the run.
        outcome: 'completed', 'node_died', 'startup_failed', 'interrupted'.
        reason: one line explaining the outcome.
        cpu_seconds: CPU core-seconds per node process (or 'in_process': all of them).

    """

    scenario: str = ""
    robot: str = "quadruped"
    goal: tuple[float, float] | None = None
    goal_tolerance: float = 0.3
    duration: float = 0.0
    robot_width: float = 0.3
    robot_height: float = 0.2
    safety_margin: float = 0.0
    filter_enabled: bool = True
    mode: str = "processes"
    perception: str = "oracle"
    wall_time: float = 0.0
    outcome: str = "completed"
    reason: str = ""
    cpu_seconds: dict[str, float] = field(default_factory=dict)


def _finite(x: float | None) -> float | None:
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _durations(t: np.ndarray) -> np.ndarray:
    """Weight of each sample: time to the next one (the last gets the median step)."""
    if t.size == 0:
        return t
    if t.size == 1:
        return np.ones(1)
    dt = np.diff(t)
    return np.append(dt, np.median(dt))


def summarize(
    data: RunData,
    ctx: RunContext,
    sim_time: float | None,
    simulator: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The run summary (JSON-ready) from collected data and context.

    ``simulator`` is the simulator's own summary (``simulator_summary.json``) when there is
    one: its collision, fall and clearance figures are evaluated at every physics step, so
    they take precedence over the 100 Hz /ground_truth/safety samples the monitor saw.
    """
    arr = data.arrays()
    odom, safety, state = arr["odom"], arr["safety"], arr["filter_state"]
    summary: dict[str, Any] = {
        "scenario": ctx.scenario,
        "robot": ctx.robot,
        "filter_enabled": ctx.filter_enabled,
        "mode": ctx.mode,
        "perception": ctx.perception,
        "outcome": ctx.outcome,
        "completed": ctx.outcome == "completed",
        "reason": ctx.reason,
    }
    # time
    if simulator and simulator.get("sim_time") is not None:
        sim_time = max(sim_time or 0.0, float(simulator["sim_time"]))
    summary["sim_time"] = _finite(sim_time)
    summary["duration"] = ctx.duration
    summary["wall_time"] = round(ctx.wall_time, 3)
    summary["real_time_factor"] = _finite(
        None if data.wall_last is None or data.wall_last <= (data.wall_start or 0)
        else (data.sim_last - data.sim_start) / (data.wall_last - data.wall_start)
    )
    summary["cpu"] = cpu_summary(ctx.cpu_seconds, summary["sim_time"], ctx.wall_time)
    summary["goal"] = _goal_summary(odom, ctx)
    summary["path_length"] = (
        float(np.sum(np.hypot(np.diff(odom[:, 1]), np.diff(odom[:, 2])))) if len(odom) > 1 else 0.0
    )
    summary["final_position"] = [float(odom[-1, 1]), float(odom[-1, 2])] if odom.size else None
    summary.update(_safety_summary(safety, data))
    summary["ground_truth_source"] = "/ground_truth/safety" if safety.size else None
    if simulator:
        _apply_simulator_summary(summary, simulator)
    summary["filter"] = _filter_summary(state, data)
    summary["messages"] = {
        "odom": int(len(odom)), "cmd_vel": len(data.cmd_vel),
        "cmd_vel_safe": len(data.cmd_vel_safe), "filter_state": int(len(state)),
        "ground_truth_safety": int(len(safety)), "obstacles": len(data.obstacles),
    }
    return summary


def _goal_summary(odom: np.ndarray, ctx: RunContext) -> dict[str, Any]:
    """Goal position, tolerance, final and closest distance, when it was reached."""
    goal: dict[str, Any] = {"position": list(ctx.goal) if ctx.goal else None,
                            "tolerance": ctx.goal_tolerance}
    if odom.size and ctx.goal is not None:
        dist = np.hypot(odom[:, 1] - ctx.goal[0], odom[:, 2] - ctx.goal[1])
        within = np.nonzero(dist <= ctx.goal_tolerance)[0]
        goal["final_distance"] = float(dist[-1])
        goal["min_distance"] = float(dist.min())
        goal["reached"] = bool(within.size)
        goal["time_reached"] = float(odom[within[0], 0]) if within.size else None
    else:
        goal.update(final_distance=None, min_distance=None, reached=False, time_reached=None)
    return goal


def _safety_summary(safety: np.ndarray, data: RunData) -> dict[str, Any]:
    """Collision, fall and clearance figures from the /ground_truth/safety samples."""
    if not safety.size:
        return dict(collision=None, collision_count=None, collision_time=None,
                    obstacles_touched=[], fallen=None, min_clearance=None,
                    min_clearance_time=None, min_clearance_obstacle=None)
    clearance = safety[:, 3]
    finite = np.isfinite(clearance)
    i = int(np.argmin(np.where(finite, clearance, np.inf))) if finite.any() else None
    return {
        "collision": bool(safety[:, 1].any() or safety[:, 2].max() > 0),
        "collision_count": int(safety[:, 2].max()),
        "collision_time": _durations_sum(safety[:, 0], safety[:, 1] > 0),
        "obstacles_touched": sorted(data.contacts),
        "fallen": bool(safety[:, 4].any()),
        "min_clearance": _finite(clearance[i]) if i is not None else None,
        "min_clearance_time": float(safety[i, 0]) if i is not None else None,
        "min_clearance_obstacle": data.closest[i] if i is not None else None,
    }


def _filter_summary(state: np.ndarray, data: RunData) -> dict[str, Any]:
    """Filter cycles, solvers, intervention and status shares, solve times, lowest h."""
    filt: dict[str, Any] = {"cycles": int(len(state)), "solvers": sorted(data.solver_names)}
    if not state.size:
        filt.update(intervention_share=None, status_share={},
                    solve_time_ms={"median": None, "p99": None, "max": None}, min_h=None)
        return filt
    w = _durations(state[:, 0])
    status = state[:, 1].astype(int)
    total = float(w.sum()) or 1.0
    filt["intervention_share"] = float(w[np.isin(status, list(INTERVENING))].sum() / total)
    filt["status_share"] = {
        STATUS_NAMES.get(s, str(s)): float(w[status == s].sum() / total)
        for s in sorted(set(status.tolist()))
    }
    solve_ms = state[:, 3] * 1e3
    solve_ms = solve_ms[np.isfinite(solve_ms)]
    filt["solve_time_ms"] = {
        "median": float(np.median(solve_ms)) if solve_ms.size else None,
        "p99": float(np.percentile(solve_ms, 99)) if solve_ms.size else None,
        "max": float(solve_ms.max()) if solve_ms.size else None,
    }
    h = state[:, 2]
    h = h[np.isfinite(h)]
    filt["min_h"] = float(h.min()) if h.size else None
    return filt


def _apply_simulator_summary(summary: dict[str, Any], sim: dict[str, Any]) -> None:
    """Take collision, fall and clearance figures from the simulator's own summary."""
    if "collision_count" in sim:
        count = int(sim["collision_count"] or 0)
        summary["collision_count"] = count
        summary["collision"] = count > 0 or bool(sim.get("time_in_collision"))
        touched = {c.get("obstacle_id") for c in sim.get("collisions") or [] if c}
        summary["obstacles_touched"] = sorted(
            set(summary.get("obstacles_touched") or []) | {t for t in touched if t}
        )
    if sim.get("time_in_collision") is not None:
        summary["collision_time"] = float(sim["time_in_collision"])
    if "fell" in sim:
        summary["fallen"] = bool(sim["fell"])
        summary["fall_time"] = sim.get("fall_time")
    if "min_distance" in sim:
        summary["min_clearance"] = _finite(sim["min_distance"])
        summary["min_clearance_time"] = sim.get("min_distance_time")
        summary["min_clearance_obstacle"] = sim.get("min_distance_obstacle")
    summary["ground_truth_source"] = "simulator summary (every physics step)"


def _durations_sum(t: np.ndarray, mask: np.ndarray) -> float:
    return float(_durations(t)[mask].sum()) if t.size else 0.0


def _fmt(value: Any, spec: str = ".2f", unit: str = "") -> str:
    if value is None:
        return "n/a"
    text = f"{value:{spec}}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]  # no "-0.000"
    return text + unit


def format_summary(summary: dict[str, Any], run_dir: Path | None = None) -> str:
    """The summary as the lines printed at the end of a run."""
    g, f = summary["goal"], summary["filter"]
    solve = f.get("solve_time_ms") or {}
    collision = summary.get("collision")
    if collision is None:
        collision_text = "unknown (no ground truth received)"
    elif collision:
        touched = ", ".join(summary.get("obstacles_touched") or []) or "?"
        collision_text = f"YES ({summary['collision_count']} event(s); touched {touched})"
    else:
        collision_text = "no"
    if g.get("reached"):
        goal_text = (
            f"yes (at t = {g['time_reached']:.1f} s; "
            f"final distance {g['final_distance']:.2f} m)"
        )
    else:
        goal_text = f"no (final distance {_fmt(g.get('final_distance'), '.2f', ' m')})"
    share = f.get("intervention_share")
    lines = [
        f"Run {summary['outcome'].upper()}: {summary['reason']}" if summary.get("reason")
        else f"Run {summary['outcome'].upper()}",
        f"  scenario          {summary['scenario']} ({summary['robot']}, filter "
        f"{'on' if summary['filter_enabled'] else 'OFF'}, {summary['mode']})",
        f"  goal reached      {goal_text}",
        f"  collision         {collision_text}",
        f"  fallen            {_yesno(summary.get('fallen'))}",
        f"  min clearance     {_fmt(summary.get('min_clearance'), '.3f', ' m')}"
        + (f" (to {summary['min_clearance_obstacle']} at t = {summary['min_clearance_time']:.1f} s)"
           if summary.get("min_clearance_obstacle") else ""),
        f"  time              {_fmt(summary.get('sim_time'), '.1f', ' s')} sim in "
        f"{summary['wall_time']:.1f} s wall (real-time factor "
        f"{_fmt(summary.get('real_time_factor'), '.2f')})",
        f"  cpu               {_cpu_text(summary.get('cpu') or {})}",
        f"  filter intervened {_fmt(None if share is None else 100 * share, '.1f', ' %')} "
        f"of the time ({f['cycles']} cycles)",
        f"  filter solve time median {_fmt(solve.get('median'), '.3f', ' ms')}, "
        f"p99 {_fmt(solve.get('p99'), '.3f', ' ms')}",
    ]
    if run_dir is not None:
        lines.append(f"  run folder        {run_dir}")
    return "\n".join(lines)


def _cpu_text(cpu: dict[str, Any]) -> str:
    """'1.42 core-s per sim s (simulator 0.60, ...)' or 'n/a'."""
    total, per = cpu.get("total_per_sim_second"), cpu.get("per_sim_second") or {}
    if total is None:
        return "n/a"
    parts = ", ".join(f"{k} {v:.2f}" for k, v in sorted(per.items(), key=lambda kv: -kv[1]))
    return f"{total:.2f} core-s per sim s ({parts})"


def _yesno(value: bool | None) -> str:
    return "unknown" if value is None else ("YES" if value else "no")


# ----------------------------------------------------------------------------- storage


def save_timeseries(path: Path, data: RunData) -> None:
    """Write the series to ``timeseries.npz`` (re-plot with ``python -m ...run.report``)."""
    arrays = data.arrays()
    extra: dict[str, np.ndarray] = {}
    for i, (oid, rows) in enumerate(sorted(data.barrier.items())):
        extra[f"barrier_{i}"] = np.array(rows, dtype=float).reshape(-1, 2)
        extra[f"barrier_{i}_id"] = np.array(oid)
    for i, (oid, track) in enumerate(sorted(data.obstacles.items())):
        extra[f"obstacle_{i}"] = np.column_stack(
            [np.array(track.t, dtype=float), np.array(track.xyz, dtype=float).reshape(-1, 3)]
        )
        extra[f"obstacle_{i}_meta"] = np.array(
            json.dumps({"id": oid, "plane": track.plane, "semi_axes": list(track.semi_axes),
                        "orientation": track.orientation, "extent": track.extent})
        )
    np.savez_compressed(path, **arrays, **extra)


def load_timeseries(path: Path) -> RunData:
    """Inverse of :func:`save_timeseries` (tabular series, barriers and obstacles)."""
    data = RunData()
    with np.load(path) as z:
        for name in ("odom", "cmd_vel", "cmd_vel_safe", "filter_state", "safety"):
            setattr(data, name, [tuple(r) for r in z[name]])
        data.closest = [""] * len(data.safety)
        i = 0
        while f"barrier_{i}" in z:
            data.barrier[str(z[f"barrier_{i}_id"])] = [tuple(r) for r in z[f"barrier_{i}"]]
            i += 1
        i = 0
        while f"obstacle_{i}" in z:
            meta = json.loads(str(z[f"obstacle_{i}_meta"]))
            rows = z[f"obstacle_{i}"]
            data.obstacles[meta["id"]] = ObstacleTrack(
                meta["id"], meta["plane"], tuple(meta["semi_axes"]), meta["orientation"],
                meta["extent"], rows[:, 0].tolist(), [tuple(r) for r in rows[:, 1:]],
            )
            i += 1
    return data


def write_run_folder(
    run_dir: Path,
    data: RunData,
    ctx: RunContext,
    sim_time: float | None,
    extra: dict[str, Any] | None = None,
    simulator: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Write report.json, timeseries.npz and the plots; return the report."""
    run_dir.mkdir(parents=True, exist_ok=True)
    summary = summarize(data, ctx, sim_time, simulator)
    report: dict[str, Any] = {"summary": summary, "context": asdict(ctx)}
    report["context"]["goal"] = list(ctx.goal) if ctx.goal else None
    report["diagnostics"] = {
        "last": {k: {"level": v[0], "message": v[1]} for k, v in sorted(data.diagnostics.items())},
        "events": [
            {"t": t, "name": n, "level": lvl, "message": m}
            for t, n, lvl, m in data.diagnostic_events[-200:]
        ],
    }
    save_timeseries(run_dir / "timeseries.npz", data)
    files = ["timeseries.npz"]
    try:
        files += write_plots(run_dir, data, ctx)
    except Exception as err:  # noqa: BLE001 - a plot bug must not lose the report
        report["plot_error"] = repr(err)
    report["files"] = files
    if simulator is not None:
        report["simulator"] = simulator
    if extra:
        report.update(extra)
    with open(run_dir / "report.json", "w", encoding="utf-8") as f:
        json.dump(report, f, indent=2, default=_json_default)
        f.write("\n")
    return report


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, set | tuple):
        return list(value)
    raise TypeError(f"not JSON serializable: {type(value).__name__}")


def main(args: list[str] | None = None) -> int:
    """Redraw the plots of a run folder from its timeseries.npz and report.json."""
    parser = argparse.ArgumentParser(prog="python -m safe_legged_c3bf.run.report",
                                     description="Redraw the plots of a bringup run folder.")
    parser.add_argument("run_dir", type=Path)
    opts = parser.parse_args(args)
    report = json.loads((opts.run_dir / "report.json").read_text())
    ctx_fields = {k: v for k, v in report["context"].items() if k in RunContext.__annotations__}
    ctx = RunContext(**ctx_fields)
    if ctx.goal is not None:
        ctx.goal = tuple(ctx.goal)
    data = load_timeseries(opts.run_dir / "timeseries.npz")
    for name in write_plots(opts.run_dir, data, ctx):
        print(opts.run_dir / name)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
