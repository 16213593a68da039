"""Run summary, ``report.json`` and plots from what the monitor collected.

``summarize`` reduces :class:`~safe_legged_c3bf.run.monitor.RunData` to the numbers a user
asks first (goal reached? collision? minimum clearance? how often did the filter step in? how
fast did it solve?); ``write_run_folder`` writes ``report.json``, ``timeseries.npz`` and the
PNG plots (matplotlib, Agg canvas, no pyplot state). ``python -m safe_legged_c3bf.run.report
RUN_DIR`` redraws the plots of a finished run from its ``timeseries.npz``.
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from safe_legged_c3bf.run.figure import figure
from safe_legged_c3bf.run.monitor import INTERVENING, STATUS_NAMES, ObstacleTrack, RunData

PLOTS = {
    "top_view": "top_view.png",
    "side_view": "side_view.png",
    "barrier": "barrier_h.png",
    "commands": "commands.png",
    "clearance": "clearance.png",
}


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
        wall_time: wall seconds from start of the nodes to the end of the run.
        outcome: 'completed', 'node_died', 'startup_failed', 'interrupted'.
        reason: one line explaining the outcome.

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
    wall_time: float = 0.0
    outcome: str = "completed"
    reason: str = ""


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
    # goal
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
    summary["goal"] = goal
    summary["path_length"] = (
        float(np.sum(np.hypot(np.diff(odom[:, 1]), np.diff(odom[:, 2])))) if len(odom) > 1 else 0.0
    )
    summary["final_position"] = [float(odom[-1, 1]), float(odom[-1, 2])] if odom.size else None
    # safety (ground truth)
    if safety.size:
        clearance = safety[:, 3]
        finite = np.isfinite(clearance)
        i = int(np.argmin(np.where(finite, clearance, np.inf))) if finite.any() else None
        summary["collision"] = bool(safety[:, 1].any() or safety[:, 2].max() > 0)
        summary["collision_count"] = int(safety[:, 2].max())
        summary["collision_time"] = _durations_sum(safety[:, 0], safety[:, 1] > 0)
        summary["obstacles_touched"] = sorted(data.contacts)
        summary["fallen"] = bool(safety[:, 4].any())
        summary["min_clearance"] = _finite(clearance[i]) if i is not None else None
        summary["min_clearance_time"] = float(safety[i, 0]) if i is not None else None
        summary["min_clearance_obstacle"] = data.closest[i] if i is not None else None
    else:
        summary.update(collision=None, collision_count=None, collision_time=None,
                       obstacles_touched=[], fallen=None, min_clearance=None,
                       min_clearance_time=None, min_clearance_obstacle=None)
    summary["ground_truth_source"] = "/ground_truth/safety" if safety.size else None
    if simulator:
        _apply_simulator_summary(summary, simulator)
    # filter
    filt: dict[str, Any] = {"cycles": int(len(state)), "solvers": sorted(data.solver_names)}
    if state.size:
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
    else:
        filt.update(intervention_share=None, status_share={},
                    solve_time_ms={"median": None, "p99": None, "max": None}, min_h=None)
    summary["filter"] = filt
    summary["messages"] = {
        "odom": int(len(odom)), "cmd_vel": len(data.cmd_vel),
        "cmd_vel_safe": len(data.cmd_vel_safe), "filter_state": int(len(state)),
        "ground_truth_safety": int(len(safety)), "obstacles": len(data.obstacles),
    }
    return summary


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
        f"  filter intervened {_fmt(None if share is None else 100 * share, '.1f', ' %')} "
        f"of the time ({f['cycles']} cycles)",
        f"  filter solve time median {_fmt(solve.get('median'), '.3f', ' ms')}, "
        f"p99 {_fmt(solve.get('p99'), '.3f', ' ms')}",
    ]
    if run_dir is not None:
        lines.append(f"  run folder        {run_dir}")
    return "\n".join(lines)


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


# ----------------------------------------------------------------------------- plots


def _shade_intervals(ax, t: np.ndarray, mask: np.ndarray, color: str, label: str) -> None:  # noqa: ANN001
    """Shade the time spans where ``mask`` holds."""
    if t.size == 0 or not mask.any():
        return
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0] - 1
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    for k, (a, b) in enumerate(zip(starts, ends, strict=True)):
        ax.axvspan(t[a], t[b] + step, color=color, alpha=0.15, lw=0,
                   label=label if k == 0 else None)


def plot_top_view(path: Path, data: RunData, ctx: RunContext) -> None:
    """Path, goal and obstacles (true shape, inflated circle, path of moving ones) from above."""
    from matplotlib.patches import Circle, Ellipse, Rectangle

    fig, axes = figure((8, 7))
    ax = axes[0, 0]
    odom = data.arrays()["odom"]
    safety = data.arrays()["safety"]
    for oid, track in sorted(data.obstacles.items()):
        xyz = np.array(track.xyz).reshape(-1, 3)
        if not xyz.size:
            continue
        a, b = track.semi_axes
        moving = np.ptp(xyz[:, :2], axis=0).max() > 0.05 if len(xyz) > 1 else False
        x0, y0 = xyz[0, 0], xyz[0, 1]
        if track.plane == 0:  # vertical: ellipse in x-y
            ax.add_patch(Ellipse((x0, y0), 2 * a, 2 * b, angle=math.degrees(track.orientation),
                                 color="tab:red", alpha=0.5))
            r = max(a, b) + ctx.robot_width / 2 + ctx.safety_margin
            ax.add_patch(Circle((x0, y0), r, fill=False, ls="--", color="tab:red", lw=1))
            if moving:
                ax.plot(xyz[:, 0], xyz[:, 1], ":", color="tab:red", lw=1.2)
                ax.add_patch(Ellipse((xyz[-1, 0], xyz[-1, 1]), 2 * a, 2 * b,
                                     angle=math.degrees(track.orientation), fill=False,
                                     color="tab:red", alpha=0.6))
                ax.add_patch(Circle((xyz[-1, 0], xyz[-1, 1]), r, fill=False, ls="--",
                                    color="tab:red", alpha=0.4, lw=1))
        else:  # horizontal bar across y: footprint in x-y
            half_x = max(a, b)
            ax.add_patch(Rectangle((x0 - half_x, y0 - track.extent / 2), 2 * half_x,
                                   track.extent, color="tab:purple", alpha=0.25))
            if moving:
                ax.plot(xyz[:, 0], xyz[:, 1], ":", color="tab:purple", lw=1.2)
        ax.annotate(oid, (x0, y0), fontsize=8, ha="center", va="center")
    if odom.size:
        ax.plot(odom[:, 1], odom[:, 2], "-", color="tab:blue", lw=1.5, label="robot path")
        ax.plot(odom[0, 1], odom[0, 2], "o", color="tab:blue", label="start")
        if safety.size and safety[:, 1].any():
            hit_t = safety[safety[:, 1] > 0, 0]
            hx = np.interp(hit_t, odom[:, 0], odom[:, 1])
            hy = np.interp(hit_t, odom[:, 0], odom[:, 2])
            ax.plot(hx, hy, "x", color="black", ms=6, label="in collision")
    if ctx.goal is not None:
        ax.plot(*ctx.goal, "*", color="tab:green", ms=14, label="goal")
        ax.add_patch(Circle(ctx.goal, ctx.goal_tolerance, fill=False, color="tab:green"))
    ax.plot([], [], "--", color="tab:red", lw=1, label="inflated obstacle")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x (m, odom)")
    ax.set_ylabel("y (m, odom)")
    ax.set_title(f"{ctx.scenario}: top view")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.savefig(path)


def plot_side_view(path: Path, data: RunData, ctx: RunContext) -> bool:
    """Base height along x with horizontal obstacles (x-z); False when there are none."""
    from matplotlib.patches import Circle, Ellipse

    bars = [t for t in data.obstacles.values() if t.plane == 1 and t.xyz]
    if not bars:
        return False
    fig, axes = figure((9, 4.5))
    ax = axes[0, 0]
    for track in bars:
        x0, _, z0 = track.xyz[0]
        a, b = track.semi_axes
        ax.add_patch(Ellipse((x0, z0), 2 * a, 2 * b, angle=math.degrees(track.orientation),
                             color="tab:purple", alpha=0.5))
        r = max(a, b) + ctx.robot_height / 2 + ctx.safety_margin
        ax.add_patch(Circle((x0, z0), r, fill=False, ls="--",
                            color="tab:purple", lw=1))
        ax.annotate(track.id, (x0, z0), fontsize=8, ha="center", va="center")
    odom = data.arrays()["odom"]
    if odom.size:
        ax.plot(odom[:, 1], odom[:, 3], color="tab:blue", label="base height")
        ax.fill_between(odom[:, 1], odom[:, 3] - ctx.robot_height / 2,
                        odom[:, 3] + ctx.robot_height / 2, color="tab:blue", alpha=0.15,
                        label="body (height)")
    ax.axhline(0.0, color="black", lw=0.8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x (m, odom)")
    ax.set_ylabel("z (m)")
    ax.set_title(f"{ctx.scenario}: side view (horizontal obstacles)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.savefig(path)
    return True


def plot_barrier(path: Path, data: RunData, ctx: RunContext) -> None:
    """Barrier value h(t) per obstacle."""
    fig, axes = figure((9, 4.5))
    ax = axes[0, 0]
    for oid, rows in sorted(data.barrier.items()):
        arr = np.array(rows).reshape(-1, 2)
        ax.plot(arr[:, 0], arr[:, 1], ".", ms=2, label=oid)
    ax.axhline(0.0, color="black", lw=1)
    if not data.barrier:
        ax.text(0.5, 0.5, "no barrier values received", transform=ax.transAxes, ha="center")
    ax.set_xlabel("t (s, sim)")
    ax.set_ylabel("h (m²/s)")
    ax.set_title(f"{ctx.scenario}: C3BF barrier per obstacle (safe when h ≥ 0)")
    ax.grid(True, alpha=0.3)
    if data.barrier:
        ax.legend(loc="best", fontsize=8, markerscale=4)
    fig.savefig(path)


def plot_commands(path: Path, data: RunData, ctx: RunContext) -> None:
    """Reference vs filtered command, with the spans where the filter intervened."""
    arr = data.arrays()
    state = arr["filter_state"]
    if state.size:
        t, ref, out = state[:, 0], state[:, 4:8], state[:, 8:12]
        t_ref, t_out = t, t
        intervening = np.isin(state[:, 1].astype(int), list(INTERVENING))
    else:
        t_ref, ref = arr["cmd_vel"][:, 0], arr["cmd_vel"][:, 1:5]
        t_out, out = arr["cmd_vel_safe"][:, 0], arr["cmd_vel_safe"][:, 1:5]
        t, intervening = t_out, np.zeros(len(t_out), dtype=bool)
    fig, axes = figure((9, 8), 4, 1)
    labels = ["vx (m/s)", "vy (m/s)", "vz (m/s)", "yaw rate (rad/s)"]
    for k, label in enumerate(labels):
        ax = axes[k, 0]
        _shade_intervals(ax, t, intervening, "tab:orange", "filter intervened")
        ax.plot(t_ref, ref[:, k], color="tab:gray", lw=3.0, alpha=0.5, label="reference /cmd_vel")
        ax.plot(t_out, out[:, k], color="tab:blue", lw=1.0, label="filtered /cmd_vel_safe")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0, 0].set_title(f"{ctx.scenario}: reference vs filtered command (base_link)")
    axes[0, 0].legend(loc="best", fontsize=8)
    axes[-1, 0].set_xlabel("t (s, sim)")
    fig.tight_layout()
    fig.savefig(path)


def plot_clearance(path: Path, data: RunData, ctx: RunContext) -> None:
    """Ground-truth minimum robot-obstacle distance over time."""
    safety = data.arrays()["safety"]
    fig, axes = figure((9, 4))
    ax = axes[0, 0]
    if safety.size:
        _shade_intervals(ax, safety[:, 0], safety[:, 1] > 0, "tab:red", "in collision")
        ax.plot(safety[:, 0], safety[:, 3], color="tab:blue", label="min distance")
        ax.legend(loc="best", fontsize=8)
    else:
        ax.text(0.5, 0.5, "no ground truth received", transform=ax.transAxes, ha="center")
    ax.axhline(0.0, color="black", lw=1)
    ax.set_xlabel("t (s, sim)")
    ax.set_ylabel("clearance (m)")
    ax.set_title(f"{ctx.scenario}: robot-obstacle clearance (ground truth)")
    ax.grid(True, alpha=0.3)
    fig.savefig(path)


def write_plots(run_dir: Path, data: RunData, ctx: RunContext) -> list[str]:
    """Draw every plot into ``run_dir``; return the file names written."""
    written = []
    plot_top_view(run_dir / PLOTS["top_view"], data, ctx)
    written.append(PLOTS["top_view"])
    if plot_side_view(run_dir / PLOTS["side_view"], data, ctx):
        written.append(PLOTS["side_view"])
    for key, fn in (("barrier", plot_barrier), ("commands", plot_commands),
                    ("clearance", plot_clearance)):
        fn(run_dir / PLOTS[key], data, ctx)
        written.append(PLOTS[key])
    return written


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
