"""The PNG plots of a run: top view, side view, barrier values, commands and clearance.

Drawn from :class:`~safe_legged_c3bf.run.monitor.RunData` and the
:class:`~safe_legged_c3bf.run.report.RunContext` on Agg figures (:mod:`.figure`), no pyplot
state; :func:`write_plots` draws them all into a run folder.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from safe_legged_c3bf.run.figure import figure
from safe_legged_c3bf.run.monitor import INTERVENING, RunData

if TYPE_CHECKING:
    from safe_legged_c3bf.run.report import RunContext

PLOTS = {
    "top_view": "top_view.png",
    "side_view": "side_view.png",
    "barrier": "barrier_h.png",
    "commands": "commands.png",
    "clearance": "clearance.png",
}


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
