"""Start node processes, notice when one dies, and stop them all without leaving orphans.

Each child runs in its own session and process group (so a Ctrl-C in the terminal reaches only
the supervisor, which then stops the children in order) and gets SIGTERM from the kernel if the
supervisor itself dies (see :mod:`.child`). Stopping escalates per process group: SIGINT, then
SIGTERM, then SIGKILL, all within :data:`STOP_TIMEOUT` seconds. The stdout and stderr of each
child go to ``<log_dir>/<name>.log``; the last lines of stderr are kept in memory to explain a
death.
"""

from __future__ import annotations

import collections
import importlib.util
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from safe_legged_c3bf.run.child import SUPERVISOR_ENV
from safe_legged_c3bf.run.process_group import group_alive, signal_group, stop_groups

#: Seconds between the first SIGINT and the last SIGKILL when stopping.
STOP_TIMEOUT = 4.5
SIGINT_GRACE = 2.0
SIGTERM_GRACE = 1.5
TAIL_LINES = 200


@dataclass
class NodeSpec:
    """A node to run.

    Attributes:
        name: short name used in messages and log file names ('simulator').
        module: Python module with a ``main()`` ('safe_legged_c3bf.nodes.simulator_node').
        parameters: ROS parameter overrides (name -> value), applied last.
        params_files: YAML parameter files (ros__parameters layout) applied first.
        args: extra command-line arguments placed before ``--ros-args``.
        ros_args: extra ROS arguments (e.g. ``-r /a:=/b``) placed after ``--ros-args``.

    """

    name: str
    module: str
    parameters: dict[str, Any] = field(default_factory=dict)
    params_files: list[Path] = field(default_factory=list)
    args: list[str] = field(default_factory=list)
    ros_args: list[str] = field(default_factory=list)

    def module_available(self) -> bool:
        """True when the node's module can be imported."""
        try:
            return importlib.util.find_spec(self.module) is not None
        except (ImportError, ValueError):
            return False


def signal_name(number: int) -> str:
    """'SIGKILL' for 9, etc."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def describe_returncode(code: int | None) -> str:
    """Human text for a Popen return code."""
    if code is None:
        return "still running"
    if code < 0:
        return f"killed by {signal_name(-code)}"
    return f"exited with code {code}"


def write_params_file(path: Path, parameters: dict[str, Any]) -> Path:
    """Write ``parameters`` as a ROS parameter file applying to any node name."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        yaml.safe_dump({"/**": {"ros__parameters": parameters}}, f, sort_keys=False)
    return path


class ManagedProcess:
    """One child process, its log file and the tail of its stderr."""

    def __init__(
        self,
        spec: NodeSpec,
        popen: subprocess.Popen,
        log_path: Path,
        echo: Callable[[str], None] | None = None,
    ) -> None:
        """Wrap a started process (use :meth:`Supervisor.start`); ``echo`` sees each line."""
        self.spec = spec
        self.popen = popen
        self.pid = popen.pid
        self.log_path = log_path
        self.tail: collections.deque[str] = collections.deque(maxlen=TAIL_LINES)
        self.started = time.monotonic()
        self.stopping = False
        self._echo = echo
        self._log = open(log_path, "a", encoding="utf-8", errors="replace")  # noqa: SIM115
        self._reader = threading.Thread(
            target=self._read_stderr, name=f"stderr-{spec.name}", daemon=True
        )
        self._reader.start()

    @property
    def name(self) -> str:
        """The node's short name."""
        return self.spec.name

    def _read_stderr(self) -> None:
        stream = self.popen.stderr
        if stream is None:
            return
        for raw in iter(stream.readline, b""):
            line = raw.decode("utf-8", errors="replace").rstrip("\n")
            self.tail.append(line)
            if self._echo is not None:
                self._echo(line)
            try:
                self._log.write(line + "\n")
                self._log.flush()
            except ValueError:  # log closed
                pass
        stream.close()

    def poll(self) -> int | None:
        """Return code, or None while running."""
        return self.popen.poll()

    def last_lines(self, count: int = 15, wait: float = 1.0) -> list[str]:
        """The last ``count`` stderr lines (waits up to ``wait`` s for the pipe to drain)."""
        self._reader.join(timeout=wait)
        return [line for line in self.tail if line.strip()][-count:]

    def signal_group(self, sig: int) -> bool:
        """Send ``sig`` to the child's process group; False if the group is gone."""
        return signal_group(self.pid, sig)

    def frozen(self) -> bool:
        """True when the process is stopped (SIGSTOP/SIGTSTP: state T in /proc)."""
        try:
            with open(f"/proc/{self.pid}/stat", encoding="ascii", errors="replace") as f:
                stat = f.read()
        except OSError:
            return False
        state = stat.rpartition(")")[2].split()  # after "pid (comm)": state first
        return bool(state) and state[0] in ("T", "t")

    def group_alive(self) -> bool:
        """True while any process of the child's process group exists."""
        return group_alive(self.popen)

    def describe_exit(self) -> str:
        """'simulator (pid 123) killed by SIGKILL' etc."""
        return f"{self.name} (pid {self.pid}) {describe_returncode(self.poll())}"

    def close(self) -> None:
        """Close the log once the reader is done."""
        self._reader.join(timeout=1.0)
        try:
            self._log.close()
        except OSError:
            pass


class Supervisor:
    """Starts :class:`NodeSpec` processes and stops them again."""

    def __init__(self, log_dir: Path, env: dict[str, str], python: str = sys.executable) -> None:
        """Children get ``env`` (plus the supervisor pid) and log to ``log_dir``."""
        self.log_dir = Path(log_dir)
        self.env = dict(env)
        self.env[SUPERVISOR_ENV] = str(os.getpid())
        self.env.setdefault("PYTHONUNBUFFERED", "1")
        self.env.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
        self.python = python
        self.processes: list[ManagedProcess] = []
        self._reported: set[int] = set()

    def command(self, spec: NodeSpec) -> list[str]:
        """The command line of a node."""
        cmd = [self.python, "-m", "safe_legged_c3bf.run.child", spec.module, *spec.args]
        ros_args: list[str] = []
        for path in spec.params_files:
            ros_args += ["--params-file", str(path)]
        if spec.parameters:
            path = write_params_file(self.log_dir / "params" / f"{spec.name}.yaml", spec.parameters)
            ros_args += ["--params-file", str(path)]
        ros_args += spec.ros_args
        if ros_args:
            cmd += ["--ros-args", *ros_args]
        return cmd

    def start(
        self, spec: NodeSpec, echo: Callable[[str], None] | None = None
    ) -> ManagedProcess:
        """Start one node process in its own session (``echo`` sees its stderr lines)."""
        self.log_dir.mkdir(parents=True, exist_ok=True)
        log_path = self.log_dir / f"{spec.name}.log"
        cmd = self.command(spec)
        with open(log_path, "w", encoding="utf-8") as log:
            log.write("$ " + " ".join(cmd) + "\n")
        stdout = open(log_path, "ab")  # noqa: SIM115 - handed to the child, closed below
        try:
            popen = subprocess.Popen(
                cmd,
                stdin=subprocess.DEVNULL,
                stdout=stdout,
                stderr=subprocess.PIPE,
                env=self.env,
                start_new_session=True,
                close_fds=True,
            )
        finally:
            stdout.close()
        proc = ManagedProcess(spec, popen, log_path, echo)
        self.processes.append(proc)
        return proc

    def newly_exited(self) -> list[ManagedProcess]:
        """Processes that exited since the last call (not counting ones being stopped)."""
        out = []
        for proc in self.processes:
            if proc.pid in self._reported or proc.stopping:
                continue
            if proc.poll() is not None:
                self._reported.add(proc.pid)
                out.append(proc)
        return out

    def running(self) -> list[ManagedProcess]:
        """Processes still running."""
        return [p for p in self.processes if p.poll() is None]

    def stop(
        self, processes: list[ManagedProcess] | None = None, deadline: float | None = None
    ) -> list[ManagedProcess]:
        """Stop ``processes`` (default all): SIGINT, SIGTERM, SIGKILL; return those escalated.

        ``deadline`` (time.monotonic) bounds the whole stop; by default STOP_TIMEOUT from now.
        """
        procs = list(self.processes if processes is None else processes)
        start = time.monotonic()
        deadline = start + STOP_TIMEOUT if deadline is None else deadline
        total = max(deadline - start, 0.3)
        for proc in procs:
            proc.stopping = True
        steps = [
            (start + min(SIGINT_GRACE, total * 0.45), signal.SIGTERM),
            (start + min(SIGINT_GRACE + SIGTERM_GRACE, total * 0.8), signal.SIGKILL),
        ]
        # wake: a frozen child must run to handle SIGINT
        hard = stop_groups([p.popen for p in procs], steps, wake=True)
        by_popen = {id(p.popen): p for p in procs}
        escalated = [by_popen[id(popen)] for popen in hard]
        # The leaders are gone or SIGKILLed; reap them and clear what is left of their groups.
        while time.monotonic() < deadline and any(p.group_alive() for p in procs):
            time.sleep(0.02)
        for proc in procs:
            if proc.group_alive():
                proc.signal_group(signal.SIGKILL)
            try:
                proc.popen.wait(timeout=0.5)
            except subprocess.TimeoutExpired:
                pass
            proc.close()
        return escalated
