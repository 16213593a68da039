"""Start, watch and keep a run of the whole node graph: ``python -m safe_legged_c3bf.bringup``.

Runs the simulator bridge, obstacle tracker, reference planner, C3BF safety filter and gait
controller on a scenario (default ``quadruped_default``, headless), each node in its own process
(or all on one executor with ``--in-process``), on a private ROS domain restricted to this host
unless ``--domain-id`` is given. While it runs a progress line shows sim time, real-time factor,
distance to the goal and the filter status. At the end it prints a summary and writes a run
folder (``--out``, default ``runs/<scenario>-<timestamp>/``) with ``report.json``, plots, the
node logs and, on request, an MCAP recording (``--record``) and a video (``--video``).

Exit codes: 0 the run completed (also when the robot collided or fell: the report says so);
1 a node died or the simulation stalled; 2 start-up failed (bad arguments, unknown scenario,
missing node module, no simulation time within ``--startup-timeout``); 130 / 143 stopped by
SIGINT (Ctrl-C) / SIGTERM. See doc/bringup.md.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import math
import os
import signal
import sys
import time
import traceback
from pathlib import Path
from typing import Any

from safe_legged_c3bf.run.console import Progress, StopRequest, progress_text, say
from safe_legged_c3bf.run.graph import GRAPH_NODES, LAST_NODE
from safe_legged_c3bf.run.outcome import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_SIGNAL,
    EXIT_STARTUP,
    Outcome,
    StartupError,
)
from safe_legged_c3bf.run.parameters import merged_parameters
from safe_legged_c3bf.run.plan import RunPlan, make_plan
from safe_legged_c3bf.run.quiet_stderr import stderr_to_file
from safe_legged_c3bf.run.report import format_summary, write_run_folder
from safe_legged_c3bf.run.supervisor import (
    ManagedProcess,
    Supervisor,
    describe_returncode,
)

DEFAULT_SCENARIO = "quadruped_default"
HOUSEKEEPING_PERIOD = 0.1
#: Sim seconds a --stop-on-outcome run goes on after its deciding event (data to plot).
OUTCOME_HOLD = 1.0
#: After a node dies or freezes, the run goes on this long (sim s; at most the wall s) so the
#: report shows the remaining graph's fail-safe (the robot stopping) before the run ends.
FAILURE_WATCH_SIM, FAILURE_WATCH_WALL = 2.0, 10.0


# ------------------------------------------------------------------------------ arguments


def build_parser() -> argparse.ArgumentParser:
    """The bringup's command line."""
    p = argparse.ArgumentParser(
        prog="python -m safe_legged_c3bf.bringup",
        description="Run the safe_legged_c3bf node graph on a scenario and report on it.",
        epilog="Exit codes: 0 run completed (even with a collision: see the report), 1 a node "
        "died, 2 start-up failed, 130/143 interrupted by SIGINT/SIGTERM.",
    )
    p.add_argument("--scenario", default=DEFAULT_SCENARIO, metavar="NAME|PATH",
                   help=f"scenario name in config/scenarios or a YAML path "
                   f"(default {DEFAULT_SCENARIO})")
    p.add_argument("--list-scenarios", action="store_true", help="list scenario names and exit")
    p.add_argument("--gui", action="store_true", help="open the PyBullet GUI (needs a display)")
    p.add_argument("--no-filter", action="store_true",
                   help="run the safety filter disabled (pass-through), for comparison")
    p.add_argument("--in-process", action="store_true",
                   help="compose all nodes on one executor in this process")
    p.add_argument("--record", metavar="FILE.mcap", type=Path,
                   help="record every contract topic to an MCAP file (Foxglove, ros2 bag)")
    p.add_argument("--video", metavar="FILE.gif|.mp4", type=Path,
                   help="write the simulator's follow-camera video (headless)")
    p.add_argument("--video-fps", type=float, default=10.0, metavar="FPS",
                   help="video frames per simulated second (default 10)")
    p.add_argument("--lockstep", action=argparse.BooleanOptionalAction, default=True,
                   help="the simulator waits for the gait controller's command of every state "
                   "(default: on, so a slow machine slows the run down instead of starving "
                   "the controller and dropping the robot; --no-lockstep paces physics by "
                   "the wall clock alone)")
    p.add_argument("--real-time-factor", type=float, metavar="X",
                   help="simulator pacing: sim seconds per wall second (0 = as fast as "
                   "possible; default the simulator's, 1)")
    p.add_argument("--duration", type=float, metavar="S",
                   help="override the scenario duration (s, sim time)")
    p.add_argument("--seed", type=int, metavar="N", help="override the scenario seed")
    p.add_argument("--stop-on-outcome", action="store_true",
                   help="end the run once its outcome is settled: "
                   f"{OUTCOME_HOLD:g} s (sim) after the goal is reached, the first collision "
                   "or a fall (evaluations use it; default: run the whole duration)")
    p.add_argument("--domain-id", type=int, metavar="N",
                   help="use this ROS_DOMAIN_ID as is (default: lease a private one, "
                   "localhost only)")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="run folder (default runs/<scenario>-<timestamp>/)")
    p.add_argument("--remap", action="append", default=[], metavar="FROM:=TO",
                   help="topic remapping applied to every node (repeatable)")
    p.add_argument("--node", action="append", default=[], metavar="NAME=MODULE",
                   help="run MODULE instead of the standard module for node NAME (repeatable)")
    p.add_argument("--executor", choices=("single", "multi"), default="single",
                   help="executor for --in-process (default single)")
    p.add_argument("--startup-timeout", type=float, default=60.0, metavar="S",
                   help="wall seconds to wait for simulation time to start (default 60)")
    p.add_argument("--stall-timeout", type=float, default=30.0, metavar="S",
                   help="wall seconds without simulation progress before giving up "
                   "(default 30)")
    p.add_argument("--progress-period", type=float, metavar="S",
                   help="seconds between progress lines (default 0.25 on a terminal, where "
                   "the line is rewritten in place, else 5)")
    p.add_argument("--verbose", "-v", action="store_true",
                   help="also print the nodes' log lines (they always go to <out>/logs/)")
    return p


# ------------------------------------------------------------------------------ running


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


def _rclpy_parameters(values: dict[str, Any]) -> list:
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


def _remap_args(remaps: list[str]) -> list[str]:
    args: list[str] = []
    for r in remaps:
        args += ["-r", r]
    return ["--ros-args", *args] if args else []


class Bringup:
    """One run: starts the nodes, watches them and the monitor, stops everything."""

    def __init__(self, opts: argparse.Namespace, plan: RunPlan) -> None:
        """Prepare a run of ``plan``."""
        self.opts = opts
        self.plan = plan
        self.progress = Progress(period=opts.progress_period)
        self.stop_request = StopRequest()
        self.supervisor: Supervisor | None = None
        self.processes: dict[str, ManagedProcess] = {}
        self.in_process_nodes: list = []
        self.monitor = None
        self.executor = None
        self.wall_start = time.monotonic()
        self.outcome = Outcome()

    # -- start ---------------------------------------------------------------------------------
    def _check_modules(self) -> None:
        specs = list(self.plan.specs) + ([self.plan.recorder] if self.plan.recorder else [])
        missing = [f"{s.name} ({s.module})" for s in specs if not s.module_available()]
        if missing:
            raise StartupError(
                "node module(s) not installed: " + ", ".join(missing)
                + ". Reinstall the package (pip install -e .) or check --node."
            )

    def _start_processes(self, env: dict[str, str]) -> None:
        self.supervisor = Supervisor(self.plan.run_dir / "logs", env)
        remap = [arg for r in self.plan.remaps for arg in ("-r", r)]
        first = [s for s in self.plan.specs if s.name != LAST_NODE]
        last = [s for s in self.plan.specs if s.name == LAST_NODE]
        if self.plan.recorder is not None:
            first.insert(0, self.plan.recorder)  # record from the very first message
        for batch in (first, last):
            for spec in batch:
                if self.stop_request:
                    return
                spec.ros_args = [*spec.ros_args, *remap]
                echo = self._echo_line(spec.name) if self.opts.verbose else None
                self.processes[spec.name] = self.supervisor.start(spec, echo=echo)
            if batch is first and last:
                self._wait_for_nodes(len(first))

    def _wait_for_nodes(self, count: int, timeout: float = 30.0) -> None:
        """Spin until ``count`` nodes besides the monitor are in the graph (or one died).

        Physics starts with the gait controller's first command, so the gait controller is
        started only once the other nodes are up: all of them see the run from t = 0.
        """
        deadline = time.monotonic() + min(timeout, self.opts.startup_timeout)
        own = self.monitor.get_name()
        while time.monotonic() < deadline and not self.stop_request:
            names = {n for n in self.monitor.get_node_names() if n != own}
            if len(names) >= count:
                return
            if any(p.poll() is not None for p in self.processes.values()):
                return  # the watch loop reports it
            self.progress.update(f"starting nodes: {len(names)} of {count} up")
            self.executor.spin_once(timeout_sec=0.05)
        if not self.stop_request:
            say(self.progress, f"only {len(names)} of {count} nodes visible after "
                 f"{min(timeout, self.opts.startup_timeout):g} s; starting {LAST_NODE} anyway")

    def _echo_line(self, name: str):  # noqa: ANN202
        def echo(line: str) -> None:
            self.progress.clear()
            print(f"[{name}] {line}", file=sys.stderr, flush=True)

        return echo

    def _start_in_process(self) -> None:
        from safe_legged_c3bf.run.recorder import RecorderNode

        cli = _remap_args(self.plan.remaps)
        if self.plan.recorder is not None:
            node = RecorderNode(self.plan.recorder.args[0], cli_args=cli or None)
            self.in_process_nodes.append(("recorder", node))
            self.executor.add_node(node)
        for spec in self.plan.specs:
            if self.stop_request:
                return
            cls = find_node_class(spec.module)
            try:
                node = cls(
                    parameter_overrides=_rclpy_parameters(merged_parameters(spec)),
                    cli_args=cli or None,
                )
            except Exception as err:
                raise StartupError(
                    f"{spec.name} ({spec.module}) failed to start: {err!r}\n"
                    + "".join(traceback.format_exc(limit=-4))
                ) from None
            self.in_process_nodes.append((spec.name, node))
            self.executor.add_node(node)

    # -- watch ---------------------------------------------------------------------------------
    def _check_processes(self) -> bool:
        """Handle exited children; return True when the run is over."""
        if self.supervisor is None:
            return False
        for proc in self.supervisor.newly_exited():
            code = proc.poll()
            if proc.name == "simulator" and code == 0:
                self.outcome = Outcome("completed", "the simulator finished the scenario")
                return True
            lines = proc.last_lines()
            self.outcome = Outcome(
                "node_died",
                f"node {proc.name} (pid {proc.pid}) {describe_returncode(code)}",
                EXIT_FAILED, proc.name, lines,
            )
            return True
        for proc in self.supervisor.running():
            if proc.frozen():
                self.outcome = Outcome(
                    "node_died",
                    f"node {proc.name} (pid {proc.pid}) is frozen (stopped by a signal)",
                    EXIT_FAILED, proc.name, [],
                )
                return True
        return False

    def _finish_grace(self) -> float:
        return 30.0 if self.opts.video is not None else 5.0

    def run(self) -> int:
        """Start everything, watch until done, stop, report; return the exit code."""
        import rclpy
        from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        from safe_legged_c3bf.run.monitor import MonitorNode

        plan, opts = self.plan, self.opts
        env = dict(os.environ)
        self._check_modules()
        rclpy.init(args=None, signal_handler_options=SignalHandlerOptions.NO)
        redirect = None
        try:
            if opts.in_process and not opts.verbose:
                redirect = stderr_to_file(plan.run_dir / "logs" / "in_process.log")
            self.monitor = MonitorNode(cli_args=_remap_args(plan.remaps) or None)
            self.monitor.goal = plan.context.goal
            self.monitor.goal_tolerance = plan.context.goal_tolerance
            if opts.in_process and opts.executor == "multi":
                self.executor = MultiThreadedExecutor(num_threads=4)
            else:
                self.executor = SingleThreadedExecutor()
            self.executor.add_node(self.monitor)
            self.wall_start = time.monotonic()
            try:
                if opts.in_process:
                    self._start_in_process()
                else:
                    self._start_processes(env)
                if not self.stop_request:
                    self._watch()
                if self._done:
                    self._drain()
            except StartupError as err:
                self.outcome = Outcome("startup_failed", str(err), EXIT_STARTUP)
            except Exception as err:  # noqa: BLE001 - a node raised inside the executor
                self.outcome = self._callback_failure(err)
            if self.stop_request and not self._done and self.outcome.kind in (
                "completed", "startup_failed"
            ):
                sig = self.stop_request.signum
                self.outcome = Outcome(
                    "interrupted", f"stopped by {signal.Signals(sig).name}",
                    EXIT_SIGNAL.get(sig, 128 + sig),
                )
            self._stop_all()
            if redirect is not None:
                redirect.restore()
                redirect = None
            return self._finish()
        finally:
            if redirect is not None:
                redirect.restore()
            self.stop_request.restore()
            if self.executor is not None:
                self.executor.shutdown(timeout_sec=1.0)
            self._destroy_in_process_nodes()
            if self.monitor is not None:
                self.monitor.destroy_node()
            rclpy.try_shutdown()

    def _drain(self, timeout: float = 2.0) -> None:
        """Let the monitor (and an in-process recorder) catch up with the last messages."""
        deadline = time.monotonic() + (0.3 if self._stopped_early else timeout)
        target = self.plan.context.duration - 1e-3
        while time.monotonic() < deadline and not self.stop_request:
            if self.monitor.sim_time is not None and self.monitor.sim_time >= target:
                break
            self.executor.spin_once(timeout_sec=0.05)

    def _destroy_in_process_nodes(self) -> None:
        """Destroy the composed nodes, last started first (the simulator writes its summary)."""
        while self.in_process_nodes:
            name, node = self.in_process_nodes.pop()
            try:
                if self.executor is not None:
                    self.executor.remove_node(node)
                node.destroy_node()
            except Exception as err:  # noqa: BLE001 - report and go on stopping the rest
                say(None, f"{name}: error while stopping: {err!r}")

    _done = False
    _stopped_early = False

    def _watch(self) -> None:
        plan, opts, monitor = self.plan, self.opts, self.monitor
        duration = plan.context.duration
        started_at: float | None = None
        reached_at: float | None = None
        last_progress_sim, last_progress_wall = -math.inf, time.monotonic()
        last_check = -math.inf
        failed: tuple[float, float] | None = None  # (sim, wall) time a node was found dead
        while not self.stop_request:
            self.executor.spin_once(timeout_sec=0.05)
            now = time.monotonic()
            if now - last_check < HOUSEKEEPING_PERIOD:
                continue  # keep up with the message stream; check the run 10 times a second
            last_check = now
            t = monitor.sim_time
            if t is not None and t > 0 and started_at is None:
                started_at = now  # physics runs (the simulator waits for a first command)
            if t is not None and t > last_progress_sim:
                last_progress_sim, last_progress_wall = t, now
            duration_reached = t is not None and t >= duration - 1e-6
            if duration_reached and reached_at is None:
                reached_at = now
            if failed is None and self._check_processes():
                self._done = self.outcome.kind == "completed"
                if self.outcome.kind != "node_died" or self.outcome.failed_node == "simulator":
                    return
                # Keep the simulator running a little: the report shows the fail-safe at work
                # (the robot stopping without the dead node) from ground truth.
                failed = (t if t is not None else 0.0, now)
                say(self.progress, f"{self.outcome.reason}: watching the fail-safe for "
                     f"{FAILURE_WATCH_SIM:g} s of sim time")
            if failed is not None:
                if (t is not None and t >= failed[0] + FAILURE_WATCH_SIM) or (
                        now - failed[1] > FAILURE_WATCH_WALL):
                    return
                continue
            if self._in_process_finished():
                self.outcome = Outcome("completed", "the simulator finished the scenario")
                self._done = True
                return
            settled = monitor.decided(OUTCOME_HOLD) if opts.stop_on_outcome else None
            if settled is not None:
                self.outcome = Outcome("completed", settled)
                self._done = self._stopped_early = True
                return
            if reached_at is not None and (
                self.supervisor is None or now - reached_at > self._finish_grace()
            ):
                self.outcome = Outcome("completed", "scenario duration reached")
                self._done = True
                return
            if started_at is None and now - self.wall_start > opts.startup_timeout:
                what = (
                    "no message from the simulator" if t is None
                    else "simulation time still 0 (no joint command reached the simulator)"
                )
                self.outcome = Outcome(
                    "startup_failed",
                    f"{what} after {opts.startup_timeout:g} s; nodes seen: "
                    f"{', '.join(sorted(set(monitor.get_node_names()))) or 'none'}",
                    EXIT_STARTUP,
                )
                return
            if (started_at is not None and reached_at is None
                    and now - last_progress_wall > opts.stall_timeout):
                self.outcome = Outcome(
                    "stalled", f"simulation time stuck at {last_progress_sim:.2f} s for "
                    f"{opts.stall_timeout:g} s", EXIT_FAILED,
                )
                return
            self.progress.update(progress_text(monitor, duration))

    def _in_process_finished(self) -> bool:
        return any(
            name == "simulator" and bool(getattr(node, "finished", False))
            for name, node in self.in_process_nodes
        )

    def _callback_failure(self, err: BaseException) -> Outcome:
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

    # -- stop ----------------------------------------------------------------------------------
    def _stop_all(self) -> None:
        if self.supervisor is None:
            self._destroy_in_process_nodes()
            return
        deadline = time.monotonic() + 4.5
        graph = [p for name, p in self.processes.items() if name != "recorder"]
        recorder = [p for name, p in self.processes.items() if name == "recorder"]
        escalated = self.supervisor.stop(graph, deadline=deadline - 1.0 if recorder else deadline)
        if recorder:
            escalated += self.supervisor.stop(recorder, deadline=deadline)
        for proc in escalated:
            self.outcome.details.append(
                f"{proc.name} did not stop on SIGINT: {describe_returncode(proc.poll())}"
            )

    # -- report --------------------------------------------------------------------------------
    def _finish(self) -> int:
        import json

        self.progress.clear()
        plan, outcome = self.plan, self.outcome
        ctx = plan.context
        ctx.wall_time = time.monotonic() - self.wall_start
        ctx.outcome, ctx.reason = outcome.kind, outcome.reason
        if outcome.kind == "node_died":
            label = "traceback" if self.supervisor is None else "last lines of its stderr"
            say(None, outcome.reason + (
                f"; {label}:" if outcome.details else " (no stderr output)"))
            for line in outcome.details:
                print(f"    {line}", file=sys.stderr)
            log = plan.run_dir / "logs" / f"{outcome.failed_node}.log"
            if log.exists():
                print(f"  full log: {log}", file=sys.stderr)
            print("bringup: stopped the other nodes", file=sys.stderr, flush=True)
        elif outcome.kind != "completed":
            say(None, f"{outcome.kind.replace('_', ' ')}: {outcome.reason}")
        extra: dict[str, Any] = {
            "exit_code": outcome.exit_code,
            "command": sys.argv,
            "ros_domain_id": os.environ.get("ROS_DOMAIN_ID"),
            "scenario_file": str(plan.scenario_file),
            "nodes": {
                name: {"pid": p.pid, "module": p.spec.module,
                       "exit": describe_returncode(p.poll()), "log": str(p.log_path)}
                for name, p in self.processes.items()
            } or {name: {"module": mod, "in_process": True} for name, mod in
                  ((s.name, s.module) for s in plan.specs)},
        }
        if outcome.details:
            extra["failure_details"] = outcome.details
        simulator = None
        sim_summary = plan.run_dir / "simulator_summary.json"
        if sim_summary.exists():
            try:
                simulator = json.loads(sim_summary.read_text())
            except (OSError, ValueError):
                simulator = None
        if self.opts.record is not None:
            extra["recording"] = str(self.opts.record.resolve())
        if self.opts.video is not None:
            video = self.opts.video.resolve()
            extra["video"] = str(video) if video.is_file() else None
            if not video.is_file():
                say(None, f"--video: the simulator wrote no video to {video} (its node must "
                     "support the video_path / video_fps parameters)")
        monitor = self.monitor
        report = write_run_folder(
            plan.run_dir, monitor.data, ctx, monitor.sim_time, extra, simulator
        )
        print(format_summary(report["summary"], plan.run_dir), flush=True)
        return outcome.exit_code


# ------------------------------------------------------------------------------ entry point


def _isolate(opts: argparse.Namespace):  # noqa: ANN202 - DomainLease | None
    """Choose the ROS domain for this process and every child (before rclpy starts)."""
    if opts.domain_id is not None:
        if not 0 <= opts.domain_id <= 232:
            raise StartupError("--domain-id must be in 0..232")
        os.environ["ROS_DOMAIN_ID"] = str(opts.domain_id)
        return None
    from safe_legged_c3bf.ros_domain import isolate_environment

    try:
        _, lease = isolate_environment()
    except RuntimeError as err:
        raise StartupError(str(err)) from None
    return lease


def main(args: list[str] | None = None) -> int:
    """Command-line entry point."""
    opts = build_parser().parse_args(sys.argv[1:] if args is None else args)
    if opts.list_scenarios:
        from safe_legged_c3bf.sim.scenario import available_scenarios

        print("\n".join(available_scenarios()))
        return EXIT_OK
    lease = None
    try:
        plan = make_plan(opts)
        lease = _isolate(opts)
    except StartupError as err:
        print(f"bringup: start-up failed: {err}", file=sys.stderr)
        return EXIT_STARTUP
    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    local = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST"
    print(
        f"bringup: scenario {plan.scenario.name} ({plan.context.robot}, "
        f"{plan.scenario.duration:g} s sim), "
        f"filter {'on' if plan.context.filter_enabled else 'OFF'}, "
        f"{'in-process' if opts.in_process else 'one process per node'}\n"
        f"bringup: ROS domain {domain}{' (localhost only)' if local else ''}; watch with "
        f"`python -m safe_legged_c3bf.echo /cmd_vel_safe --domain-id {domain}`\n"
        f"bringup: run folder {plan.run_dir}",
        flush=True,
    )
    try:
        return Bringup(opts, plan).run()
    except StartupError as err:
        print(f"bringup: start-up failed: {err}", file=sys.stderr)
        return EXIT_STARTUP
    finally:
        if lease is not None:
            lease.release()


if __name__ == "__main__":
    raise SystemExit(main())
