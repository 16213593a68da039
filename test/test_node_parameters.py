"""Every parameter of every node: in its config file, documented, and refused when invalid.

Walks the graph nodes and their parameter classes
(safe_legged_c3bf/interfaces/node_parameters.py): config/<node>.yaml holds exactly the class's
defaults; each parameter has a unit and a description (on the node too, read-only where fixed
at start-up); an invalid value (the example of its rule, and a value of the wrong type) makes
the node's constructor raise a ValueError naming the parameter, and a live ``set_parameters``
fail with a reason naming it.
"""

from __future__ import annotations

import importlib

import pytest
import rclpy
import yaml
from rclpy.parameter import Parameter

from safe_legged_c3bf.interfaces.node_parameters import NODE_PARAMETER_CLASSES, parameter_class
from safe_legged_c3bf.nodes.parameters import same_value, to_ros
from safe_legged_c3bf.run.config import config_path

#: Node name -> (module, class) of the rclpy node.
NODES = {
    "safety_filter": ("safe_legged_c3bf.nodes.safety_filter_node", "SafetyFilterNode"),
    "obstacle_tracker": ("safe_legged_c3bf.nodes.obstacle_tracker_node", "ObstacleTrackerNode"),
    "obstacle_detector": (
        "safe_legged_c3bf.nodes.obstacle_detector_node", "ObstacleDetectorNode"
    ),
    "reference_planner": (
        "safe_legged_c3bf.nodes.reference_planner_node", "ReferencePlannerNode"
    ),
    "gait_controller": ("safe_legged_c3bf.nodes.gait_controller_node", "GaitControllerNode"),
    "simulator": ("safe_legged_c3bf.nodes.simulator_node", "SimulatorNode"),
}

#: Parameters rclpy declares on every node.
RCLPY_PARAMETERS = {"use_sim_time", "start_type_description_service"}


def node_class(node: str) -> type:
    module, name = NODES[node]
    return getattr(importlib.import_module(module), name)


def wrong_type(default: object) -> object:
    """A value of another parameter type than ``default``'s."""
    return 1.5 if isinstance(default, str) else "text"


def invalid_values(spec) -> list[object]:
    """The rule's example of an invalid value, and one of the wrong type."""
    return [spec.invalid, wrong_type(spec.default)]


def test_every_node_has_a_parameter_class():
    assert set(NODE_PARAMETER_CLASSES) == set(NODES)


@pytest.mark.parametrize("node", NODES)
def test_config_file_holds_exactly_the_defaults(node):
    values = yaml.safe_load(config_path(f"{node}.yaml").read_text())[node]["ros__parameters"]
    cls = parameter_class(node)
    defaults = {name: to_ros(value) for name, value in cls.defaults().items()}
    assert sorted(values) == sorted(defaults), "config file and class list other parameters"
    for name, value in values.items():
        assert type(value) is type(defaults[name]), name
        assert same_value(value, defaults[name]), name
    cls.from_flat(values)  # and they are valid together


@pytest.mark.parametrize("node", NODES)
def test_every_parameter_has_a_unit_a_description_and_an_invalid_example(node):
    for spec in parameter_class(node).specs():
        assert spec.unit.strip(), f"{spec.name}: no unit ('-' when unitless)"
        assert len(spec.description.strip()) > 10, f"{spec.name}: no description"
        for value in invalid_values(spec):
            with pytest.raises(ValueError, match=rf"^{spec.name}\b"):
                spec.check(value)


@pytest.mark.parametrize("node", NODES)
def test_an_invalid_start_up_value_is_refused_with_the_reason(ros_executor, node):
    # A node that lives through the loop keeps the context's DDS participant: otherwise every
    # refused node was the participant's last one, and a participant created and destroyed
    # per value once stalled the test process for minutes (Fast DDS busy-waits for a
    # discovery callback in flight when a participant is deleted).
    ros_executor.add_node(rclpy.create_node("keeper", context=ros_executor.context_for_nodes))
    cls = node_class(node)
    for spec in parameter_class(node).specs():
        for value in invalid_values(spec):
            override = [Parameter(spec.name, value=to_ros(value))]
            with pytest.raises(ValueError, match=rf"\b{spec.name}\b.*must be"):
                cls(context=ros_executor.context_for_nodes, parameter_overrides=override)


@pytest.mark.parametrize("node", NODES)
def test_the_node_declares_its_class_and_refuses_invalid_live_values(ros_executor, node):
    instance = node_class(node)(context=ros_executor.context_for_nodes)
    ros_executor.add_node(instance)
    specs = parameter_class(node).specs()
    declared = set(instance.list_parameters([], 0).names) - RCLPY_PARAMETERS
    assert declared == {s.name for s in specs}
    for spec in specs:
        descriptor = instance.describe_parameter(spec.name)
        unit = "unitless" if spec.unit == "-" else spec.unit
        assert descriptor.description.endswith(f"[{unit}]"), spec.name
        assert descriptor.read_only == spec.fixed, spec.name
        before = instance.get_parameter(spec.name).value
        for value in invalid_values(spec):
            result = instance.set_parameters([Parameter(spec.name, value=to_ros(value))])[0]
            assert not result.successful, (spec.name, value)
            assert spec.name in result.reason, (spec.name, result.reason)
            assert same_value(instance.get_parameter(spec.name).value, before), spec.name
