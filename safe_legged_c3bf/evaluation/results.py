"""Write the evaluation results: tables (Markdown, CSV) and figures.

Input: the result rows of :func:`safe_legged_c3bf.evaluation.runner.record_from_report`
(plain dicts, one per bringup run); the metrics are computed in
:mod:`safe_legged_c3bf.evaluation.metrics` (definitions there and in doc/evaluation.md).
:func:`write_results` writes ``results.md``, ``results.csv`` (one row per run),
``summary.csv`` (the aggregate rows) and ``figures/*.png`` into a folder; :func:`read_csv`
reads a ``results.csv`` back.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from safe_legged_c3bf.evaluation.metrics import (
    SUMMARY_COLUMNS,
    aggregate,
    attach_overhead,
    finite_values,
    is_success,
    summarize_group,
)
from safe_legged_c3bf.evaluation.runner import RUN_FAILURES
from safe_legged_c3bf.run.figure import figure

__all__ = [  # the metrics are re-exported from evaluation.metrics
    "FIGURES", "RUN_COLUMNS", "RUN_TABLE", "SUMMARY_COLUMNS", "SUMMARY_HEADERS", "aggregate",
    "attach_overhead", "is_success", "markdown_table", "read_csv", "results_markdown",
    "summarize_group", "write_csv", "write_figures", "write_results",
]

#: Columns of results.csv, in order.
RUN_COLUMNS = (
    "run_id", "suite", "case", "scenario", "robot", "kind", "variant", "filter", "seed",
    "outcome", "failures", "goal_reached", "goal_time", "free_goal_time", "overhead_s",
    "overhead_pct", "collision", "collision_count", "obstacles_touched", "fallen",
    "min_clearance", "min_clearance_obstacle", "final_goal_distance", "path_length",
    "intervention_share", "relaxed_share", "brake_share", "filter_cycles", "solve_median_ms",
    "solve_p99_ms", "solve_max_ms", "sim_time", "duration", "real_time_factor", "wall_time",
    "exit_code", "timed_out", "reason", "run_dir",
)
FIGURES = {
    "outcomes": "outcomes.png",
    "clearance": "clearance.png",
    "overhead": "overhead.png",
    "solve_time": "solve_time.png",
    "intervention": "intervention.png",
}


# ------------------------------------------------------------------------------ writing


def _cell(value: Any, key: str = "") -> str:
    if value is None or value == "" or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if abs(value) < 5e-4:
            value = 0.0  # no "-0.000"
        if key.endswith("_rate") or key in ("intervention_mean", "intervention_share",
                                            "relaxed_share"):
            digits = 1 if 0 < abs(value) < 0.1 else 0  # "0.4 %", not "0 %"
            return f"{100 * value:.{digits}f} %"
        if key.endswith("_ms"):
            return f"{value:.2f}"
        if key.endswith("_pct"):
            return f"{value:+.0f} %"
        if key.startswith("overhead"):
            return f"{value:+.1f}"
        if key.startswith("clearance") or key == "min_clearance":
            return f"{value:.3f}"
        return f"{value:.2f}"
    return str(value)


def markdown_table(rows: Sequence[dict[str, Any]], columns: Sequence[str],
                   headers: Sequence[str] | None = None) -> str:
    """A GitHub Markdown table of ``rows`` (formatted per column name)."""
    headers = list(headers or columns)
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for r in rows:
        lines.append("| " + " | ".join(_cell(r.get(c), c) for c in columns) + " |")
    return "\n".join(lines)


def write_csv(path: Path, rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> None:
    """Write ``rows`` to a CSV file with ``columns`` (missing values empty)."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=list(columns), extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({c: "" if r.get(c) is None else r.get(c) for c in columns})


def read_csv(path: Path) -> list[dict[str, Any]]:
    """Read a results.csv back (numbers and booleans converted, empty cells -> None)."""
    out = []
    with open(path, newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            out.append({k: _parse_cell(v) for k, v in row.items()})
    return out


def _parse_cell(text: str) -> Any:
    if text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


SUMMARY_HEADERS = {
    "runs": "runs", "run_failures": "run failures", "valid": "valid",
    "collision_rate": "collision", "fall_rate": "fell", "goal_rate": "goal reached",
    "success_rate": "success", "infeasible_runs": "RELAXED runs",
    "clearance_min": "min clearance (m)", "clearance_p10": "p10 clearance (m)",
    "clearance_median": "median clearance (m)", "overhead_mean_s": "overhead mean (s)",
    "overhead_max_s": "overhead max (s)", "overhead_mean_pct": "overhead mean",
    "intervention_mean": "intervened", "solve_median_ms": "solve median (ms)",
    "solve_p99_max_ms": "solve p99 max (ms)", "solve_max_ms": "solve max (ms)",
}
RUN_TABLE = (
    ("run_id", "run"), ("filter", "filter"), ("outcome", "outcome"),
    ("failures", "flags"), ("goal_time", "goal (s)"), ("free_goal_time", "free goal (s)"),
    ("overhead_s", "overhead (s)"), ("min_clearance", "min clearance (m)"),
    ("min_clearance_obstacle", "closest"), ("intervention_share", "intervened"),
    ("relaxed_share", "RELAXED"), ("solve_median_ms", "solve median (ms)"),
    ("solve_p99_ms", "solve p99 (ms)"), ("real_time_factor", "RTF"),
    ("wall_time", "wall (s)"),
)


def results_markdown(
    records: Sequence[dict[str, Any]], title: str = "Evaluation results",
    notes: Sequence[str] = (), figures: Sequence[str] = (),
) -> str:
    """The whole results.md text."""
    keys = list(SUMMARY_COLUMNS)
    heads = [SUMMARY_HEADERS[k] for k in keys]
    parts = [f"# {title}", ""]
    parts += [f"{n}" for n in notes]
    if notes:
        parts.append("")
    parts += [
        "Metrics: doc/evaluation.md. Rates are over the valid runs (run failures excluded); "
        "'overhead' is the time to goal minus that of the same scenario without obstacles "
        "(filter on, goal reached in both).", "",
        "## By robot and filter", "",
        markdown_table(aggregate(records, ("robot", "filter")), ["robot", "filter", *keys],
                       ["robot", "filter", *heads]), "",
        "## By robot, scenario kind and filter", "",
        markdown_table(aggregate(records, ("robot", "kind", "filter")),
                       ["robot", "kind", "filter", *keys], ["robot", "kind", "filter", *heads]),
        "",
        "## By scenario and filter", "",
        markdown_table(
            aggregate(records, ("scenario", "filter")),
            ["scenario", "filter", "runs", "collision_rate", "goal_rate", "success_rate",
             "clearance_min", "overhead_mean_s", "intervention_mean", "solve_p99_max_ms"],
            ["scenario", "filter", "runs", "collision", "goal reached", "success",
             "min clearance (m)", "overhead (s)", "intervened", "solve p99 max (ms)"],
        ), "",
        "## Every run", "",
        markdown_table(sorted(records, key=lambda r: (r.get("case", ""), r.get("variant", ""),
                                                      r.get("filter", ""))),
                       [c for c, _ in RUN_TABLE], [h for _, h in RUN_TABLE]), "",
    ]
    failures = [r for r in records if r.get("outcome") in RUN_FAILURES
                or (r.get("filter") == "on" and r.get("outcome") != "ok")]
    parts += ["## Failures (filter on, or runs that did not complete)", ""]
    if failures:
        for r in failures:
            parts.append(f"- `{r['run_id']}`: **{r['outcome']}** ({r.get('failures') or '-'})"
                         f" – {r.get('reason') or ''} – `{r.get('run_dir', '')}`")
    else:
        parts.append("None.")
    parts.append("")
    if figures:
        parts += ["## Figures", ""]
        parts += [f"![{Path(f).stem}]({f})" for f in figures]
        parts.append("")
    return "\n".join(parts)


def write_results(
    records: list[dict[str, Any]], out_dir: str | Path, title: str = "Evaluation results",
    notes: Sequence[str] = (), figures: bool = True,
) -> dict[str, Path]:
    """Write results.md, results.csv, summary.csv and figures/ into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    attach_overhead(records)
    paths = {"csv": out / "results.csv", "summary": out / "summary.csv",
             "markdown": out / "results.md"}
    write_csv(paths["csv"], records, RUN_COLUMNS)
    summary_rows = aggregate(records, ("robot", "kind", "filter"))
    write_csv(paths["summary"], summary_rows, ("robot", "kind", "filter", *SUMMARY_COLUMNS))
    written: list[str] = []
    if figures:
        try:
            written = write_figures(records, out / "figures")
        except Exception as err:  # noqa: BLE001 - a plotting bug must not lose the tables
            notes = [*notes, f"(figures failed: {err!r})"]
    for name in written:
        paths[Path(name).stem] = out / name
    paths["markdown"].write_text(results_markdown(records, title, notes, written),
                                 encoding="utf-8")
    return paths


# ------------------------------------------------------------------------------ figures


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
