"""Expected outcomes of a run: held stop before an impassable obstacle, unsurvivable movers,
and their columns in the tables."""

from __future__ import annotations

import numpy as np

from safe_legged_c3bf.evaluation.expectations import annotate, judge, read_odom
from safe_legged_c3bf.evaluation.metrics import aggregate, is_success, summarize_group
from safe_legged_c3bf.evaluation.results import read_csv, results_markdown, write_results
from safe_legged_c3bf.evaluation.runner import RunSpec, classify, record_from_report
from safe_legged_c3bf.sim.scenario import load_scenario


def trajectory(xs, dt=0.05):
    t = np.arange(len(xs)) * dt
    zeros = np.zeros(len(xs))
    return np.column_stack([t, xs, zeros, zeros + 0.25, zeros, zeros, zeros, zeros, zeros])


def stop_before_bar(x_end=2.1, creep=0.0, seconds=25.0):
    walk = np.linspace(0.0, x_end, 120)
    hold = x_end + np.linspace(0.0, creep, int(seconds / 0.05) - 120)
    return trajectory(np.concatenate([walk, hold]))


def report(reached=False, collision=False, sim_time=25.0):
    return {"summary": {
        "scenario": "quadruped_low_bar", "robot": "quadruped", "outcome": "completed",
        "sim_time": sim_time, "duration": 25.0,
        "goal": {"reached": reached, "time_reached": 12.0 if reached else None},
        "collision": collision, "fallen": False, "min_clearance": 0.0 if collision else 0.2,
        "filter": {"intervention_share": 0.5, "status_share": {"ACTIVE": 0.4, "RELAXED": 0.1},
                   "solve_time_ms": {"median": 0.1, "p99": 1.0, "max": 2.0}}}}


def low_bar_row(tmp_path, odom, **kw):
    spec = RunSpec("low__filter", "low", "quadruped_low_bar", "quadruped", "impassable")
    run_dir = tmp_path / "run"
    run_dir.mkdir(exist_ok=True)
    np.savez_compressed(run_dir / "timeseries.npz", odom=odom)
    rec = record_from_report(spec, report(**kw), 0, 30.0, False, run_dir)
    return annotate(rec, "quadruped_low_bar", run_dir)


def test_held_stop_before_the_low_bar_is_a_success(tmp_path):
    rec = low_bar_row(tmp_path, stop_before_bar())
    assert rec["impassable"] == "bar"
    assert rec["stopped_before_impassable"] is True and rec["creep"] < 0.01
    assert rec["outcome"] == "stopped_impassable" and "goal_not_reached" not in rec["failures"]
    assert is_success(rec) and rec["unsurvivable"] is False
    assert read_odom(tmp_path / "run").shape[1] == 9


def test_creeping_touching_or_ending_early_is_not(tmp_path):
    creeping = low_bar_row(tmp_path, stop_before_bar(creep=0.2))
    assert creeping["stopped_before_impassable"] is False
    assert creeping["outcome"] == "goal_not_reached" and not is_success(creeping)
    touched = low_bar_row(tmp_path, stop_before_bar(), collision=True)
    assert touched["outcome"] == "collided" and not touched["stopped_before_impassable"]
    short = low_bar_row(tmp_path, stop_before_bar(seconds=12.0), sim_time=12.0)
    assert short["stopped_before_impassable"] is False  # did not hold to the end
    assert low_bar_row(tmp_path, stop_before_bar(x_end=2.6))["stopped_before_impassable"] is False


def test_without_blockers_or_scenario(tmp_path):
    sc = load_scenario("quadruped_static")
    out = judge({"sim_time": 25.0, "collision": False, "fallen": False}, sc,
                trajectory(np.linspace(0, 6, 200)))
    assert out["impassable"] == "" and out["stopped_before_impassable"] is False
    assert judge({}, None, None)["impassable"] is None
    spec = RunSpec("x", "x", "no_such_scenario", "quadruped", "static")
    rec = annotate(record_from_report(spec, report(), 0), "no_such_scenario", tmp_path)
    assert rec["impassable"] is None and rec["outcome"] == "goal_not_reached"


def test_classify_stopped_impassable():
    row = {"has_report": True, "exit_code": 0, "collision": False, "fallen": False,
           "goal_reached": False, "stopped_before_impassable": True}
    assert classify(row) == ("stopped_impassable", ["stopped_impassable"])


def rows():
    base = {"variant": "obstacles", "outcome": "ok", "robot": "quadruped", "filter": "on",
            "collision": False, "fallen": False, "goal_reached": True, "min_clearance": 0.2,
            "relaxed_share": 0.0, "intervention_share": 0.5}
    return [
        base | {"run_id": "a", "body_model": "point", "collision": True, "outcome": "collided",
                "goal_reached": False, "min_clearance": 0.0},
        base | {"run_id": "b", "body_model": "point", "collision": True, "outcome": "collided",
                "unsurvivable": True, "min_clearance": 0.0},
        base | {"run_id": "c", "body_model": "body", "goal_reached": False,
                "outcome": "stopped_impassable", "impassable": "bar",
                "stopped_before_impassable": True, "relaxed_share": 0.2},
        base | {"run_id": "d", "body_model": "body", "min_clearance": 0.05},
    ]


def test_summary_counts_unsurvivable_and_impassable_apart():
    group = summarize_group(rows())
    assert group["collision_rate"] == 0.5  # nothing hidden
    assert group["collisions"] == 1 and group["unsurvivable_runs"] == 1
    assert group["unsurvivable_collided"] == 1
    assert group["impassable_runs"] == 1 and group["stopped_impassable"] == 1
    assert group["relaxed_mean"] == 0.05
    by_model = {r["body_model"]: r for r in aggregate(rows(), ("robot", "body_model"))}
    assert by_model["body"]["success_rate"] == 1.0 and by_model["point"]["success_rate"] == 0.0


def test_body_model_table_and_csv(tmp_path):
    text = results_markdown(rows())
    assert "## Filter body models side by side" in text
    assert "| quadruped | body |" in text and "| quadruped | point |" in text
    assert "stopped before impassable" in text and "RELAXED share" in text
    assert "side by side" not in results_markdown([r | {"body_model": ""} for r in rows()])
    paths = write_results(rows(), tmp_path, figures=False)
    back = {r["run_id"]: r for r in read_csv(paths["csv"])}
    assert back["b"]["unsurvivable"] is True and back["c"]["body_model"] == "body"
