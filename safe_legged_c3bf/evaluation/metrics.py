"""Evaluation metrics: the time-to-goal overhead of each run and the aggregate of a group.

Input: the result rows of :func:`safe_legged_c3bf.evaluation.runner.record_from_report`
(plain dicts, one per bringup run). :func:`attach_overhead` pairs every run with the
obstacle-free run of the same case (``variant == 'free'``) and adds the time-to-goal overhead;
:func:`aggregate` groups rows (by robot and filter, or by robot, scenario kind and filter) and
computes, per group (metric definitions: doc/evaluation.md):

* ``runs``: rows with obstacles in the group; ``run_failures``: of those, runs without a
  trustworthy result (start-up failure, node died, wall timeout, interrupted), which the
  rates below exclude (``valid`` = runs - run_failures);
* ``collision_rate``, ``fall_rate``, ``goal_rate`` and ``success_rate`` (goal reached or
  stopped and held before an impassable obstacle, no collision, no fall) over the valid runs,
  ``reachable_goal_rate``: the goal rate over the valid runs with no impassable obstacle,
  each with its 95 % Clopper-Pearson interval (``<rate>_lo``, ``<rate>_hi``;
  :mod:`.stats`), and ``collision_upper``: the one-sided 95 % upper bound of the collision
  rate the group's runs support;
* ``collisions``: valid runs with a collision that are not flagged unsurvivable;
  ``unsurvivable_runs`` / ``unsurvivable_collided``: flagged runs and those of them with a
  collision (:mod:`.unsurvivable`); ``impassable_runs`` / ``stopped_impassable``: runs with
  an impassable obstacle on the path and those that stopped and held before it;
  ``impassable_by_margin_runs``: of the former, those whose blocker the bare body would pass
  (impassable only with the filter's clearance, :mod:`.impassable`);
  ``leader_runs`` / ``overtook_runs``: runs with a slower mover ahead going the robot's way
  and those that got past it (:mod:`.overtaking`);
* ``infeasible_runs``: runs with some time in the filter status RELAXED; ``relaxed_mean``:
  mean share of time in RELAXED (filter-on runs);
* min clearance (ground truth, m): min, 10th percentile, median over runs;
* time-to-goal overhead against the obstacle-free run (s and %): mean and max over runs
  that reached the goal in both;
* filter intervention share (mean) and solve times (median of the per-run medians, max of
  the per-run 99th percentiles, max).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from safe_legged_c3bf.evaluation import stats
from safe_legged_c3bf.evaluation.runner import RUN_FAILURES

#: The rates of a group; each has a 95 % interval in ``<rate>_lo`` and ``<rate>_hi``.
RATES = ("collision_rate", "fall_rate", "goal_rate", "reachable_goal_rate", "success_rate")
#: Columns of the aggregate tables (after the group keys); results.md shows the interval of
#: a rate in the rate's cell, summary.csv has the ``_lo`` / ``_hi`` columns too.
SUMMARY_COLUMNS = (
    "runs", "run_failures", "valid", "collision_rate", "collisions", "unsurvivable_runs",
    "unsurvivable_collided", "fall_rate", "goal_rate", "reachable_goal_rate", "impassable_runs",
    "impassable_by_margin_runs", "stopped_impassable", "leader_runs", "overtook_runs",
    "success_rate", "infeasible_runs", "relaxed_mean",
    "clearance_min", "clearance_p10", "clearance_median", "overhead_mean_s", "overhead_max_s",
    "overhead_mean_pct",
    "intervention_mean", "solve_median_ms", "solve_p99_max_ms", "solve_max_ms",
)
#: SUMMARY_COLUMNS with every rate followed by its interval, and the collision-rate bound.
SUMMARY_CSV_COLUMNS = tuple(
    c for key in SUMMARY_COLUMNS
    for c in ((key, f"{key}_lo", f"{key}_hi") if key in RATES else (key,))
) + ("collision_upper",)
#: Columns of the side-by-side table of the filter's body models (same seeds).
BODY_MODEL_COLUMNS = (
    "runs", "valid", "collisions", "unsurvivable_runs", "unsurvivable_collided", "goal_rate",
    "reachable_goal_rate", "impassable_runs", "impassable_by_margin_runs", "stopped_impassable",
    "leader_runs", "overtook_runs", "success_rate",
    "intervention_mean", "relaxed_mean", "clearance_min", "clearance_median",
)


def finite_values(rows: Iterable[dict[str, Any]], key: str) -> np.ndarray:
    """The finite numbers under ``key`` in ``rows`` (booleans as 0/1; others skipped)."""
    out = []
    for r in rows:
        v = r.get(key)
        if isinstance(v, bool):
            v = float(v)
        if isinstance(v, int | float) and math.isfinite(v):
            out.append(float(v))
    return np.array(out, dtype=float)


def _stat(values: np.ndarray, fn: str) -> float | None:
    if values.size == 0:
        return None
    if fn == "mean":
        return float(values.mean())
    if fn == "median":
        return float(np.median(values))
    if fn == "min":
        return float(values.min())
    if fn == "max":
        return float(values.max())
    if fn == "p10":
        return float(np.percentile(values, 10))
    raise ValueError(fn)


def _rates(valid: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The :data:`RATES` of the valid runs with their 95 % intervals and the collision bound."""
    def goal(r: dict[str, Any]) -> bool:
        return bool(r.get("goal_reached"))

    reachable = [r for r in valid if not r.get("impassable")]  # no blocker on the path
    tests = {  # rate -> (runs it is over, what counts)
        "collision_rate": (valid, lambda r: bool(r.get("collision"))),
        "fall_rate": (valid, lambda r: bool(r.get("fallen"))),
        "goal_rate": (valid, goal),
        "reachable_goal_rate": (reachable, goal),
        "success_rate": (valid, is_success),
    }
    out: dict[str, Any] = {}
    for key, (runs, test) in tests.items():
        n = len(runs)
        k = sum(1 for r in runs if test(r))
        ci = stats.interval(k, n)
        out[key] = k / n if n else None
        out[f"{key}_lo"], out[f"{key}_hi"] = (round(ci[0], 6), round(ci[1], 6)) if ci else (
            None, None)
        if key == "collision_rate":
            upper = stats.upper_bound(k, n)
            out["collision_upper"] = None if upper is None else round(upper, 6)
    return out


def collision_bound(row: dict[str, Any]) -> str:
    """The collision-rate bound an aggregate row supports, in words (:mod:`.stats`)."""
    n = int(row.get("valid") or 0)
    k = round((row.get("collision_rate") or 0.0) * n)
    return stats.bound_sentence(k, n, "collision")


def is_success(rec: dict[str, Any]) -> bool:
    """Goal reached, or stopped and held before an impassable obstacle; untouched, standing."""
    done = bool(rec.get("goal_reached")) or bool(rec.get("stopped_before_impassable"))
    return done and not rec.get("collision") and not rec.get("fallen")


def attach_overhead(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Add ``free_goal_time``, ``overhead_s`` and ``overhead_pct`` to every row (in place).

    The reference of a row is the obstacle-free run (``variant == 'free'``) of the same
    ``case``; the overhead is defined when both reached the goal.
    """
    free = {r.get("case"): r for r in records if r.get("variant") == "free"}
    for r in records:
        ref = free.get(r.get("case")) if r.get("variant") != "free" else None
        t_free = ref.get("goal_time") if ref and ref.get("goal_reached") else None
        r["free_goal_time"] = t_free
        t = r.get("goal_time") if r.get("goal_reached") else None
        if t is not None and t_free is not None:
            r["overhead_s"] = float(t) - float(t_free)
            r["overhead_pct"] = 100.0 * r["overhead_s"] / float(t_free) if t_free > 0 else None
        else:
            r["overhead_s"] = None
            r["overhead_pct"] = None
    return records


def summarize_group(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The aggregate metrics of one group of rows (see the module docstring)."""
    rows = [r for r in rows if r.get("variant", "obstacles") != "free"]
    valid = [r for r in rows if r.get("outcome") not in RUN_FAILURES]
    filtered = [r for r in valid if r.get("filter") == "on"]
    out: dict[str, Any] = {
        "runs": len(rows),
        "run_failures": len(rows) - len(valid),
        "valid": len(valid),
        **_rates(valid),
        "infeasible_runs": sum(1 for r in valid if (r.get("relaxed_share") or 0) > 0),
        "relaxed_mean": _stat(finite_values(filtered, "relaxed_share"), "mean"),
    }
    hopeless = [r for r in valid if r.get("unsurvivable")]
    out["collisions"] = sum(1 for r in valid if r.get("collision") and not r.get("unsurvivable"))
    out["unsurvivable_runs"] = len(hopeless)
    out["unsurvivable_collided"] = sum(1 for r in hopeless if r.get("collision"))
    out["impassable_runs"] = sum(1 for r in valid if r.get("impassable"))
    out["impassable_by_margin_runs"] = sum(1 for r in valid if r.get("impassable_by_margin"))
    out["stopped_impassable"] = sum(1 for r in valid if r.get("stopped_before_impassable"))
    out["leader_runs"] = sum(1 for r in valid if r.get("leaders"))
    out["overtook_runs"] = sum(1 for r in valid if r.get("overtook") is True)
    clearance = finite_values(valid, "min_clearance")
    out["clearance_min"] = _stat(clearance, "min")
    out["clearance_p10"] = _stat(clearance, "p10")
    out["clearance_median"] = _stat(clearance, "median")
    overhead = finite_values(valid, "overhead_s")
    out["overhead_mean_s"] = _stat(overhead, "mean")
    out["overhead_max_s"] = _stat(overhead, "max")
    out["overhead_mean_pct"] = _stat(finite_values(valid, "overhead_pct"), "mean")
    out["intervention_mean"] = _stat(finite_values(filtered, "intervention_share"), "mean")
    out["solve_median_ms"] = _stat(finite_values(filtered, "solve_median_ms"), "median")
    out["solve_p99_max_ms"] = _stat(finite_values(filtered, "solve_p99_ms"), "max")
    out["solve_max_ms"] = _stat(finite_values(filtered, "solve_max_ms"), "max")
    return out


def aggregate(
    records: Sequence[dict[str, Any]], by: Sequence[str] = ("robot", "filter")
) -> list[dict[str, Any]]:
    """One aggregate row per distinct value of the ``by`` keys (obstacle runs only), sorted."""
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for r in records:
        if r.get("variant", "obstacles") == "free":
            continue
        groups.setdefault(tuple(str(r.get(k, "")) for k in by), []).append(r)
    rows = []
    for key in sorted(groups, key=lambda k: tuple((x == "off", x) for x in k)):
        rows.append(dict(zip(by, key, strict=True)) | summarize_group(groups[key]))
    return rows
