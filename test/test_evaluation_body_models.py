"""The single-point vs whole-body comparison: its run plan (no simulation)."""

from __future__ import annotations

import yaml

from safe_legged_c3bf import evaluate
from safe_legged_c3bf.evaluation.suites import BODY_MODELS, plan_cases, plan_runs


def plan(tmp_path, *args):
    opts = evaluate.build_parser().parse_args([*args, "--out", str(tmp_path)])
    cases = plan_cases(opts, tmp_path)
    return cases, plan_runs(cases, opts, tmp_path, "t")


def test_compare_plans_one_filter_run_per_body_model_on_the_same_scenario(tmp_path):
    cases, specs = plan(tmp_path, "--suite", "random-quadruped", "--seeds", "2",
                        "--compare-body-models")
    assert BODY_MODELS == ("point", "body")
    ids = [s.run_id for s in specs]
    for c in cases:
        assert f"{c.case}__point" in ids and f"{c.case}__body" in ids
        assert f"{c.case}__filter" not in ids
        assert f"{c.case}__nofilter" in ids and f"{c.case}__free" in ids
    for s in specs:
        if s.body_model:
            data = yaml.safe_load(open(s.scenario, encoding="utf-8"))
            assert data["filter"]["body_model"] == s.body_model and s.filter_enabled
            base = next(c.raw for c in cases if c.case == s.case)
            # Same scenario otherwise: obstacles, robot, goal and the other overrides.
            assert data["obstacles"] == base["obstacles"] and data["goal"] == base["goal"]
            others = {k: v for k, v in data["filter"].items() if k != "body_model"}
            assert others == (base.get("filter") or {})
        else:
            assert s.run_id.endswith(("__nofilter", "__free"))


def test_compare_keeps_named_scenarios_and_perception_seeds(tmp_path):
    _, specs = plan(tmp_path, "--scenario", "quadruped_low_bar", "--seeds", "2",
                    "--compare-body-models", "--no-baseline", "--no-free")
    assert sorted((s.run_id, s.seed, s.body_model) for s in specs) == [
        ("quadruped_low_bar@seed31__body", 31, "body"),
        ("quadruped_low_bar@seed31__point", 31, "point"),
        ("quadruped_low_bar@seed32__body", 32, "body"),
        ("quadruped_low_bar@seed32__point", 32, "point"),
    ]
    data = yaml.safe_load(open(specs[0].scenario, encoding="utf-8"))
    assert data["filter"]["min_height"] == 0.18  # the scenario's own overrides kept


def test_without_compare_the_plan_is_unchanged(tmp_path):
    _, specs = plan(tmp_path, "--scenario", "quadruped_static")
    assert [s.run_id for s in specs] == [
        "quadruped_static__filter", "quadruped_static__nofilter", "quadruped_static__free"]
    assert all(s.body_model == "" for s in specs)


def test_dry_run_lists_the_body_models(tmp_path, capsys):
    code = evaluate.main(["--scenario", "quadruped_gap", "--compare-body-models", "--dry-run",
                          "--out", str(tmp_path)])
    assert code == 0
    out = capsys.readouterr().out
    assert "body_model point" in out and "body_model body" in out and "4 run(s)" in out
