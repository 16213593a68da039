"""How the graph's nodes run: one interface, two implementations.

:class:`~.processes.ProcessLauncher` runs each node in its own supervised process,
:class:`~.in_process.InProcessLauncher` composes them on the bringup's executor
(``--in-process``). The session (:mod:`.session`) starts, watches and stops them through
this interface only.
"""

from __future__ import annotations

import argparse
import os
from abc import ABC, abstractmethod
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from safe_legged_c3bf.run.outcome import Outcome
    from safe_legged_c3bf.run.session import Session


class Launcher(ABC):
    """Starts the plan's nodes, tells the session when one ends, stops them."""

    #: What a dead node's Outcome.details hold, for the message at the end.
    failure_label = "last lines of its stderr"
    #: Wall s to wait for the simulator to end the run once the duration is reached (0: don't).
    end_grace = 0.0
    #: File the C-level stderr of this process goes to unless --verbose (None: the terminal).
    shared_log: Path | None = None

    def make_executor(self) -> Any:
        """The executor the session spins (the monitor's, and the nodes' in-process)."""
        from rclpy.executors import SingleThreadedExecutor

        return SingleThreadedExecutor()

    @abstractmethod
    def start(self, session: Session) -> None:
        """Start the nodes (returns early once ``session.stop_request`` is set)."""

    @abstractmethod
    def check(self) -> Outcome | None:
        """An Outcome when a node ended (died, froze, or the simulator finished), else None."""

    @abstractmethod
    def stop(self) -> list[str]:
        """Stop every node; return a line for each that had to be forced."""

    def cpu_seconds(self) -> dict[str, float]:
        """CPU core-seconds used so far, per node process ({}: unknown)."""
        return {}

    def node_table(self) -> dict[str, dict[str, Any]]:
        """Per started node: pid, module, exit and log, for report.json ({}: nothing to say)."""
        return {}

    def close(self) -> None:  # noqa: B027 - optional: nothing to release by default
        """Release what is left after :meth:`stop` (also after a failed start)."""


def make_launcher(opts: argparse.Namespace, run_dir: Path) -> Launcher:
    """The launcher the command line asks for."""
    from safe_legged_c3bf.nodes.ros_common import DEFAULT_EXECUTOR, EXECUTOR_VARIABLE

    executor = opts.executor or DEFAULT_EXECUTOR
    if opts.in_process:
        from safe_legged_c3bf.run.in_process import InProcessLauncher

        return InProcessLauncher(run_dir, executor=executor)
    from safe_legged_c3bf.run.processes import ProcessLauncher

    os.environ[EXECUTOR_VARIABLE] = executor  # read by each node's run_node

    return ProcessLauncher(run_dir, video=opts.video is not None, verbose=opts.verbose)
