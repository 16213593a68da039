"""benchmarks/overhead_breakdown.py: the split of a run's overhead, on hand-made folders."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import numpy as np
import pytest
import yaml

from safe_legged_c3bf.evaluation.detour_bound import detour_bound
from safe_legged_c3bf.sim.scenario import load_scenario

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "overhead_breakdown.py"
_spec = importlib.util.spec_from_file_location("overhead_breakdown", _PATH)
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

FIELDS = ["run_id", "suite", "case", "scenario", "robot", "variant", "filter", "goal_reached",
          "goal_time", "free_goal_time", "overhead_s", "run_dir"]
SCENARIO = {
    "name": "split", "robot": {"kind": "quadruped"}, "goal": {"position": [4.0, 0.0]},
    "planner": {"mode": "goal", "speed": 0.4}, "duration": 30.0,
    "obstacles": [
        {"id": "pillar", "position": [2.0, 0.0], "semi_axes": [0.3, 0.3]},
        {"id": "walker", "position": [3.0, 2.0], "semi_axes": [0.2, 0.2],
         "motion": {"type": "waypoints", "waypoints": [[3.0, -2.0]], "speed": 0.3}},
    ],
}


def _run_dir(folder: Path, name: str, leaves_at: float, scenario: dict | None) -> Path:
    """A run folder whose robot walks +x at 0.4 m/s from ``leaves_at`` [s]."""
    run = folder / "runs" / name
    run.mkdir(parents=True)
    t = np.arange(0.0, 12.0, 0.05)
    x = 0.4 * np.clip(t - leaves_at, 0.0, None)
    odom = np.column_stack([t, x] + [np.zeros_like(t)] * 7)
    np.savez(run / "timeseries.npz", odom=odom)
    if scenario is not None:
        (run / "scenario.yaml").write_text(yaml.safe_dump(scenario), encoding="utf-8")
    return run


def _evaluation(folder: Path, rows: list[dict]) -> Path:
    with (folder / "results.csv").open("w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in FIELDS})
    return folder


def _row(case, variant, goal_time, run_dir, **extra):
    return {"run_id": f"{case}__{variant}", "suite": "named", "case": case,
            "scenario": case, "robot": "quadruped", "variant": variant, "filter": "on",
            "goal_reached": "True", "goal_time": goal_time, "run_dir": str(run_dir), **extra}


@pytest.fixture
def evaluation(tmp_path):
    """One filtered run (12 s, leaves 1.5 s late) and its free run (10 s)."""
    folder = tmp_path / "full"
    run = _run_dir(folder, "split__filter", 2.0, SCENARIO)
    free = _run_dir(folder, "split__free", 0.5, None)
    return _evaluation(folder, [
        _row("split", "obstacles", 12.0, run, free_goal_time=10.0, overhead_s=2.0),
        _row("split", "free", 10.0, free),
    ])


def test_the_overhead_is_split_into_the_least_detour_the_start_and_the_rest(evaluation):
    (r,) = bench.breakdown_rows([evaluation])
    least = detour_bound(load_scenario(evaluation / "runs" / "split__filter" / "scenario.yaml"))
    assert r["overhead"] == pytest.approx(2.0)
    assert r["detour"] == pytest.approx(least.extra_time) and 0.0 < r["detour"] < 2.0
    assert r["rest"] == pytest.approx(2.0 - least.extra_time)
    assert r["start"] == pytest.approx(1.5, abs=0.06)  # one odometry sample
    assert "static" not in r


def test_static_scenarios_lose_their_movers_and_add_a_column(evaluation, tmp_path):
    (path,) = bench.write_static([evaluation], tmp_path / "static_scenarios")
    written = load_scenario(path)
    assert written.name == "split_static"
    assert [o.id for o in written.obstacles] == ["pillar"]
    folder = tmp_path / "static"
    run = _run_dir(folder, "split_static__filter", 1.0, None)
    _evaluation(folder, [_row("split_static", "obstacles", 11.0, run)])
    (r,) = bench.breakdown_rows([evaluation], folder)
    assert r["static"] == pytest.approx(1.0)
    assert r["start"] == pytest.approx(0.5, abs=0.06)  # the static-only run's start


def test_a_run_whose_static_twin_missed_is_left_out(evaluation, tmp_path):
    folder = tmp_path / "static"
    run = _run_dir(folder, "split_static__filter", 1.0, None)
    _evaluation(folder, [_row("split_static", "obstacles", "", run, goal_reached="False")])
    assert bench.breakdown_rows([evaluation], folder) == []
