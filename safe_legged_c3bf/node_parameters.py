"""The parameters each graph node declares, without importing ROS.

A scenario's ``filter:``, ``tracker:``, ``controller:`` and ``planner:`` sections are
parameter overrides of the safety filter, obstacle tracker, gait controller and reference
planner nodes (the bringup hands them over). rclpy ignores an override of a parameter a node
never declared, so a misspelt key would silently do nothing: :mod:`safe_legged_c3bf.sim.scenario`
checks the keys against the names listed here when the file is loaded.

Where the names come from:

* safety filter: the fields of :class:`~safe_legged_c3bf.filtering.params.FilterParams`
  (the node declares exactly these);
* obstacle tracker: :class:`~safe_legged_c3bf.tracking.params.ObstacleTrackerParams` (its
  fields, then those of ``TrackerConfig`` and ``TrackConfig``: the node declares these);
* reference planner: :class:`~safe_legged_c3bf.planning.params.ReferencePlannerParams`;
* gait controller: :class:`~safe_legged_c3bf.gait_controller_params.GaitControllerParams`
  (its gait parameters come from its ``controller_config`` file, not from parameters).

``use_sim_time`` is left out on purpose: every node of the graph must run on sim time.
"""

from __future__ import annotations

from dataclasses import asdict

#: Scenario override section -> the node that receives it.
OVERRIDE_NODES = {
    "filter": "safety_filter",
    "tracker": "obstacle_tracker",
    "controller": "gait_controller",
    "planner": "reference_planner",
}


#: Sections whose node declares its floating-point parameters without dynamic typing: rclpy
#: refuses an integer there (``gamma: 1`` instead of ``1.0``) and the node fails to start.
STRICT_DOUBLE_SECTIONS = frozenset({"filter", "controller"})


def filter_parameter_defaults() -> dict[str, object]:
    """The safety filter node's parameters: the fields of FilterParams, with defaults."""
    from safe_legged_c3bf.filtering.params import FilterParams

    return asdict(FilterParams())


def tracker_parameter_defaults() -> dict[str, object]:
    """The obstacle tracker node's parameters: node extras, tracker and track configuration."""
    from safe_legged_c3bf.tracking.params import ObstacleTrackerParams

    return ObstacleTrackerParams.defaults()


def planner_parameter_defaults() -> dict[str, object]:
    """The reference planner node's parameters, with defaults."""
    from safe_legged_c3bf.planning.params import ReferencePlannerParams

    return ReferencePlannerParams.defaults()


def controller_parameter_defaults() -> dict[str, object]:
    """The gait controller node's parameters, with defaults."""
    from safe_legged_c3bf.gait_controller_params import GaitControllerParams

    return GaitControllerParams.defaults()


def override_parameter_defaults(section: str) -> dict[str, object]:
    """Parameters (name -> default) a scenario's ``section`` ('filter', ...) may override."""
    return {
        "filter": filter_parameter_defaults,
        "tracker": tracker_parameter_defaults,
        "controller": controller_parameter_defaults,
        "planner": planner_parameter_defaults,
    }[section]()
