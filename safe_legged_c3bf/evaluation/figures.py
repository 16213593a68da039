"""The evaluation figures: per (robot, scenario kind) group, filter on against off.

:func:`write_figures` draws ``outcomes.png`` (collision and success rates, %),
``clearance.png`` (min robot-obstacle distance per run, m, ground truth), ``overhead.png``
(time-to-goal overhead, s), ``intervention.png`` (share of the run the filter changed the
command, %) and ``solve_time.png`` (filter solve time, ms) from the result rows of
:func:`safe_legged_c3bf.evaluation.runner.record_from_report`. Run failures and the
obstacle-free reference runs are left out.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from safe_legged_c3bf.evaluation.metrics import finite_values, summarize_group
from safe_legged_c3bf.evaluation.runner import RUN_FAILURES
from safe_legged_c3bf.run.figure import figure

FIGURES = {
    "outcomes": "outcomes.png",
    "clearance": "clearance.png",
    "overhead": "overhead.png",
    "solve_time": "solve_time.png",
    "intervention": "intervention.png",
}


def _figure(size: tuple[float, float] = (9, 4.5)):  # noqa: ANN202
    fig, axes = figure(size)  # the run report's Agg figure, one axes
    return fig, axes[0, 0]


def _group_labels(records, keys=("robot", "kind")) -> list[tuple]:  # noqa: ANN001
    return sorted({tuple(str(r.get(k, "")) for k in keys) for r in records
                   if r.get("variant", "obstacles") != "free"})


def _strip(ax, groups: list[tuple[str, np.ndarray]], color: str, offset: float) -> None:  # noqa: ANN001
    for i, (_, vals) in enumerate(groups):
        if vals.size:
            jitter = np.linspace(-0.08, 0.08, vals.size) if vals.size > 1 else np.zeros(1)
            ax.plot(i + offset + jitter, vals, "o", color=color, alpha=0.7, ms=5)
            ax.plot([i + offset - 0.15, i + offset + 0.15], [np.median(vals)] * 2, "-",
                    color=color, lw=2)


def write_figures(records: Sequence[dict[str, Any]], folder: Path) -> list[str]:
    """Draw the evaluation figures into ``folder``; return their paths relative to its parent."""
    folder.mkdir(parents=True, exist_ok=True)
    rel = folder.name
    groups = _group_labels(records)
    names = [f"{robot}\n{kind}" for robot, kind in groups]
    obstacle_runs = [r for r in records if r.get("variant", "obstacles") != "free"
                     and r.get("outcome") not in RUN_FAILURES]

    def pick(robot: str, kind: str, filt: str) -> list[dict[str, Any]]:
        return [r for r in obstacle_runs if str(r.get("robot")) == robot
                and str(r.get("kind")) == kind and r.get("filter") == filt]

    written = []
    # outcomes: collision rate (filter on / off) and success rate (filter on) per group
    fig, ax = _figure((max(6, 1.6 * len(groups) + 3), 4.5))
    x = np.arange(len(groups))
    bars = (("on", "collision_rate", "tab:red", "collision, filter on"),
            ("off", "collision_rate", "salmon", "collision, filter off"),
            ("on", "success_rate", "tab:green", "success, filter on"))
    for k, (filt, key, color, label) in enumerate(bars):
        vals = [summarize_group(pick(rb, kd, filt)).get(key) for rb, kd in groups]
        heights = [np.nan if v is None else 100 * v for v in vals]
        bars_k = ax.bar(x + (k - 1) * 0.27, heights, 0.25, color=color, label=label)
        ax.bar_label(bars_k, labels=["" if np.isnan(h) else f"{h:.0f}" for h in heights],
                     fontsize=7)
    ax.set_xticks(x, names, fontsize=8)
    ax.set_ylabel("% of runs")
    ax.set_ylim(0, 110)
    ax.set_title("Collisions and successes per scenario kind")
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(folder / FIGURES["outcomes"])
    written.append(f"{rel}/{FIGURES['outcomes']}")
    # min clearance distribution, filter on vs off
    fig, ax = _figure((max(6, 1.6 * len(groups) + 3), 4.5))
    for filt, color, off in (("on", "tab:blue", -0.18), ("off", "tab:gray", 0.18)):
        _strip(ax, [(n, finite_values(pick(rb, kd, filt), "min_clearance"))
                    for n, (rb, kd) in zip(names, groups, strict=True)], color, off)
        ax.plot([], [], "o", color=color, label=f"filter {filt}")
    ax.axhline(0.0, color="black", lw=1)
    ax.set_xticks(x, names, fontsize=8)
    ax.set_ylabel("min robot-obstacle distance (m)")
    ax.set_title("Minimum clearance per run (ground truth; 0 = contact)")
    ax.legend(fontsize=8)
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(folder / FIGURES["clearance"])
    written.append(f"{rel}/{FIGURES['clearance']}")
    # time-to-goal overhead
    fig, ax = _figure((max(6, 1.6 * len(groups) + 3), 4.5))
    _strip(ax, [(n, finite_values(pick(rb, kd, "on"), "overhead_s"))
                for n, (rb, kd) in zip(names, groups, strict=True)], "tab:purple", 0.0)
    ax.axhline(0.0, color="black", lw=1)
    ax.set_xticks(x, names, fontsize=8)
    ax.set_ylabel("time to goal - obstacle-free time to goal (s)")
    ax.set_title("Time-to-goal overhead with the filter")
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(folder / FIGURES["overhead"])
    written.append(f"{rel}/{FIGURES['overhead']}")
    # intervention share
    fig, ax = _figure((max(6, 1.6 * len(groups) + 3), 4.5))
    _strip(ax, [(n, 100 * finite_values(pick(rb, kd, "on"), "intervention_share"))
                for n, (rb, kd) in zip(names, groups, strict=True)], "tab:orange", 0.0)
    ax.set_xticks(x, names, fontsize=8)
    ax.set_ylabel("% of the run")
    ax.set_ylim(bottom=0)
    ax.set_title("Share of time the filter changed the command")
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(folder / FIGURES["intervention"])
    written.append(f"{rel}/{FIGURES['intervention']}")
    # solve times
    fig, ax = _figure((max(6, 1.6 * len(groups) + 3), 4.5))
    for key, color, off, label in (("solve_median_ms", "tab:blue", -0.18, "per-run median"),
                                   ("solve_p99_ms", "tab:red", 0.18, "per-run p99")):
        _strip(ax, [(n, finite_values(pick(rb, kd, "on"), key))
                    for n, (rb, kd) in zip(names, groups, strict=True)], color, off)
        ax.plot([], [], "o", color=color, label=label)
    ax.set_xticks(x, names, fontsize=8)
    ax.set_ylabel("filter solve time (ms)")
    ax.set_yscale("symlog", linthresh=0.1)
    ax.set_title("Safety filter solve time")
    ax.legend(fontsize=8)
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(folder / FIGURES["solve_time"])
    written.append(f"{rel}/{FIGURES['solve_time']}")
    return written
