"""Run each node in its own supervised process (the default launcher).

The recorder (with ``--record``) and every node but the gait controller start first; the gait
controller, whose first command starts physics, once the others are in the ROS graph. Node logs
go to ``<run>/logs/<node>.log`` (see :mod:`.supervisor`).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from safe_legged_c3bf.run.console import say
from safe_legged_c3bf.run.cpu_usage import CpuMeter, own_cpu_seconds
from safe_legged_c3bf.run.graph import LAST_NODE
from safe_legged_c3bf.run.launcher import Launcher
from safe_legged_c3bf.run.outcome import EXIT_FAILED, Outcome
from safe_legged_c3bf.run.supervisor import ManagedProcess, Supervisor, describe_returncode

if TYPE_CHECKING:
    from safe_legged_c3bf.run.session import Session

#: Wall s from the first SIGINT to the last SIGKILL when stopping (the recorder last).
STOP_WINDOW = 4.5
#: Wall s of STOP_WINDOW left to the recorder once the graph nodes are stopped.
RECORDER_STOP = 1.0


class ProcessLauncher(Launcher):
    """One process per node, started and stopped by a :class:`Supervisor`."""

    failure_label = "last lines of its stderr"

    def __init__(self, run_dir: Path, video: bool = False, verbose: bool = False) -> None:
        """Nodes log to ``run_dir/logs``; ``verbose`` echoes their lines to the terminal."""
        self.log_dir = run_dir / "logs"
        self.env = dict(os.environ)
        self.verbose = verbose
        # the simulator process exits by itself at the duration (a video takes a while)
        self.end_grace = 30.0 if video else 5.0
        self.supervisor: Supervisor | None = None
        self.processes: dict[str, ManagedProcess] = {}
        self.cpu = CpuMeter()
        self._own_cpu_start = own_cpu_seconds()

    def start(self, session: Session) -> None:
        """Start the recorder and the graph nodes; the gait controller once the others are up."""
        plan = session.plan
        self.supervisor = Supervisor(self.log_dir, self.env)
        remap = [arg for r in plan.remaps for arg in ("-r", r)]
        first = [s for s in plan.specs if s.name != LAST_NODE]
        last = [s for s in plan.specs if s.name == LAST_NODE]
        if plan.recorder is not None:
            first.insert(0, plan.recorder)  # record from the very first message
        for batch in (first, last):
            for spec in batch:
                if session.stop_request:
                    return
                spec.ros_args = [*spec.ros_args, *remap]
                echo = _echo_line(session, spec.name) if self.verbose else None
                self.processes[spec.name] = self.supervisor.start(spec, echo=echo)
            if batch is first and last:
                self._wait_for_nodes(session, len(first))

    def _wait_for_nodes(self, session: Session, count: int, timeout: float = 30.0) -> None:
        """Spin until ``count`` nodes besides the monitor are in the graph (or one died).

        Physics starts with the gait controller's first command, so the gait controller is
        started only once the other nodes are up: all of them see the run from t = 0.
        """
        timeout = min(timeout, session.opts.startup_timeout)
        deadline = time.monotonic() + timeout
        own = session.monitor.get_name()
        names: set[str] = set()
        while time.monotonic() < deadline and not session.stop_request:
            names = {n for n in session.monitor.get_node_names() if n != own}
            if len(names) >= count:
                return
            if any(p.poll() is not None for p in self.processes.values()):
                return  # the watch loop reports it
            session.progress.update(f"starting nodes: {len(names)} of {count} up")
            session.executor.spin_once(timeout_sec=0.05)
        if not session.stop_request:
            say(session.progress, f"only {len(names)} of {count} nodes visible after "
                f"{timeout:g} s; starting {LAST_NODE} anyway")

    def check(self) -> Outcome | None:
        """The simulator's exit 0 completes the run; any other exit or a frozen node fails it."""
        if self.supervisor is None:
            return None
        self._sample_cpu()
        for proc in self.supervisor.newly_exited():
            code = proc.poll()
            if proc.name == "simulator" and code == 0:
                return Outcome("completed", "the simulator finished the scenario")
            return Outcome(
                "node_died", f"node {proc.name} (pid {proc.pid}) {describe_returncode(code)}",
                EXIT_FAILED, proc.name, proc.last_lines(),
            )
        for proc in self.supervisor.running():
            if proc.frozen():
                return Outcome(
                    "node_died",
                    f"node {proc.name} (pid {proc.pid}) is frozen (stopped by a signal)",
                    EXIT_FAILED, proc.name, [],
                )
        return None

    def stop(self) -> list[str]:
        """SIGINT every node's group, escalating; the recorder last (it keeps the last data)."""
        if self.supervisor is None:
            return []
        self._sample_cpu()
        deadline = time.monotonic() + STOP_WINDOW
        graph = [p for name, p in self.processes.items() if name != "recorder"]
        recorder = [p for name, p in self.processes.items() if name == "recorder"]
        escalated = self.supervisor.stop(
            graph, deadline=deadline - RECORDER_STOP if recorder else deadline
        )
        if recorder:
            escalated += self.supervisor.stop(recorder, deadline=deadline)
        return [f"{p.name} did not stop on SIGINT: {describe_returncode(p.poll())}"
                for p in escalated]

    def _sample_cpu(self) -> None:
        self.cpu.sample({name: p.pid for name, p in self.processes.items()})

    def cpu_seconds(self) -> dict[str, float]:
        """Each node process's CPU core-seconds (last read), and this process's (the monitor)."""
        return {**self.cpu.seconds, "bringup": own_cpu_seconds() - self._own_cpu_start}

    def node_table(self) -> dict[str, dict[str, Any]]:
        """Per started process: pid, module, how it exited and its log file."""
        return {
            name: {"pid": p.pid, "module": p.spec.module,
                   "exit": describe_returncode(p.poll()), "log": str(p.log_path)}
            for name, p in self.processes.items()
        }


def _echo_line(session: Session, name: str) -> Callable[[str], None]:
    """Print a node's stderr line as ``[name] line`` (for --verbose)."""
    def echo(line: str) -> None:
        session.progress.clear()
        print(f"[{name}] {line}", file=sys.stderr, flush=True)

    return echo
