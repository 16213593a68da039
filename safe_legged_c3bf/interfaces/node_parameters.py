"""The parameter class of each graph node, without importing ROS.

Every node declares exactly the fields of one
:class:`~safe_legged_c3bf.interfaces.typed_params.TypedParams` class (through
:class:`~safe_legged_c3bf.nodes.parameters.NodeParameters`), listed in
:data:`NODE_PARAMETER_CLASSES`. Names, defaults, types, units and which parameters are fixed
at start-up all come from those classes; nothing is listed twice.

A scenario's ``filter:``, ``tracker:``, ``controller:``, ``planner:`` and ``detector:``
sections are parameter overrides of the safety filter, obstacle tracker, gait controller,
reference planner and obstacle detector nodes (:data:`OVERRIDE_NODES`). rclpy ignores an
override of a parameter a node never declared, so a misspelt key would silently do nothing:
:mod:`safe_legged_c3bf.sim.scenario` checks the keys and value types against these classes
when the file is loaded.

``use_sim_time`` is left out on purpose: every node of the graph must run on sim time.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from safe_legged_c3bf.interfaces.typed_params import TypedParams

#: Node name -> (module, class) of its parameters (imported on use: the tracker's needs scipy).
NODE_PARAMETER_CLASSES = {
    "safety_filter": ("safe_legged_c3bf.safety.params", "FilterParams"),
    "obstacle_tracker": ("safe_legged_c3bf.perception.params", "ObstacleTrackerParams"),
    "obstacle_detector": (
        "safe_legged_c3bf.perception.detector_params", "ObstacleDetectorParams"
    ),
    "reference_planner": ("safe_legged_c3bf.planning.params", "ReferencePlannerParams"),
    "gait_controller": ("safe_legged_c3bf.gait.params", "GaitControllerParams"),
    "simulator": ("safe_legged_c3bf.sim.node_params", "SimulatorParams"),
}

#: Scenario override section -> the node that receives it.
OVERRIDE_NODES = {
    "filter": "safety_filter",
    "tracker": "obstacle_tracker",
    "controller": "gait_controller",
    "planner": "reference_planner",
    "detector": "obstacle_detector",
}


def parameter_class(node: str) -> type[TypedParams]:
    """The parameter class of the graph node named ``node`` ('safety_filter', ...)."""
    module, name = NODE_PARAMETER_CLASSES[node]
    return getattr(import_module(module), name)


def override_parameter_defaults(section: str) -> dict[str, object]:
    """Parameters (name -> default) a scenario's ``section`` ('filter', ...) may override."""
    return parameter_class(OVERRIDE_NODES[section]).defaults()


def override_refuses_integers(section: str) -> bool:
    """True when the node of ``section`` refuses an integer for a float (``1`` for ``1.0``)."""
    return not parameter_class(OVERRIDE_NODES[section]).int_for_float


def override_fixed_parameters(section: str) -> tuple[str, ...]:
    """The parameters of the node of ``section`` that are fixed at its start-up."""
    return tuple(s.name for s in parameter_class(OVERRIDE_NODES[section]).specs() if s.fixed)
