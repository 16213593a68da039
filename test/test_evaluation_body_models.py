"""The single-point vs whole-body comparison: its run plan (no simulation)."""

from __future__ import annotations

import yaml

from safe_legged_c3bf import evaluate
from safe_legged_c3bf.evaluation.suites import (
    BODY_MODELS,
    FILTER_VARIANTS,
    plan_cases,
    plan_runs,
)


def plan(tmp_path, *args):
    opts = evaluate.build_parser().parse_args([*args, "--out", str(tmp_path)])
    cases = plan_cases(opts, tmp_path)
    return cases, plan_runs(cases, opts, tmp_path, "t")


def test_compare_plans_one_filter_run_per_body_model_on_the_same_scenario(tmp_path):
    cases, specs = plan(tmp_path, "--suite", "random-quadruped", "--seeds", "2",
                        "--compare-body-models")
    assert BODY_MODELS == ("point", "body", "body_lateral")
    ids = [s.run_id for s in specs]
    for c in cases:
        assert {f"{c.case}__{m}" for m in BODY_MODELS} <= set(ids)
        assert f"{c.case}__filter" not in ids
        assert f"{c.case}__nofilter" in ids and f"{c.case}__free" in ids
    for s in specs:
        if s.body_model:
            data = yaml.safe_load(open(s.scenario, encoding="utf-8"))
            variant = FILTER_VARIANTS[s.body_model]
            assert {k: data["filter"][k] for k in variant} == variant and s.filter_enabled
            assert data["filter"]["body_model"] == s.body_model.split("_")[0]
            assert data["filter"].get("model", "unicycle") == (
                "unicycle_lateral" if s.body_model == "body_lateral" else "unicycle")
            base = next(c.raw for c in cases if c.case == s.case)
            # Same scenario otherwise: obstacles, robot, goal and the other overrides.
            assert data["obstacles"] == base["obstacles"] and data["goal"] == base["goal"]
            others = {k: v for k, v in data["filter"].items() if k not in variant}
            assert others == (base.get("filter") or {})
        else:
            assert s.run_id.endswith(("__nofilter", "__free"))


def test_compare_keeps_named_scenarios_and_perception_seeds(tmp_path):
    _, specs = plan(tmp_path, "--scenario", "quadruped_low_bar", "--seeds", "2",
                    "--compare-body-models", "--no-baseline", "--no-free")
    assert sorted((s.run_id, s.seed, s.body_model) for s in specs) == sorted(
        (f"quadruped_low_bar@seed{seed}__{m}", seed, m) for seed in (31, 32) for m in BODY_MODELS
    )
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
    assert all(f"body_model {m}" in out for m in BODY_MODELS) and "5 run(s)" in out


def test_compare_runs_only_the_body_models_named(tmp_path):
    _, specs = plan(tmp_path, "--scenario", "quadruped_gap", "--compare-body-models", "body",
                    "--no-baseline", "--no-free")
    assert [(s.run_id, s.body_model) for s in specs] == [("quadruped_gap__body", "body")]
