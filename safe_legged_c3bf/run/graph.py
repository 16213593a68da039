"""The node graph a bringup runs: node names, their modules and the start order."""

from __future__ import annotations

from collections.abc import Iterable

from safe_legged_c3bf.run.outcome import StartupError

NODE_PACKAGE = "safe_legged_c3bf.nodes"
#: Graph nodes in start order: (name, module). The gait controller's robot comes from the
#: scenario; the simulator is started first so that it is up when the others subscribe.
GRAPH_NODES = (
    ("simulator", f"{NODE_PACKAGE}.simulator_node"),
    ("obstacle_tracker", f"{NODE_PACKAGE}.obstacle_tracker_node"),
    ("reference_planner", f"{NODE_PACKAGE}.reference_planner_node"),
    ("safety_filter", f"{NODE_PACKAGE}.safety_filter_node"),
    ("gait_controller", f"{NODE_PACKAGE}.gait_controller_node"),
)
NODE_NAMES = tuple(name for name, _ in GRAPH_NODES)
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
