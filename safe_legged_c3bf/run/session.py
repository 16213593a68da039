"""One run of a plan: start the nodes, watch them and the monitor, stop everything.

The session owns the monitor node, the executor and the stop request; a
:class:`~.launcher.Launcher` runs the nodes (processes or in-process) and the watch loop is the
same for both. The run ends when the simulator finishes, the outcome is settled
(``--stop-on-outcome``), start-up or simulation time stalls, a signal arrives, or a node dies
or freezes; after a node failure the run goes on :data:`FAILURE_WATCH_SIM` s of sim time so
the report shows the rest of the graph's fail-safe. :mod:`.ending` then reports.
"""

from __future__ import annotations

import argparse
import math
import signal
import time
import traceback
from dataclasses import dataclass, field

from safe_legged_c3bf.run.console import Progress, StopRequest, progress_text, say
from safe_legged_c3bf.run.ending import finish
from safe_legged_c3bf.run.graph import GRAPH_NODES
from safe_legged_c3bf.run.launcher import Launcher, make_launcher
from safe_legged_c3bf.run.outcome import (
    EXIT_FAILED,
    EXIT_SIGNAL,
    EXIT_STARTUP,
    Outcome,
    StartupError,
)
from safe_legged_c3bf.run.plan import RunPlan
from safe_legged_c3bf.run.quiet_stderr import stderr_to_file

HOUSEKEEPING_PERIOD = 0.1
#: Sim seconds a --stop-on-outcome run goes on after its deciding event (data to plot).
OUTCOME_HOLD = 1.0
#: After a node dies or freezes, the run goes on this long (sim s; at most the wall s) so the
#: report shows the remaining graph's fail-safe (the robot stopping) before the run ends.
FAILURE_WATCH_SIM, FAILURE_WATCH_WALL = 2.0, 10.0


@dataclass
class _Clocks:
    """What the watch loop remembers between its checks (wall times are time.monotonic)."""

    started_at: float | None = None  # physics runs
    reached_at: float | None = None  # sim time reached the duration
    last_progress_sim: float = -math.inf
    last_progress_wall: float = field(default_factory=time.monotonic)
    failed: tuple[float, float] | None = None  # (sim, wall) time a node was found dead


class Session:
    """One run: starts the nodes, watches them and the monitor, stops everything."""

    def __init__(
        self, opts: argparse.Namespace, plan: RunPlan, launcher: Launcher | None = None
    ) -> None:
        """Prepare a run of ``plan`` (``launcher`` default: the one ``opts`` asks for)."""
        self.opts = opts
        self.plan = plan
        self.launcher = launcher or make_launcher(opts, plan.run_dir)
        self.progress = Progress(period=opts.progress_period)
        self.stop_request = StopRequest()
        self.monitor = None
        self.executor = None
        self.wall_start = time.monotonic()
        self.outcome = Outcome()
        self.done = False  # the run reached its end (no failure, no signal)
        self.stopped_early = False  # --stop-on-outcome ended it

    def run(self) -> int:
        """Start everything, watch until done, stop, report; return the exit code."""
        import rclpy
        from rclpy.signals import SignalHandlerOptions

        self._check_modules()
        rclpy.init(args=None, signal_handler_options=SignalHandlerOptions.NO)
        redirect = None
        try:
            if self.launcher.shared_log is not None and not self.opts.verbose:
                redirect = stderr_to_file(self.launcher.shared_log)
            self._start_monitor()
            self.wall_start = time.monotonic()
            try:
                self.launcher.start(self)
                if not self.stop_request:
                    self._watch()
                if self.done:
                    self._drain()
            except StartupError as err:
                self.outcome = Outcome("startup_failed", str(err), EXIT_STARTUP)
            except Exception as err:  # noqa: BLE001 - a node raised inside the executor
                self.outcome = _callback_failure(err)
            self._note_interruption()
            self.outcome.details.extend(self.launcher.stop())
            if redirect is not None:
                redirect.restore()
                redirect = None
            return finish(self)
        finally:
            if redirect is not None:
                redirect.restore()
            self.stop_request.restore()
            if self.executor is not None:
                self.executor.shutdown(timeout_sec=1.0)
            self.launcher.close()
            if self.monitor is not None:
                self.monitor.destroy_node()
            rclpy.try_shutdown()

    # -- start ---------------------------------------------------------------------------------
    def _check_modules(self) -> None:
        specs = list(self.plan.specs) + ([self.plan.recorder] if self.plan.recorder else [])
        missing = [f"{s.name} ({s.module})" for s in specs if not s.module_available()]
        if missing:
            raise StartupError(
                "node module(s) not installed: " + ", ".join(missing)
                + ". Reinstall the package (pip install -e .) or check --node."
            )

    def _start_monitor(self) -> None:
        from safe_legged_c3bf.run.monitor import MonitorNode

        self.monitor = MonitorNode(cli_args=self.plan.ros_cli_args() or None)
        self.monitor.goal = self.plan.context.goal
        self.monitor.goal_tolerance = self.plan.context.goal_tolerance
        self.executor = self.launcher.make_executor()
        self.executor.add_node(self.monitor)

    # -- watch ---------------------------------------------------------------------------------
    def _watch(self) -> None:
        """Spin, and ten times a second decide whether the run is over."""
        clocks = _Clocks()
        last_check = -math.inf
        while not self.stop_request:
            self.executor.spin_once(timeout_sec=0.05)
            now = time.monotonic()
            if now - last_check < HOUSEKEEPING_PERIOD:
                continue  # keep up with the message stream; check the run 10 times a second
            last_check = now
            t = self.monitor.sim_time
            _observe(clocks, t, now, self.plan.context.duration)
            if clocks.failed is None and self._node_ended(clocks, t, now):
                return
            if clocks.failed is not None:
                if (t is not None and t >= clocks.failed[0] + FAILURE_WATCH_SIM) or (
                        now - clocks.failed[1] > FAILURE_WATCH_WALL):
                    return
                continue
            if self._run_ended(clocks, t, now):
                return
            self.progress.update(progress_text(self.monitor, self.plan.context.duration))

    def _node_ended(self, clocks: _Clocks, t: float | None, now: float) -> bool:
        """Ask the launcher; True when the run is over, False also while a failure is watched."""
        outcome = self.launcher.check()
        if outcome is None:
            return False
        self.outcome = outcome
        self.done = outcome.kind == "completed"
        if outcome.kind != "node_died" or outcome.failed_node == "simulator":
            return True
        # Keep the simulator running a little: the report shows the fail-safe at work
        # (the robot stopping without the dead node) from ground truth.
        clocks.failed = (t if t is not None else 0.0, now)
        say(self.progress, f"{outcome.reason}: watching the fail-safe for "
            f"{FAILURE_WATCH_SIM:g} s of sim time")
        return False

    def _run_ended(self, clocks: _Clocks, t: float | None, now: float) -> bool:
        """Outcome settled, duration reached, start-up timed out or simulation stalled."""
        opts = self.opts
        settled = self.monitor.decided(OUTCOME_HOLD) if opts.stop_on_outcome else None
        if settled is not None:
            self.outcome = Outcome("completed", settled)
            self.done = self.stopped_early = True
            return True
        grace = self.launcher.end_grace
        if clocks.reached_at is not None and (grace <= 0 or now - clocks.reached_at > grace):
            self.outcome = Outcome("completed", "scenario duration reached")
            self.done = True
            return True
        if clocks.started_at is None and now - self.wall_start > opts.startup_timeout:
            what = (
                "no message from the simulator" if t is None
                else "simulation time still 0 (no joint command reached the simulator)"
            )
            seen = ", ".join(sorted(set(self.monitor.get_node_names()))) or "none"
            self.outcome = Outcome(
                "startup_failed",
                f"{what} after {opts.startup_timeout:g} s; nodes seen: {seen}", EXIT_STARTUP,
            )
            return True
        if (clocks.started_at is not None and clocks.reached_at is None
                and now - clocks.last_progress_wall > opts.stall_timeout):
            self.outcome = Outcome(
                "stalled", f"simulation time stuck at {clocks.last_progress_sim:.2f} s for "
                f"{opts.stall_timeout:g} s", EXIT_FAILED,
            )
            return True
        return False

    def _drain(self, timeout: float = 2.0) -> None:
        """Let the monitor (and an in-process recorder) catch up with the last messages."""
        deadline = time.monotonic() + (0.3 if self.stopped_early else timeout)
        target = self.plan.context.duration - 1e-3
        while time.monotonic() < deadline and not self.stop_request:
            if self.monitor.sim_time is not None and self.monitor.sim_time >= target:
                break
            self.executor.spin_once(timeout_sec=0.05)

    # -- stop ----------------------------------------------------------------------------------
    def _note_interruption(self) -> None:
        """A signal that came before the run's end makes the outcome 'interrupted'."""
        if self.stop_request and not self.done and self.outcome.kind in (
            "completed", "startup_failed"
        ):
            sig = self.stop_request.signum
            self.outcome = Outcome(
                "interrupted", f"stopped by {signal.Signals(sig).name}",
                EXIT_SIGNAL.get(sig, 128 + sig),
            )


def _observe(clocks: _Clocks, t: float | None, now: float, duration: float) -> None:
    """Note when physics started, when sim time last moved and when it reached the duration."""
    if t is not None and t > 0 and clocks.started_at is None:
        clocks.started_at = now  # physics runs (the simulator waits for a first command)
    if t is not None and t > clocks.last_progress_sim:
        clocks.last_progress_sim, clocks.last_progress_wall = t, now
    if t is not None and t >= duration - 1e-6 and clocks.reached_at is None:
        clocks.reached_at = now


def _callback_failure(err: BaseException) -> Outcome:
    """A node_died Outcome for an exception out of the executor (node guessed from frames)."""
    frames = traceback.extract_tb(err.__traceback__)
    node = None
    for frame in reversed(frames):
        for name, module in GRAPH_NODES:
            if frame.filename.endswith(module.rsplit(".", 1)[1] + ".py"):
                node = name
                break
        if node:
            break
    lines = traceback.format_exception(err)
    tail = "".join(lines).splitlines()[-15:]
    return Outcome(
        "node_died", f"node {node or '?'} raised {type(err).__name__}: {err}", EXIT_FAILED,
        node, tail,
    )
