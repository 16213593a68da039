"""The evaluation figures: per (robot, scenario kind) group, filter on against off.

:func:`write_figures` draws ``outcomes.png`` (collision and success rates, %, with 95 % intervals),
``clearance.png`` (min robot-obstacle distance per run, m, ground truth), ``overhead.png``
(time-to-goal overhead, s), ``intervention.png`` (share of the run the filter changed the
command, %) and ``solve_time.png`` (filter solve time, ms) from the result rows of
:func:`safe_legged_c3bf.evaluation.runner.record_from_report`. Run failures and the
obstacle-free reference runs are left out.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
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


@dataclass(frozen=True)
class _Groups:
    """The x axis of every figure: (robot, kind) groups, and the runs to plot.

    Attributes:
        keys: sorted (robot, kind) of the rows with obstacles.
        runs: the rows with obstacles, without run failures.

    """

    keys: list[tuple[str, str]]
    runs: list[dict[str, Any]]

    @classmethod
    def of(cls, records: Sequence[dict[str, Any]]) -> _Groups:
        """The groups of ``records`` (result rows)."""
        keys = sorted({(str(r.get("robot", "")), str(r.get("kind", ""))) for r in records
                       if r.get("variant", "obstacles") != "free"})
        runs = [r for r in records if r.get("variant", "obstacles") != "free"
                and r.get("outcome") not in RUN_FAILURES]
        return cls(keys, runs)

    @property
    def names(self) -> list[str]:
        """Tick labels: robot and kind on two lines."""
        return [f"{robot}\n{kind}" for robot, kind in self.keys]

    @property
    def x(self) -> np.ndarray:
        """Tick positions 0, 1, ..."""
        return np.arange(len(self.keys))

    def pick(self, robot: str, kind: str, filt: str) -> list[dict[str, Any]]:
        """The runs of one group with the filter 'on' or 'off'."""
        return [r for r in self.runs if str(r.get("robot")) == robot
                and str(r.get("kind")) == kind and r.get("filter") == filt]

    def values(self, key: str, filt: str) -> list[tuple[str, np.ndarray]]:
        """Per group: (tick label, the finite values of ``key`` in its runs with ``filt``)."""
        return [(n, finite_values(self.pick(rb, kd, filt), key))
                for n, (rb, kd) in zip(self.names, self.keys, strict=True)]


def _new_figure(groups: _Groups):  # noqa: ANN202
    """A figure wide enough for the groups (inches), and its one axes."""
    fig, axes = figure((max(6, 1.6 * len(groups.keys) + 3), 4.5))  # the run report's Agg figure
    return fig, axes[0, 0]


def _save(fig, ax, folder: Path, key: str) -> str:  # noqa: ANN001
    """Grid, lay out and write figure ``key``; return its path relative to folder's parent."""
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(folder / FIGURES[key])
    return f"{folder.name}/{FIGURES[key]}"


def _strip(ax, groups: list[tuple[str, np.ndarray]], color: str, offset: float) -> None:  # noqa: ANN001
    """Per group: its values as dots and their median as a bar, ``offset`` from the tick."""
    for i, (_, vals) in enumerate(groups):
        if vals.size:
            jitter = np.linspace(-0.08, 0.08, vals.size) if vals.size > 1 else np.zeros(1)
            ax.plot(i + offset + jitter, vals, "o", color=color, alpha=0.7, ms=5)
            ax.plot([i + offset - 0.15, i + offset + 0.15], [np.median(vals)] * 2, "-",
                    color=color, lw=2)


def write_figures(records: Sequence[dict[str, Any]], folder: Path) -> list[str]:
    """Draw the evaluation figures into ``folder``; return their paths relative to its parent."""
    folder.mkdir(parents=True, exist_ok=True)
    groups = _Groups.of(records)
    return [draw(groups, folder) for draw in (_outcomes, _clearance, _overhead, _intervention,
                                              _solve_time)]


def _outcomes(groups: _Groups, folder: Path) -> str:
    """Collision (filter on / off) and success rates (filter on) per group, % with 95 % bars."""
    fig, ax = _new_figure(groups)
    x = groups.x
    bars = (("on", "collision_rate", "tab:red", "collision, filter on"),
            ("off", "collision_rate", "salmon", "collision, filter off"),
            ("on", "success_rate", "tab:green", "success, filter on"))
    for k, (filt, key, color, label) in enumerate(bars):
        rows = [summarize_group(groups.pick(rb, kd, filt)) for rb, kd in groups.keys]
        heights = [np.nan if r.get(key) is None else 100 * r[key] for r in rows]
        err = np.array([[0.0, 0.0] if r.get(key) is None else
                        [100 * (r[key] - r[f"{key}_lo"]), 100 * (r[f"{key}_hi"] - r[key])]
                        for r in rows]).T
        bars_k = ax.bar(x + (k - 1) * 0.27, heights, 0.25, color=color, label=label,
                        yerr=err, error_kw={"elinewidth": 0.8, "capsize": 2})
        ax.bar_label(bars_k, labels=["" if np.isnan(h) else f"{h:.0f}" for h in heights],
                     fontsize=7)
    ax.set_xticks(x, groups.names, fontsize=8)
    ax.set_ylabel("% of runs")
    ax.set_ylim(0, 110)
    ax.set_title("Collisions and successes per scenario kind (bars: 95 % intervals)")
    ax.legend(fontsize=8, loc="upper right")
    return _save(fig, ax, folder, "outcomes")


def _clearance(groups: _Groups, folder: Path) -> str:
    """Min robot-obstacle distance per run (m, ground truth), filter on against off."""
    fig, ax = _new_figure(groups)
    for filt, color, off in (("on", "tab:blue", -0.18), ("off", "tab:gray", 0.18)):
        _strip(ax, groups.values("min_clearance", filt), color, off)
        ax.plot([], [], "o", color=color, label=f"filter {filt}")
    ax.axhline(0.0, color="black", lw=1)
    ax.set_xticks(groups.x, groups.names, fontsize=8)
    ax.set_ylabel("min robot-obstacle distance (m)")
    ax.set_title("Minimum clearance per run (ground truth; 0 = contact)")
    ax.legend(fontsize=8)
    return _save(fig, ax, folder, "clearance")


def _overhead(groups: _Groups, folder: Path) -> str:
    """Time-to-goal overhead per run with the filter (s)."""
    fig, ax = _new_figure(groups)
    _strip(ax, groups.values("overhead_s", "on"), "tab:purple", 0.0)
    ax.axhline(0.0, color="black", lw=1)
    ax.set_xticks(groups.x, groups.names, fontsize=8)
    ax.set_ylabel("time to goal - obstacle-free time to goal (s)")
    ax.set_title("Time-to-goal overhead with the filter")
    return _save(fig, ax, folder, "overhead")


def _intervention(groups: _Groups, folder: Path) -> str:
    """Share of each run the filter changed the command (%)."""
    fig, ax = _new_figure(groups)
    _strip(ax, [(n, 100 * v) for n, v in groups.values("intervention_share", "on")],
           "tab:orange", 0.0)
    ax.set_xticks(groups.x, groups.names, fontsize=8)
    ax.set_ylabel("% of the run")
    ax.set_ylim(bottom=0)
    ax.set_title("Share of time the filter changed the command")
    return _save(fig, ax, folder, "intervention")


def _solve_time(groups: _Groups, folder: Path) -> str:
    """Per-run median and 99th percentile of the filter's solve time (ms)."""
    fig, ax = _new_figure(groups)
    for key, color, off, label in (("solve_median_ms", "tab:blue", -0.18, "per-run median"),
                                   ("solve_p99_ms", "tab:red", 0.18, "per-run p99")):
        _strip(ax, groups.values(key, "on"), color, off)
        ax.plot([], [], "o", color=color, label=label)
    ax.set_xticks(groups.x, groups.names, fontsize=8)
    ax.set_ylabel("filter solve time (ms)")
    ax.set_yscale("symlog", linthresh=0.1)
    ax.set_title("Safety filter solve time")
    ax.legend(fontsize=8)
    return _save(fig, ax, folder, "solve_time")
