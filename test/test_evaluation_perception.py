"""Oracle vs sensor perception in the evaluation: run plan, bringup command, tables."""

from __future__ import annotations

from pathlib import Path

from safe_legged_c3bf import evaluate
from safe_legged_c3bf.evaluation.results import results_markdown
from safe_legged_c3bf.evaluation.runner import bringup_command, record_from_report
from safe_legged_c3bf.evaluation.suites import PERCEPTION_SOURCES, plan_cases, plan_runs


def plan(tmp_path, *args):
    opts = evaluate.build_parser().parse_args([*args, "--out", str(tmp_path)])
    cases = plan_cases(opts, tmp_path)
    return cases, plan_runs(cases, opts, tmp_path, "t")


def test_compare_plans_one_filter_run_per_perception_source(tmp_path):
    cases, specs = plan(tmp_path, "--suite", "random-quadruped", "--seeds", "2",
                        "--compare-perception", "--no-free")
    assert PERCEPTION_SOURCES == ("oracle", "sensors")
    for c in cases:
        mine = {s.run_id: s for s in specs if s.case == c.case}
        assert set(mine) == {f"{c.case}__oracle", f"{c.case}__sensors", f"{c.case}__nofilter"}
        assert mine[f"{c.case}__oracle"].scenario == mine[f"{c.case}__sensors"].scenario
        cmd = bringup_command(mine[f"{c.case}__sensors"], Path("/tmp/x"))
        assert cmd[cmd.index("--perception") + 1] == "sensors"


def test_perception_option_applies_to_every_run(tmp_path):
    _, specs = plan(tmp_path, "--scenario", "quadruped_static", "--perception", "sensors")
    assert [s.perception for s in specs] == ["sensors"] * 3
    _, specs = plan(tmp_path, "--scenario", "quadruped_static")
    assert all("--perception" not in bringup_command(s, Path("/tmp/x")) for s in specs)


def test_results_tabulate_the_two_sources_side_by_side(tmp_path):
    _, specs = plan(tmp_path, "--scenario", "quadruped_static", "--compare-perception",
                    "--no-baseline", "--no-free")
    rows = []
    for spec in specs:
        report = {"summary": {"perception": spec.perception, "collision": False,
                              "goal": {"reached": True, "time_reached": 12.0},
                              "outcome": "completed"}}
        rows.append(record_from_report(spec, report))
    assert [r["perception"] for r in rows] == ["oracle", "sensors"]
    text = results_markdown(rows)
    assert "Perception sources side by side" in text
    assert "| quadruped | sensors |" in text


def test_both_comparisons_at_once_are_refused(tmp_path, capsys):
    code = evaluate.main(["--scenario", "quadruped_static", "--compare-perception",
                          "--compare-body-models", "--dry-run", "--out", str(tmp_path)])
    assert code == 2
    assert "one comparison at a time" in capsys.readouterr().err
