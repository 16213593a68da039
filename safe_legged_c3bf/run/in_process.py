"""Compose every node on the bringup's own executor (``--in-process``).

Each node module's one rclpy Node subclass is created with its merged parameters
(:func:`~.parameters.merged_parameters`); the run completes when ``SimulatorNode.finished``
becomes true. Node logs (C-level stderr) go to ``<run>/logs/in_process.log``.
"""

from __future__ import annotations

import importlib
import inspect
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Any

from safe_legged_c3bf.run.console import say
from safe_legged_c3bf.run.cpu_usage import own_cpu_seconds
from safe_legged_c3bf.run.launcher import Launcher
from safe_legged_c3bf.run.outcome import Outcome, StartupError
from safe_legged_c3bf.run.parameters import merged_parameters

if TYPE_CHECKING:
    from safe_legged_c3bf.run.session import Session


def find_node_class(module_name: str) -> type:
    """The rclpy Node subclass defined in a node module."""
    from rclpy.node import Node

    module = importlib.import_module(module_name)
    classes = [
        obj for _, obj in inspect.getmembers(module, inspect.isclass)
        if issubclass(obj, Node) and obj is not Node and obj.__module__ == module.__name__
    ]
    if len(classes) != 1:
        raise StartupError(
            f"{module_name}: expected exactly one rclpy Node subclass, found "
            f"{[c.__name__ for c in classes] or 'none'}"
        )
    return classes[0]


def rclpy_parameters(values: dict[str, Any]) -> list:
    """Plain values as rclpy Parameters (empty lists left out: their type is unknown)."""
    from rclpy.parameter import Parameter

    out = []
    for name, value in values.items():
        if isinstance(value, list | tuple):
            if not value:
                continue
            value = [float(v) for v in value] if any(isinstance(v, float) for v in value) \
                else list(value)
        out.append(Parameter(name, value=value))
    return out


class InProcessLauncher(Launcher):
    """Every node (and the recorder) as an object on the session's executor."""

    failure_label = "traceback"

    def __init__(self, run_dir: Path, executor: str) -> None:
        """Nodes log to ``run_dir/logs/in_process.log``; ``executor``: events, single, multi."""
        self.shared_log = run_dir / "logs" / "in_process.log"
        self.executor_kind = executor
        self.nodes: list[tuple[str, Any]] = []
        self._executor = None
        self._own_cpu_start = own_cpu_seconds()

    def make_executor(self) -> Any:
        """A multi-threaded executor (4 threads) with ``--executor multi``, else as asked."""
        if self.executor_kind != "multi":
            from safe_legged_c3bf.nodes.ros_common import make_executor

            return make_executor(self.executor_kind)
        from rclpy.executors import MultiThreadedExecutor

        return MultiThreadedExecutor(num_threads=4)

    def start(self, session: Session) -> None:
        """Create the recorder and the graph nodes and add them to the executor."""
        from safe_legged_c3bf.nodes.ros_common import freeze_startup_objects
        from safe_legged_c3bf.run.recorder import RecorderNode

        plan = session.plan
        self._executor = session.executor
        cli = plan.ros_cli_args()
        if plan.recorder is not None:
            node = RecorderNode(plan.recorder.args[0], cli_args=cli or None)
            self.nodes.append(("recorder", node))
            self._executor.add_node(node)
        for spec in plan.specs:
            if session.stop_request:
                return
            cls = find_node_class(spec.module)
            try:
                node = cls(
                    parameter_overrides=rclpy_parameters(merged_parameters(spec)),
                    cli_args=cli or None,
                )
            except Exception as err:
                raise StartupError(
                    f"{spec.name} ({spec.module}) failed to start: {err!r}\n"
                    + "".join(traceback.format_exc(limit=-4))
                ) from None
            self.nodes.append((spec.name, node))
            self._executor.add_node(node)
        freeze_startup_objects()  # see ros_common: full collections otherwise stall the nodes

    def check(self) -> Outcome | None:
        """The run completes when the simulator node says it finished the scenario."""
        if any(name == "simulator" and bool(getattr(node, "finished", False))
               for name, node in self.nodes):
            return Outcome("completed", "the simulator finished the scenario")
        return None

    def cpu_seconds(self) -> dict[str, float]:
        """CPU core-seconds of the bringup process: every node, the recorder and the monitor."""
        return {"in_process": own_cpu_seconds() - self._own_cpu_start}

    def stop(self) -> list[str]:
        """Destroy the nodes (nothing is ever forced)."""
        self.close()
        return []

    def close(self) -> None:
        """Destroy the nodes, last started first (the simulator writes its summary)."""
        while self.nodes:
            name, node = self.nodes.pop()
            try:
                if self._executor is not None:
                    self._executor.remove_node(node)
                node.destroy_node()
            except Exception as err:  # noqa: BLE001 - report and go on stopping the rest
                say(None, f"{name}: error while stopping: {err!r}")
