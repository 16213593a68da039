"""Write the evaluation results: tables (Markdown, CSV) and figures.

Input: the result rows of :func:`safe_legged_c3bf.evaluation.runner.record_from_report`
(plain dicts, one per bringup run); the metrics are computed in
:mod:`safe_legged_c3bf.evaluation.metrics` (definitions there and in doc/evaluation.md).
:func:`write_results` writes ``results.md``, ``results.csv`` (one row per run),
``summary.csv`` (the aggregate rows, every rate with its 95 % interval) and
``figures/*.png`` into a folder; :func:`read_csv`
reads a ``results.csv`` back.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from safe_legged_c3bf.evaluation.figures import FIGURES, write_figures
from safe_legged_c3bf.evaluation.metrics import (
    BODY_MODEL_COLUMNS,
    RATES,
    SUMMARY_COLUMNS,
    SUMMARY_CSV_COLUMNS,
    aggregate,
    attach_overhead,
    collision_bound,
    is_success,
    summarize_group,
)
from safe_legged_c3bf.evaluation.runner import RUN_FAILURES

__all__ = [  # metrics and figures are re-exported from their modules
    "FIGURES", "RUN_COLUMNS", "RUN_TABLE", "SUMMARY_COLUMNS", "SUMMARY_CSV_COLUMNS",
    "SUMMARY_HEADERS", "aggregate",
    "attach_overhead", "is_success", "markdown_table", "read_csv", "results_markdown",
    "summarize_group", "write_csv", "write_figures", "write_results",
]

#: Columns of results.csv, in order.
RUN_COLUMNS = (
    "run_id", "suite", "case", "scenario", "robot", "kind", "variant", "filter", "body_model",
    "perception", "seed", "outcome", "failures", "goal_reached", "goal_time", "free_goal_time",
    "overhead_s", "overhead_pct", "collision", "collision_count", "obstacles_touched", "fallen",
    "impassable", "impassable_by_margin", "stopped_before_impassable", "creep", "unsurvivable",
    "unsurvivable_detail", "leaders", "overtook",
    "min_clearance", "min_clearance_obstacle", "final_goal_distance", "path_length",
    "intervention_share", "relaxed_share", "brake_share", "filter_cycles", "solve_median_ms",
    "solve_p99_ms", "solve_max_ms", "sim_time", "duration", "real_time_factor", "wall_time",
    "exit_code", "timed_out", "reason", "run_dir",
)

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
                                            "relaxed_share", "relaxed_mean"):
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


def _rate_cell(row: dict[str, Any], key: str) -> str:
    """A rate with its 95 % interval when the row has one: "4.0 % (0.5-13.7)"."""
    text = _cell(row.get(key), key)
    lo, hi = row.get(f"{key}_lo"), row.get(f"{key}_hi")
    if key in RATES and lo is not None and hi is not None and row.get(key) is not None:
        text += f" ({100 * lo:.1f}–{100 * hi:.1f})"
    return text


def markdown_table(rows: Sequence[dict[str, Any]], columns: Sequence[str],
                   headers: Sequence[str] | None = None) -> str:
    """A GitHub Markdown table of ``rows`` (formatted per column name).

    A rate column shows the 95 % interval of the rate in percent after it, when the row
    carries one (``<rate>_lo``, ``<rate>_hi``: the aggregate rows).
    """
    headers = list(headers or columns)
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for r in rows:
        lines.append("| " + " | ".join(_rate_cell(r, c) for c in columns) + " |")
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
    "relaxed_mean": "RELAXED share", "collisions": "collided runs (survivable)",
    "unsurvivable_runs": "unsurvivable runs", "unsurvivable_collided": "unsurvivable collided",
    "impassable_runs": "impassable runs", "stopped_impassable": "stopped before impassable",
    "impassable_by_margin_runs": "impassable by margin only",
    "reachable_goal_rate": "goal reached (reachable)",
    "leader_runs": "runs with a slower leader", "overtook_runs": "overtook",
    "clearance_min": "min clearance (m)", "clearance_p10": "p10 clearance (m)",
    "clearance_median": "median clearance (m)", "overhead_mean_s": "overhead mean (s)",
    "overhead_max_s": "overhead max (s)", "overhead_mean_pct": "overhead mean",
    "intervention_mean": "intervened", "solve_median_ms": "solve median (ms)",
    "solve_p99_max_ms": "solve p99 max (ms)", "solve_max_ms": "solve max (ms)",
}
RUN_TABLE = (
    ("run_id", "run"), ("filter", "filter"), ("body_model", "body"),
    ("perception", "perception"), ("outcome", "outcome"),
    ("failures", "flags"), ("goal_time", "goal (s)"), ("free_goal_time", "free goal (s)"),
    ("overhead_s", "overhead (s)"), ("min_clearance", "min clearance (m)"),
    ("min_clearance_obstacle", "closest"), ("overtook", "overtook"),
    ("intervention_share", "intervened"),
    ("relaxed_share", "RELAXED"), ("solve_median_ms", "solve median (ms)"),
    ("solve_p99_ms", "solve p99 (ms)"), ("real_time_factor", "RTF"),
    ("wall_time", "wall (s)"),
)


def _body_model_section(records: Sequence[dict[str, Any]]) -> list[str]:
    """The single-point vs whole-body table (filter-on runs with a body model), or nothing."""
    rows = [r for r in records if r.get("body_model") and r.get("filter") == "on"]
    if not rows:
        return []
    keys = list(BODY_MODEL_COLUMNS)
    return [
        "## Filter body models side by side (same scenarios and seeds)", "",
        "`collided runs (survivable)` counts collisions outside the runs flagged unsurvivable "
        "(doc/evaluation.md); those are in `unsurvivable collided`.", "",
        markdown_table(aggregate(rows, ("robot", "body_model")), ["robot", "body_model", *keys],
                       ["robot", "filter body model", *(SUMMARY_HEADERS[k] for k in keys)]),
        "",
    ]


def _perception_section(records: Sequence[dict[str, Any]]) -> list[str]:
    """Oracle vs sensor perception (filter-on runs), when the campaign ran both, or nothing."""
    rows = [r for r in records if r.get("filter") == "on" and r.get("variant") == "obstacles"]
    if len({r.get("perception") or "oracle" for r in rows}) < 2:
        return []
    keys = list(BODY_MODEL_COLUMNS)
    return [
        "## Perception sources side by side (same scenarios and seeds)", "",
        "`oracle`: the simulator's noisy true shapes; `sensors`: the obstacle detector on "
        "the simulated LiDAR and 3-D sensor.", "",
        markdown_table(aggregate(rows, ("robot", "perception")), ["robot", "perception", *keys],
                       ["robot", "perception", *(SUMMARY_HEADERS[k] for k in keys)]),
        "",
    ]


def _bounds_section(by_filter: Sequence[dict[str, Any]]) -> list[str]:
    """The collision-rate bound each robot and filter setting supports, in words."""
    if not by_filter:
        return []
    lines = ["### Collision-rate bounds the campaign supports", ""]
    for row in by_filter:
        lines.append(f"- {row['robot']}, filter {row['filter']}: {collision_bound(row)}")
    return [*lines, ""]


def results_markdown(
    records: Sequence[dict[str, Any]], title: str = "Evaluation results",
    notes: Sequence[str] = (), figures: Sequence[str] = (),
) -> str:
    """The whole results.md text."""
    keys = list(SUMMARY_COLUMNS)
    heads = [SUMMARY_HEADERS[k] for k in keys]
    by_filter = aggregate(records, ("robot", "filter"))
    parts = [f"# {title}", ""]
    parts += [f"{n}" for n in notes]
    if notes:
        parts.append("")
    parts += [
        "Metrics: doc/evaluation.md. Rates are over the valid runs (run failures excluded), "
        "each followed by its 95 % Clopper-Pearson interval in percent; "
        "'overhead' is the time to goal minus that of the same scenario without obstacles "
        "(filter on, goal reached in both).", "",
        "## By robot and filter", "",
        markdown_table(by_filter, ["robot", "filter", *keys], ["robot", "filter", *heads]), "",
        *_bounds_section(by_filter),
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
        *_body_model_section(records),
        *_perception_section(records),
        "## Every run", "",
        markdown_table(sorted(records, key=lambda r: (r.get("case", ""), r.get("variant", ""),
                                                      r.get("filter", ""))),
                       [c for c, _ in RUN_TABLE], [h for _, h in RUN_TABLE]), "",
    ]
    failures = [r for r in records if r.get("outcome") in RUN_FAILURES
                or (r.get("filter") == "on"
                    and r.get("outcome") not in ("ok", "stopped_impassable"))]
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
    write_csv(paths["summary"], summary_rows, ("robot", "kind", "filter", *SUMMARY_CSV_COLUMNS))
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
