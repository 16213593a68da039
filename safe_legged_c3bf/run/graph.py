"""The node graph a bringup runs: node names, their modules and the start order.

Which nodes run depends on the run: the obstacle detector only with ``sensors`` perception
(with ``oracle`` perception the simulator publishes the detections itself), and a deployment
on a real robot (``--deploy``) runs the safety pipeline alone, without simulator and gait
controller (:func:`graph_for`).
"""

from __future__ import annotations

from collections.abc import Iterable

from safe_legged_c3bf.run.outcome import StartupError
from safe_legged_c3bf.sim.scenario_sections import PERCEPTION_SOURCES

NODE_PACKAGE = "safe_legged_c3bf.nodes"
#: Graph nodes in start order: (name, module). The gait controller's robot comes from the
#: scenario; the simulator is started first so that it is up when the others subscribe.
GRAPH_NODES = (
    ("simulator", f"{NODE_PACKAGE}.simulator_node"),
    ("obstacle_detector", f"{NODE_PACKAGE}.obstacle_detector_node"),
    ("obstacle_tracker", f"{NODE_PACKAGE}.obstacle_tracker_node"),
    ("reference_planner", f"{NODE_PACKAGE}.reference_planner_node"),
    ("safety_filter", f"{NODE_PACKAGE}.safety_filter_node"),
    ("gait_controller", f"{NODE_PACKAGE}.gait_controller_node"),
)
NODE_NAMES = tuple(name for name, _ in GRAPH_NODES)
#: The nodes a deployment on a real robot runs (the planner only on request).
DEPLOY_NODES = ("obstacle_detector", "obstacle_tracker", "reference_planner", "safety_filter")
RECORDER_MODULE = "safe_legged_c3bf.run.recorder"
#: Started once the other nodes are in the graph: its first command starts physics.
LAST_NODE = "gait_controller"


def node_modules(replacements: Iterable[str]) -> dict[str, str]:
    """Node name -> module, with ``--node NAME=MODULE`` replacements applied.

    Raises:
        StartupError: a replacement is malformed or names an unknown node.

    """
    modules = dict(GRAPH_NODES)
    for item in replacements:
        name, sep, module = item.partition("=")
        if not sep or not module or name not in modules:
            raise StartupError(
                f"--node {item!r}: expected NAME=MODULE with NAME one of "
                f"{', '.join(sorted(NODE_NAMES))}"
            )
        modules[name] = module
    return modules


def graph_for(perception: str, deploy: bool = False, planner: bool = True) -> tuple[str, ...]:
    """The names of the nodes a run starts, in start order.

    Args:
        perception: 'oracle' (the simulator publishes detections) or 'sensors' (the obstacle
            detector turns /scan and /points into detections).
        deploy: the safety pipeline alone, on a real robot's topics (always 'sensors').
        planner: with ``deploy``, also run the reference planner (else /cmd_vel comes from
            the robot's own navigation or teleoperation).

    """
    if perception not in PERCEPTION_SOURCES:
        raise StartupError(
            f"perception {perception!r}: expected one of {', '.join(PERCEPTION_SOURCES)}"
        )
    if deploy:
        return tuple(n for n in DEPLOY_NODES if planner or n != "reference_planner")
    return tuple(
        n for n in NODE_NAMES if perception == "sensors" or n != "obstacle_detector"
    )
