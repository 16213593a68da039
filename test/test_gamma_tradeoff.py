"""benchmarks/gamma_tradeoff.py: the scenarios it writes and the figures it prints."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import pytest
import yaml

from safe_legged_c3bf.sim.scenario import load_scenario

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "gamma_tradeoff.py"
_spec = importlib.util.spec_from_file_location("gamma_tradeoff", _PATH)
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

FIELDS = ["case", "variant", "goal_reached", "goal_time", "impassable", "collision",
          "min_clearance", "intervention_share"]


def _write(folder: Path, rows: list[dict]) -> None:
    folder.mkdir(parents=True)
    with (folder / "results.csv").open("w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in FIELDS})


def _run(case, reached, time, clearance, impassable="", collision="False"):
    return {"case": case, "variant": "obstacles", "goal_reached": str(reached),
            "goal_time": time, "impassable": impassable, "collision": collision,
            "min_clearance": clearance, "intervention_share": 0.5}


def test_scenarios_carry_the_gamma_and_load(tmp_path):
    paths = bench.scenario_paths("biped", 2, 2.5, tmp_path)
    assert len(paths) == 2
    for p in paths:
        assert yaml.safe_load(p.read_text())["filter"]["gamma"] == 2.5
        assert load_scenario(p).filter_overrides["gamma"] == 2.5


def test_overheads_are_over_the_runs_every_gamma_brought_to_the_goal(tmp_path):
    free = [{"case": c, "variant": "free", "goal_reached": "True", "goal_time": 10.0}
            for c in ("a", "b", "c")]
    _write(tmp_path / "gamma_1", free + [_run("a", True, 12.0, 0.3), _run("b", True, 15.0, 0.2),
                                         _run("c", False, "", 0.1, impassable="bar_0")])
    _write(tmp_path / "gamma_2", [_run("a", True, 11.0, 0.25), _run("b", False, "", 0.05),
                                  _run("c", False, "", 0.1, impassable="bar_0",
                                       collision="True")])
    one, two = bench.summarise(tmp_path, [1.0, 2.0])
    assert one["timed"] == two["timed"] == 1  # only "a" reached the goal with both
    assert one["overhead_mean"] == pytest.approx(20.0)
    assert two["overhead_mean"] == pytest.approx(10.0)
    assert (one["reached"], one["reachable"]) == (2, 2)
    assert (two["reached"], two["reachable"], two["collisions"]) == (1, 2, 1)
    assert two["clearance_min"] == pytest.approx(0.05)
    bench.draw([one, two], tmp_path / "f.png", "biped")
    assert (tmp_path / "f.png").stat().st_size > 0
