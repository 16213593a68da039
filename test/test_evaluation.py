"""Evaluation: random scenarios, result classification and aggregation, runner, CLI."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from safe_legged_c3bf import evaluate
from safe_legged_c3bf.evaluation import random_scenario as rs
from safe_legged_c3bf.evaluation.random_obstacles import leaves_passage
from safe_legged_c3bf.evaluation.results import (
    aggregate,
    attach_overhead,
    read_csv,
    summarize_group,
    write_results,
)
from safe_legged_c3bf.evaluation.runner import (
    OUTCOMES,
    RUN_FAILURES,
    Runner,
    RunSpec,
    bringup_command,
    classify,
    record_from_report,
)
from safe_legged_c3bf.sim.scenario import load_scenario, parse_scenario

REPO = Path(__file__).resolve().parents[1]
SEEDS = range(30)


# ------------------------------------------------------------------------------ generator


@pytest.mark.parametrize("robot", rs.ROBOTS)
def test_random_scenario_is_deterministic_per_seed(robot):
    a = rs.generate_scenario(robot, 7)
    b = rs.generate_scenario(robot, 7)
    assert a == b
    assert rs.scenario_yaml(a) == rs.scenario_yaml(b)
    others = [rs.generate_scenario(robot, s) for s in (8, 9, 10)]
    assert all(o["obstacles"] != a["obstacles"] for o in others)


@pytest.mark.parametrize("robot", rs.ROBOTS)
def test_random_scenarios_are_valid(robot):
    for seed in SEEDS:
        data = rs.generate_scenario(robot, seed)
        sc = parse_scenario(data, name=data["name"], check_clearance=True)
        assert sc.robot.kind == robot
        assert sc.seed == seed
        assert sc.name == f"random_{robot}_{seed:03d}"
        profile = rs.profile_for(robot)
        lo, hi = profile.obstacle_count
        assert 1 <= len(sc.obstacles) <= hi
        dist = math.dist(sc.robot.position, sc.goal.position)
        assert profile.goal_distance[0] - 1e-3 <= dist <= profile.goal_distance[1] + 1e-3
        if robot == "biped" and all(o.plane == "vertical" for o in sc.obstacles):
            assert sc.filter_overrides["max_height"] > 0.8  # the biped's height range


@pytest.mark.parametrize("robot", rs.ROBOTS)
def test_random_obstacles_are_in_the_way(robot):
    for seed in SEEDS:
        sc = rs.random_scenario(robot, seed)
        gaps = rs.obstacle_gaps(sc)
        assert gaps and min(gaps.values()) < 0, (seed, gaps)  # side obstacles need not be


@pytest.mark.parametrize("robot", rs.ROBOTS)
def test_random_obstacles_stand_clear_of_start_and_goal_at_rest(robot):
    """Only where obstacles stand at t = 0 (start, goal) and where they stop (goal) keep
    clear: the filter refuses a robot starting inside an obstacle and a goal inside one
    cannot be reached. Their walks may cross both (test_random_widened.py)."""
    profile = rs.profile_for(robot)
    for seed in SEEDS:
        sc = rs.random_scenario(robot, seed)
        for obs in sc.obstacles:
            if obs.plane != "vertical":
                continue
            a = max(obs.semi_axes)
            assert math.dist(obs.position[:2], sc.robot.position) >= a + min(
                profile.start_clearance, 0.6) - 0.01, (seed, obs.id)
            rest = obs.motion.waypoints[-1][:2] if rs.moving(obs) else obs.position[:2]
            assert math.dist(rest, sc.goal.position) >= a + 0.5, (seed, obs.id)


def test_meeting_walks_see_a_mover_stopping_at_the_robot():
    data = {
        "name": "stops_at_robot", "robot": {"kind": "biped", "position": [0.0, 0.0]},
        "goal": {"position": [3.0, 0.0]}, "duration": 30.0,
        "obstacles": [{"id": "walker", "position": [2.0, 1.0], "semi_axes": [0.2, 0.2],
                       "motion": {"type": "waypoints", "waypoints": [[1.2, 0.3]],
                                  "speed": 0.15, "mode": "stop"}}],
    }
    before, after = rs.meeting_walks(parse_scenario(data, name="stops_at_robot"))["walker"]
    assert after < 0.3 and before > 0.7


def test_passage_check_sees_a_mover_stopping_beside_a_pillar():
    pillar = {"plane": "vertical", "position": [0.0, 0.0], "semi_axes": [0.25, 0.2],
              "motion": {"type": "static"}}
    mover = {"plane": "vertical", "position": [3.0, 3.0], "semi_axes": [0.2, 0.2],
             "motion": {"type": "waypoints", "waypoints": [[0.9, 0.3]], "speed": 0.2}}
    assert not leaves_passage(mover, [pillar], 1.0)
    assert leaves_passage(mover, [pillar], 0.3)
    far = {**mover, "motion": {**mover["motion"], "waypoints": [[2.0, 1.0]]}}
    assert leaves_passage(far, [pillar], 1.0)


@pytest.mark.parametrize("robot", rs.ROBOTS)
def test_random_mix_has_every_obstacle_type(robot):
    kinds = set()
    for seed in range(60):
        sc = rs.random_scenario(robot, seed)
        for obs in sc.obstacles:
            kinds.add(obs.id.rsplit("_", 1)[0])
            if obs.plane == "horizontal":
                assert sc.robot.yaw == 0.0  # bars are extruded along odom y
                # No slowed height recovery: the filter must keep the trunk's rear clear.
                assert "k_z" not in sc.planner.params
                if robot == "quadruped":
                    assert sc.filter_overrides == rs.BAR_FILTER_OVERRIDES
                else:  # the biped cannot duck: its profile's height window applies
                    assert "min_height" not in sc.filter_overrides
    assert {"pillar", "bench", "wall", "crossing", "head_on", "oblique", "bar",
            "side_pillar", "side_bench"} <= kinds


def test_random_movers_meet_the_nominal_robot():
    """A mover is at its conflict point when the nominal robot gets there."""
    profile = rs.profile_for("quadruped")
    for seed in SEEDS:
        sc = rs.random_scenario("quadruped", seed)
        for obs in sc.obstacles:
            if not rs.moving(obs):
                continue
            assert obs.motion.type == "waypoints" and obs.motion.mode == "stop"
            assert profile.mover_speed[0] - 1e-3 <= obs.motion.speed <= profile.mover_speed[1]


def test_random_scenario_file_round_trip(tmp_path):
    data = rs.generate_scenario("quadruped", 3)
    path = rs.write_scenario(tmp_path / "r.yaml", data)
    sc = load_scenario(path)
    same = rs.random_scenario("quadruped", 3)
    assert (sc.obstacles, sc.robot, sc.goal) == (same.obstacles, same.robot, same.goal)
    assert len(sc.obstacles) == len(data["obstacles"])
    free = rs.without_obstacles(data)
    assert free["obstacles"] == [] and free["name"] == data["name"] + "_free"
    assert load_scenario(rs.write_scenario(tmp_path / "f.yaml", free)).obstacles == ()


def test_random_scenario_cli_prints_yaml(capsys):
    assert rs.main(["--robot", "biped", "--seed", "4"]) == 0
    out = capsys.readouterr().out
    assert "random_biped_004" in out and "obstacles:" in out


def test_generator_rejects_bad_arguments():
    with pytest.raises(ValueError):
        rs.generate_scenario("hexapod", 0)
    with pytest.raises(ValueError):
        rs.generate_scenario("quadruped", -1)


# ------------------------------------------------------------------------------ records


def make_report(*, collision=False, fallen=False, reached=True, goal_time=12.0,
                clearance=0.3, share=0.4, relaxed=0.0, median=0.2, p99=5.0, maximum=20.0,
                outcome="completed"):
    """A synthetic report.json as the bringup writes it (only the fields used)."""
    shares = {"INACTIVE": 1.0 - share, "ACTIVE": share - relaxed}
    if relaxed:
        shares["RELAXED"] = relaxed
    return {
        "summary": {
            "scenario": "s", "robot": "quadruped", "outcome": outcome,
            "reason": "the simulator finished the scenario", "sim_time": 20.0, "duration": 20.0,
            "real_time_factor": 0.4, "wall_time": 50.0,
            "goal": {"reached": reached, "time_reached": goal_time if reached else None,
                     "final_distance": 0.1 if reached else 2.0},
            "collision": collision, "collision_count": int(collision),
            "obstacles_touched": ["pillar"] if collision else [], "fallen": fallen,
            "min_clearance": 0.0 if collision else clearance, "min_clearance_obstacle": "pillar",
            "path_length": 6.0,
            "filter": {"cycles": 1000, "intervention_share": share, "status_share": shares,
                       "solve_time_ms": {"median": median, "p99": p99, "max": maximum}},
        }
    }


def spec(case="a", filt=True, variant="obstacles", robot="quadruped", kind="static"):
    return RunSpec(run_id=f"{case}_{filt}_{variant}", case=case, scenario=case, robot=robot,
                   kind=kind, filter_enabled=filt, variant=variant, suite="t")


def test_classification():
    assert record_from_report(spec(), make_report())["outcome"] == "ok"
    rec = record_from_report(spec(filt=False), make_report(collision=True, reached=False))
    assert rec["outcome"] == "collided"
    assert rec["failures"] == "collided+goal_not_reached"
    assert rec["solve_median_ms"] is None  # pass-through: no solves
    assert record_from_report(spec(), make_report(fallen=True))["outcome"] == "fell"
    assert record_from_report(spec(), make_report(reached=False))["outcome"] == "goal_not_reached"
    rec = record_from_report(spec(), make_report(relaxed=0.02))
    assert rec["outcome"] == "ok" and "infeasible" in rec["failures"]
    assert rec["relaxed_share"] == pytest.approx(0.02)
    died = record_from_report(spec(), make_report(outcome="node_died", reached=False), 1)
    assert died["outcome"] == "node_died"
    missing = record_from_report(spec(), None, 2)
    assert missing["outcome"] == "startup_failed"
    assert missing["reason"] == "no report.json was written"
    assert record_from_report(spec(), make_report(), 0, timed_out=True)["outcome"] == (
        "wall_timeout")
    assert classify({"has_report": True, "exit_code": 130, "goal_reached": True})[0] == (
        "interrupted")


def row(**changes):
    """A result row of a completed run that reached its goal; ``changes`` applied, and a
    value of ``MISSING`` removes the field."""
    rec = {"has_report": True, "exit_code": 0, "timed_out": False, "run_outcome": "completed",
           "collision": False, "fallen": False, "goal_reached": True, "relaxed_share": 0.0}
    rec.update(changes)
    return {k: v for k, v in rec.items() if v is not MISSING}


MISSING = object()


@pytest.mark.parametrize(
    ("changes", "outcome", "flags"),
    [
        ({}, "ok", []),
        ({"has_report": MISSING}, "ok", []),  # a complete row speaks for itself
        # Run failures, whatever the report says.
        ({"exit_code": 1, "run_outcome": "stalled", "goal_reached": False},
         "node_died", ["node_died", "goal_not_reached"]),
        ({"run_outcome": "stalled", "goal_reached": False},
         "node_died", ["node_died", "goal_not_reached"]),
        ({"exit_code": 1}, "node_died", ["node_died"]),
        ({"run_outcome": "node_died"}, "node_died", ["node_died"]),
        ({"exit_code": 3}, "node_died", ["node_died"]),  # any other failing exit
        ({"exit_code": 2}, "startup_failed", ["startup_failed"]),
        ({"run_outcome": "startup_failed"}, "startup_failed", ["startup_failed"]),
        ({"has_report": False, "exit_code": 1, "run_outcome": None, "collision": None,
          "fallen": None, "goal_reached": None}, "startup_failed", ["startup_failed"]),
        ({"timed_out": True, "exit_code": 130}, "wall_timeout", ["wall_timeout"]),
        ({"timed_out": True, "exit_code": -9, "has_report": False, "collision": None,
          "fallen": None, "goal_reached": None}, "wall_timeout", ["wall_timeout"]),
        ({"exit_code": 130}, "interrupted", ["interrupted"]),
        ({"exit_code": 143}, "interrupted", ["interrupted"]),
        ({"exit_code": 129}, "interrupted", ["interrupted"]),
        ({"exit_code": -15}, "interrupted", ["interrupted"]),  # killed by a signal
        ({"run_outcome": "interrupted"}, "interrupted", ["interrupted"]),
        # Ground truth.
        ({"collision": True, "fallen": True, "goal_reached": False},
         "collided", ["collided", "fell", "goal_not_reached"]),
        ({"fallen": True}, "fell", ["fell"]),
        ({"goal_reached": False}, "goal_not_reached", ["goal_not_reached"]),
        ({"relaxed_share": 0.02}, "ok", ["infeasible"]),
        ({"relaxed_share": 0.02, "goal_reached": False},
         "goal_not_reached", ["goal_not_reached", "infeasible"]),
        ({"relaxed_share": None}, "ok", []),  # filter off: no statuses
        # Missing fields fail closed: never ok.
        ({"collision": MISSING}, "incomplete_report", ["incomplete_report"]),
        ({"collision": None}, "incomplete_report", ["incomplete_report"]),
        ({"fallen": MISSING}, "incomplete_report", ["incomplete_report"]),
        ({"goal_reached": MISSING}, "incomplete_report", ["incomplete_report"]),
        ({"goal_reached": "yes"}, "incomplete_report", ["incomplete_report"]),
        ({"collision": MISSING, "fallen": MISSING, "goal_reached": MISSING},
         "incomplete_report", ["incomplete_report"]),
        # Precedence.
        ({"exit_code": 2, "run_outcome": "node_died"}, "startup_failed", ["startup_failed"]),
        ({"timed_out": True, "exit_code": 1}, "wall_timeout", ["wall_timeout"]),
        ({"exit_code": 1, "run_outcome": "interrupted"}, "node_died", ["node_died"]),
        ({"exit_code": 2, "run_outcome": "interrupted"}, "startup_failed", ["startup_failed"]),
        ({"exit_code": 1, "collision": True}, "node_died", ["node_died", "collided"]),
        ({"exit_code": 130, "fallen": True}, "interrupted", ["interrupted", "fell"]),
        ({"timed_out": True, "collision": True}, "wall_timeout", ["wall_timeout", "collided"]),
        ({"collision": True, "fallen": MISSING}, "collided", ["collided", "incomplete_report"]),
        ({"fallen": True, "goal_reached": MISSING}, "fell", ["fell", "incomplete_report"]),
        ({"collision": MISSING, "goal_reached": False},
         "incomplete_report", ["incomplete_report", "goal_not_reached"]),
        ({"exit_code": 1, "collision": MISSING}, "node_died", ["node_died", "incomplete_report"]),
    ],
)
def test_classify_outcomes_and_precedence(changes, outcome, flags):
    assert classify(row(**changes)) == (outcome, flags)
    assert outcome in OUTCOMES


def test_outcomes_are_documented_and_incomplete_reports_are_run_failures():
    from safe_legged_c3bf.evaluation import runner

    for outcome in OUTCOMES:
        assert f"``{outcome}``" in runner.__doc__
    assert "incomplete_report" in RUN_FAILURES and "ok" not in RUN_FAILURES
    # Without collision and fall fields a row says nothing about safety: no rates from it.
    report = make_report()
    del report["summary"]["collision"]
    rec = record_from_report(spec(), report)
    assert rec["outcome"] == "incomplete_report"
    group = summarize_group([rec, record_from_report(spec("b"), make_report())])
    assert group["runs"] == 2 and group["run_failures"] == 1 and group["success_rate"] == 1.0


def synthetic_records():
    recs = [
        # case a: filter on succeeds with a 3 s detour, off collides, free reference 10 s
        record_from_report(spec("a"), make_report(goal_time=13.0, clearance=0.25)),
        record_from_report(spec("a", False), make_report(collision=True, reached=False)),
        record_from_report(spec("a", variant="free"), make_report(goal_time=10.0, share=0.0)),
        # case b: filter on succeeds (5 s detour), with RELAXED; off collides
        record_from_report(spec("b"), make_report(goal_time=17.0, clearance=0.1, relaxed=0.05,
                                                  p99=9.0, maximum=40.0, share=0.6)),
        record_from_report(spec("b", False), make_report(collision=True, reached=True,
                                                         goal_time=12.0)),
        record_from_report(spec("b", variant="free"), make_report(goal_time=12.0, share=0.0)),
        # case c: filter on, a node died: excluded from the rates
        record_from_report(spec("c", kind="moving"),
                           make_report(outcome="node_died", reached=False), 1),
        # biped d: filter on, goal not reached, off: no collision (obstacle missed)
        record_from_report(spec("d", robot="biped"), make_report(reached=False, clearance=0.4)),
        record_from_report(spec("d", False, robot="biped"), make_report(reached=True,
                                                                        clearance=0.05)),
    ]
    return attach_overhead(recs)


def test_overhead_against_the_obstacle_free_run():
    recs = {r["run_id"]: r for r in synthetic_records()}
    assert recs["a_True_obstacles"]["overhead_s"] == pytest.approx(3.0)
    assert recs["a_True_obstacles"]["overhead_pct"] == pytest.approx(30.0)
    assert recs["b_True_obstacles"]["overhead_s"] == pytest.approx(5.0)
    assert recs["b_False_obstacles"]["overhead_s"] == pytest.approx(0.0)
    assert recs["a_False_obstacles"]["overhead_s"] is None  # goal not reached
    assert recs["d_True_obstacles"]["free_goal_time"] is None  # no free run


def test_aggregate_by_robot_and_filter():
    rows = {(r["robot"], r["filter"]): r for r in aggregate(synthetic_records())}
    on = rows[("quadruped", "on")]
    assert on["runs"] == 3 and on["run_failures"] == 1 and on["valid"] == 2
    assert on["collision_rate"] == 0.0
    assert on["goal_rate"] == 1.0 and on["success_rate"] == 1.0
    assert on["infeasible_runs"] == 1
    assert on["clearance_min"] == pytest.approx(0.1)
    assert on["clearance_median"] == pytest.approx(0.175)
    assert on["overhead_mean_s"] == pytest.approx(4.0)
    assert on["overhead_max_s"] == pytest.approx(5.0)
    assert on["intervention_mean"] == pytest.approx(0.5)
    assert on["solve_median_ms"] == pytest.approx(0.2)
    assert on["solve_p99_max_ms"] == pytest.approx(9.0)
    assert on["solve_max_ms"] == pytest.approx(40.0)
    off = rows[("quadruped", "off")]
    assert off["collision_rate"] == 1.0 and off["success_rate"] == 0.0
    assert off["clearance_min"] == 0.0
    assert off["solve_median_ms"] is None
    biped_on, biped_off = rows[("biped", "on")], rows[("biped", "off")]
    assert biped_on["goal_rate"] == 0.0 and biped_on["success_rate"] == 0.0
    assert biped_off["collision_rate"] == 0.0
    # ordering: filter on before off
    keys = [(r["robot"], r["filter"]) for r in aggregate(synthetic_records())]
    assert keys.index(("quadruped", "on")) < keys.index(("quadruped", "off"))


def test_reachable_goal_rate_leaves_out_the_runs_with_a_blocker():
    recs = synthetic_records()
    a, b = (r for r in recs if r["run_id"] in ("a_True_obstacles", "b_True_obstacles"))
    b.update(goal_reached=False, impassable="bar", impassable_by_margin="bar",
             stopped_before_impassable=True)
    a.update(impassable="", impassable_by_margin="")
    on = {(r["robot"], r["filter"]): r for r in aggregate(recs)}[("quadruped", "on")]
    assert on["goal_rate"] == 0.5 and on["reachable_goal_rate"] == 1.0
    assert on["impassable_runs"] == 1 and on["impassable_by_margin_runs"] == 1
    assert on["success_rate"] == 1.0
    a.update(goal_reached=False)
    on = {(r["robot"], r["filter"]): r for r in aggregate(recs)}[("quadruped", "on")]
    assert on["reachable_goal_rate"] == 0.0 and on["reachable_goal_rate_hi"] > 0.0


def test_aggregate_by_kind_and_empty_group():
    rows = aggregate(synthetic_records(), ("robot", "kind", "filter"))
    moving = [r for r in rows if r["kind"] == "moving"][0]
    assert moving["runs"] == 1 and moving["valid"] == 0
    assert moving["collision_rate"] is None and moving["clearance_min"] is None
    assert summarize_group([])["runs"] == 0


def test_write_results(tmp_path):
    recs = synthetic_records()
    paths = write_results(recs, tmp_path, title="T", notes=["note line"])
    text = paths["markdown"].read_text()
    assert text.startswith("# T") and "note line" in text
    assert "| quadruped | on |" in text and "node_died" in text
    back = read_csv(paths["csv"])
    assert len(back) == len(recs)
    row = [r for r in back if r["run_id"] == "a_True_obstacles"][0]
    assert row["goal_reached"] is True and row["overhead_s"] == pytest.approx(3.0)
    assert paths["summary"].read_text().startswith("robot,kind,filter,runs")
    for name in ("outcomes", "clearance", "overhead", "solve_time", "intervention"):
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 1000


# ------------------------------------------------------------------------------ runner


FAKE_BRINGUP = textwrap.dedent("""\
    import json, sys, time
    args = sys.argv[1:]
    out = args[args.index("--out") + 1]
    scenario = args[args.index("--scenario") + 1]
    if scenario == "sleepy":
        time.sleep(30)
    if scenario == "broken":
        print("bringup: scenario broken: no such file", file=sys.stderr)
        sys.exit(2)
    collision = "--no-filter" in args
    report = {"summary": {
        "scenario": scenario, "robot": "quadruped", "outcome": "completed", "reason": "done",
        "goal": {"reached": not collision, "time_reached": None if collision else 9.0},
        "collision": collision, "fallen": False, "min_clearance": 0.0 if collision else 0.2,
        "filter": {"intervention_share": 0.3, "status_share": {"ACTIVE": 0.3},
                   "solve_time_ms": {"median": 0.1, "p99": 1.0, "max": 2.0}}}}
    with open(out + "/report.json", "w") as f:
        json.dump(report, f)
""")


@pytest.fixture
def fake_python(tmp_path):
    """An 'interpreter' that ignores '-m module' and behaves like a tiny bringup."""
    script = tmp_path / "fake_bringup.py"
    script.write_text(FAKE_BRINGUP)
    launcher = tmp_path / "fake_python"
    launcher.write_text(f"#!/bin/sh\nshift 2\nexec {sys.executable} {script} \"$@\"\n")
    launcher.chmod(0o755)
    return str(launcher)


def test_bringup_command():
    s = RunSpec("r", "c", "quadruped_static", "quadruped", "static", filter_enabled=False,
                seed=3, duration=12.0)
    cmd = bringup_command(s, Path("/tmp/x"), in_process=True, python="py")
    assert cmd[:3] == ["py", "-m", "safe_legged_c3bf.bringup"]
    for item in ("--no-filter", "--in-process", "--seed", "3", "--duration", "12",
                 "--out", "/tmp/x", "--scenario", "quadruped_static", "--stop-on-outcome"):
        assert item in cmd
    assert "--stop-on-outcome" not in bringup_command(s, Path("/tmp/x"), full_duration=True)


def test_runner_runs_in_parallel_and_classifies(tmp_path, fake_python):
    lines = []
    runner = Runner(tmp_path / "ev", jobs=2, python=fake_python, progress=lines.append,
                    wall_limit=lambda duration: 5.0)
    specs = [
        RunSpec("ok", "a", "a", "quadruped", "static"),
        RunSpec("off", "a", "a", "quadruped", "static", filter_enabled=False),
        RunSpec("broken", "b", "broken", "quadruped", "static"),
        RunSpec("sleepy", "c", "sleepy", "quadruped", "static"),
    ]
    seen = []
    recs = runner.run(specs, on_result=seen.append)
    assert [r["run_id"] for r in recs] == ["ok", "off", "broken", "sleepy"]
    assert len(seen) == 4
    outcome = {r["run_id"]: r["outcome"] for r in recs}
    assert outcome == {"ok": "ok", "off": "collided", "broken": "startup_failed",
                       "sleepy": "wall_timeout"}
    assert "no such file" in recs[2]["reason"]
    assert (tmp_path / "ev" / "runs" / "ok" / "bringup.log").read_text().startswith("$ ")
    assert sum(1 for line in lines if "s  start " in line) == 4
    assert any("done  a (filter OFF)" in line and "collided" in line for line in lines)


def test_runner_rejects_duplicate_ids(tmp_path):
    s = RunSpec("x", "a", "a", "quadruped", "static")
    with pytest.raises(ValueError):
        Runner(tmp_path).run([s, s])


# ------------------------------------------------------------------------------ CLI


def test_named_scenarios_exist_and_load():
    for name in (*evaluate.NAMED_SCENARIOS, evaluate.CI_SCENARIO):
        sc = load_scenario(name)
        assert sc.obstacles
        assert sc.duration <= 45.0  # the biped's random budget
        expected = "biped" if name.startswith("biped") else "quadruped"
        assert sc.robot.kind == expected
        for obs in sc.obstacles:  # never on the start or the goal
            for point in (sc.robot.position, sc.goal.position):
                assert math.dist(obs.position[:2], point) > max(obs.semi_axes) + 0.5


def test_named_scenarios_put_obstacles_in_the_way():
    """The straight-line robot (as in the unfiltered runs) meets an obstacle in each."""
    from safe_legged_c3bf.evaluation.suites import CLEAR_PATH_SCENARIOS

    for name in evaluate.NAMED_SCENARIOS:
        sc = load_scenario(name)
        gaps = rs.obstacle_gaps(sc)
        if name in CLEAR_PATH_SCENARIOS:  # the body fits past: the filter must not block it
            assert min(gaps.values()) > 0.1, (name, gaps)
        else:
            assert min(gaps.values()) < 0, (name, gaps)


def test_evaluate_dry_run_plans(tmp_path, capsys):
    assert evaluate.main(["--suite", "named", "--dry-run", "--out", str(tmp_path / "n")]) == 0
    out = capsys.readouterr().out
    assert f"{3 * len(evaluate.NAMED_SCENARIOS)} run(s)" in out
    assert (tmp_path / "n" / "scenarios" / "quadruped_static_free.yaml").is_file()
    assert evaluate.main(["--suite", "ci", "--dry-run", "--out", str(tmp_path / "c")]) == 0
    assert "1 run(s)" in capsys.readouterr().out
    assert evaluate.main(["--suite", "random-biped", "--seeds", "2", "--no-free",
                          "--dry-run", "--out", str(tmp_path / "r")]) == 0
    assert "4 run(s)" in capsys.readouterr().out
    assert load_scenario(tmp_path / "r" / "scenarios" / "random_biped_001.yaml")
    assert evaluate.main(["--suite", "paper", "--seeds", "2", "--no-baseline", "--dry-run",
                          "--out", str(tmp_path / "p")]) == 0
    assert "20 run(s)" in capsys.readouterr().out
    assert evaluate.main(["--scenario", "nope", "--dry-run", "--out", str(tmp_path / "x")]) == 2


@pytest.mark.slow
def test_ci_suite_end_to_end(tmp_path):
    """The ci suite: one short quadruped run with the filter: no collision, goal reached."""
    out = tmp_path / "ci"
    proc = subprocess.run(
        [sys.executable, "-m", "safe_legged_c3bf.evaluate", "--suite", "ci", "--out", str(out),
         "--no-figures"],
        cwd=REPO, capture_output=True, text=True, timeout=240,
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    rows = read_csv(out / "results.csv")
    assert len(rows) == 1, rows
    row = rows[0]
    detail = json.dumps(row, default=str)
    assert row["filter"] == "on" and row["outcome"] == "ok", detail
    assert row["collision"] is False, detail
    assert row["goal_reached"] is True, detail
    assert row["min_clearance"] > 0.0, detail
    assert (out / "results.md").is_file()


def test_combine_merges_evaluation_folders(tmp_path):
    from safe_legged_c3bf.evaluate import main

    recs = synthetic_records()
    quad = [r for r in recs if r["robot"] == "quadruped"]
    rest = [r for r in recs if r["robot"] != "quadruped"]
    assert quad and rest
    write_results(quad, tmp_path / "q", figures=False)
    write_results(rest, tmp_path / "b", figures=False)
    out = tmp_path / "all"
    code = main(["--combine", str(tmp_path / "q"), str(tmp_path / "b"), "--out", str(out),
                 "--no-figures"])
    assert code == 0
    back = read_csv(out / "results.csv")
    assert sorted(r["run_id"] for r in back) == sorted(r["run_id"] for r in recs)
    row = [r for r in back if r["run_id"] == "a_True_obstacles"][0]
    assert row["overhead_s"] == pytest.approx(3.0)  # recomputed across the merged rows
    # The same folder twice is refused (duplicate run ids), as is a folder without results.
    assert main(["--combine", str(tmp_path / "q"), str(tmp_path / "q"), "--out",
                 str(tmp_path / "x"), "--no-figures"]) == 2
    assert main(["--combine", str(tmp_path), "--out", str(tmp_path / "y")]) == 2
