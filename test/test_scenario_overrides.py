"""Scenario override sections are checked against the nodes' real parameters (issue #14)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from safe_legged_c3bf.interfaces import node_parameters as np_
from safe_legged_c3bf.sim.scenario import ScenarioError, parse_scenario

REPO = Path(__file__).resolve().parents[1]
BASE = {"goal": {"position": [3.0, 0.0]}, "duration": 1.0}


def _parse(section, values):
    return parse_scenario(dict(BASE, **{section: values}))


def test_scenario_module_does_not_import_ros():
    code = ("import sys, safe_legged_c3bf.sim.scenario as s; s.parse_scenario("
            "{'goal': {'position': [1.0, 0.0]}, 'filter': {'gamma': 2.0}}); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('rclpy', 'rcl_interfaces')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                         check=True, env={"PYTHONPATH": str(REPO)}).stdout
    assert out.strip().splitlines()[-1] == "[]"


def test_sections_take_their_names_and_types_from_the_parameter_classes():
    for section, node in np_.OVERRIDE_NODES.items():
        defaults = np_.parameter_class(node).defaults()
        assert np_.override_parameter_defaults(section).keys() == defaults.keys()
    # The filter and gait controller refuse an integer for a float, as they always did.
    refuse = {s for s in np_.OVERRIDE_NODES if np_.override_refuses_integers(s)}
    assert refuse == {"filter", "controller"}
    assert np_.override_fixed_parameters("planner") == ("diagnostics_period", "scenario")


@pytest.mark.parametrize(
    ("section", "values", "message"),
    [
        # rclpy refuses an integer for a double of the filter / gait controller node.
        ("filter", {"gamma": 1}, "filter.gamma: must be a floating-point number, got 1 (write 1.0"),
        ("filter", {"weights": [1, 0.2, 0.5]}, "filter.weights: must be a list of floating-point"),
        ("filter", {"enabled": "false"}, "filter.enabled: must be true or false"),
        ("filter", {"model": 2.0}, "filter.model: must be a string"),
        ("controller", {"command_timeout": 1}, "controller.command_timeout: must be a floating"),
        ("tracker", {"confirm_hits": 2.5}, "tracker.confirm_hits: must be an integer"),
        ("planner", {"k_z": "fast"}, "planner.k_z: must be a number"),
        # Values the node itself would refuse at start-up, for the filter (FilterParams).
        ("filter", {"gamma": -1.0}, "filter.gamma: must be a finite number > 0"),
        ("filter", {"min_height": 0.4, "max_height": 0.3}, "filter.min_height/max_height"),
        # The planner's scenario parameter is the bringup's; the node applies the section
        # after it started, so its parameters fixed at start-up cannot be in it.
        ("planner", {"scenario": "other"}, "planner.scenario: unknown key 'scenario'"),
        ("planner", {"diagnostics_period": 2.0}, "planner.diagnostics_period: unknown key"),
    ],
)
def test_override_values_are_typed_like_the_nodes_parameters(section, values, message):
    with pytest.raises(ScenarioError) as err:
        _parse(section, values)
    assert message in str(err.value)


def test_integers_where_the_node_accepts_them():
    # The tracker and planner take an integer for a float (their classes' int_for_float).
    sc = parse_scenario(dict(BASE, tracker={"rate": 20, "confirm_hits": 2},
                             planner={"max_vx": 1}))
    assert sc.overrides["tracker"] == {"rate": 20, "confirm_hits": 2}
    assert sc.planner.params == {"max_vx": 1}
