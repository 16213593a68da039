"""ROS 2 bridge of the PyBullet world: the ``simulator`` node.

A thin wrapper around :class:`safe_legged_c3bf.sim.world.Simulation`:

* physics runs in the node's own thread, one state period (1 / ``state_rate``) at a time,
  paced to ``real_time_factor`` against the steady wall clock (0 = as fast as possible). The
  node never blocks an executor: the executor it is added to only runs its diagnostics timer,
  so it can share an executor (and a process) with other nodes, or run as its own process
  (``simulator`` console script). The world is used under :attr:`SimulatorNode.lock`.
* ``/joint_commands`` (MotorCommand) is read by the physics thread itself, from a subscription
  of a helper node ``<name>_motor_drivers`` that is never added to an executor: commands are
  taken before every physics step (between periods in lockstep mode) and handed to the
  emulated motor drivers; rejected ones (non-finite, negative gains, unknown joints, wrong
  sizes) are counted and reported in ``/diagnostics``. Why not an executor callback and a
  wall timer: at the 500 Hz of states and commands, rclpy's executor costs more CPU per
  wake-up than a physics step, and commands keep reaching the drivers when a shared executor
  is busy.
* publishes in sim time ``/imu`` and ``/joint_states`` (every state period), ``/odom`` and
  ``/clock`` (every round(``state_rate`` / ``odom_rate``) and round(``state_rate`` /
  ``clock_rate``) state periods, so the rates are rounded: 125 Hz for the requested 100 Hz
  at the A1's 250 Hz state rate, 100 Hz at the biped's 200 Hz; logged at start; /clock
  stamped like the state
  published with it), ``/obstacles/detections`` (noisy, no velocities),
  ``/ground_truth/safety`` and ``/ground_truth/obstacles``, and ``/diagnostics`` (motor driver
  mode, rejected commands, lockstep timeouts; WARN while the drivers damp after a command
  timeout). The messages that change only in a few numbers (/clock, /odom, /imu,
  /joint_states, /ground_truth/obstacles) are serialized once and patched in place
  (:mod:`safe_legged_c3bf.nodes.simulator.cdr_template`);
* before the first command (``wait_for_first_command``) physics does not advance: /clock and
  the state at t = 0 are republished at 10 Hz so controllers in slow-to-discover processes
  can start;
* stops when the scenario duration is reached: writes the JSON summary to ``summary_path``,
  logs it, sets :attr:`SimulatorNode.finished` (after the file is written) and publishes a
  final diagnostics status with message 'finished'; ``exit_on_finish`` then shuts the ROS
  context down (standalone process);
* optionally renders the follow camera every 1 / ``video_fps`` sim seconds and writes the
  frames to ``video_path`` (GIF or MP4, :mod:`safe_legged_c3bf.sim.video`). In-process, a
  bringup can instead call ``node.simulation.record_every(n)`` and ``node.take_frames()``.

Lockstep mode (``lockstep: true``), for deterministic runs: one control period = one state
period (1 / ``state_rate``). After publishing the state stamped S, physics waits until a
MotorCommand whose header.stamp >= S has arrived, applies it at sim time S and advances one
period; commands stamped before S (computed from an older state, e.g. answers to the
repeated t = 0 state) are ignored and counted. If no command arrives within
``lockstep_timeout`` wall seconds, a warning is logged, the timeout counted
(``lockstep_timeouts`` in the summary) and physics advances with the previous command.

What is deterministic: a lockstep run with no lockstep timeouts, deterministic controllers
that send one command per state, and the same scenario, seed and parameters is reproducible
bit for bit (physics, obstacle motion, perception noise and drop-outs drawn at fixed sim
times, ground truth). What is not: outside lockstep, when a command takes effect relative to
the physics steps depends on process scheduling and DDS latency, so the robot's motion is not
reproducible (the obstacle motion and the sequence of perception noise draws still are); the
wall-time entries of the summary are never reproducible.
"""

from __future__ import annotations

import json
import math
import sys
import threading
import time
import traceback
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from safe_legged_c3bf import topics
from safe_legged_c3bf.nodes.ros_common import diagnostic_status, run_node, to_time_msg
from safe_legged_c3bf.nodes.simulator.command_bus import CommandBus
from safe_legged_c3bf.nodes.simulator.detection_publisher import DetectionPublisher
from safe_legged_c3bf.nodes.simulator.ground_truth_publisher import GroundTruthPublisher
from safe_legged_c3bf.nodes.simulator.parameters import PARAMETERS, LoopSettings, declare_parameters
from safe_legged_c3bf.nodes.simulator.quiet_publisher import quiet_publisher
from safe_legged_c3bf.nodes.simulator.state_publisher import StatePublisher
from safe_legged_c3bf.sim.motor_driver import DriverMode
from safe_legged_c3bf.sim.scenario import ScenarioError
from safe_legged_c3bf.sim.world import Simulation
from safe_legged_c3bf_msgs.msg import MotorCommand

_IDLE_PUBLISH_PERIOD = 0.1  # wall s between state republications while waiting


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class SimulatorNode(Node):
    """The simulator bridge node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        """Create the node; ``kwargs`` go to rclpy's Node (context, parameter_overrides...)."""
        super().__init__("simulator", **kwargs)
        p = declare_parameters(self)
        self._params = p
        physics_dt = 1.0 / float(p["physics_rate"])
        seed = int(p["seed"])
        self._sim = Simulation(
            str(p["scenario"]),
            physics_dt=physics_dt,
            gui=bool(p["gui"]),
            seed=None if seed < 0 else seed,
            command_timeout=float(p["command_timeout"]),
            damping_kd=float(p["damping_kd"]),
        )
        sim = self._sim
        settings = LoopSettings.from_parameters(p, sim.scenario.perception.rate)
        self._settings = settings
        self._rtf = settings.real_time_factor
        self._lockstep = settings.lockstep
        self._lockstep_timeout = settings.lockstep_timeout
        self._summary_path = str(p["summary_path"])
        self._exit_on_finish = bool(p["exit_on_finish"])
        self._state_every = settings.state_every
        self._clock_every = settings.clock_every
        self._odom_every = settings.odom_every
        self._gt_every = settings.ground_truth_every
        self._det_every = settings.detection_every
        self._max_lag = settings.max_lag

        self._state = StatePublisher(self, sim, settings.clock_every, settings.odom_every)
        self._detections = DetectionPublisher(self, sim, bool(p["strip_detection_ids"]))
        self._truth = GroundTruthPublisher(self, sim)
        self._pub_diag = quiet_publisher(self, topics.DIAGNOSTICS)
        self._bus = CommandBus(self, self._take_command, kwargs.get("cli_args"))
        #: Held by the physics thread while it uses the world; hold it to use
        #: :attr:`simulation` from another thread while the node runs.
        self.lock = threading.RLock()
        self._stop = threading.Event()
        self._error: str | None = None

        self._finished = False
        self._summary_written = False
        self._finished_callbacks: list[Callable[[SimulatorNode], None]] = []
        self._waiting = bool(p["wait_for_first_command"])
        self._await_stamp: int | None = None
        self._await_since = 0.0
        self.lockstep_timeouts = 0
        self.stale_commands = 0
        self._anchor: tuple[float, float] | None = None  # (wall, sim) of the pacing
        self._wall_start: float | None = None
        self._wall_end: float | None = None
        self._last_idle_publish = -math.inf
        self._last_state_stamp = 0
        self._last_mode = sim.driver_mode
        self._last_reject_warning = -math.inf
        self._video = None
        if p["video_path"]:
            from safe_legged_c3bf.sim.video import VideoWriter, frame_interval_steps

            self._video = VideoWriter(str(p["video_path"]), float(p["video_fps"]))
            sim.record_every(frame_interval_steps(float(p["video_fps"]), physics_dt))

        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diag_timer = self.create_timer(
            float(p["diagnostics_period"]), self._publish_diagnostics, clock=steady
        )
        self._publish_state()
        self._publish_ground_truth()
        self._last_idle_publish = time.monotonic()
        if not self._waiting:
            self._start_running()
            if self._lockstep:  # the t = 0 state needs its command too
                self._await_stamp, self._await_since = 0, time.monotonic()
        self.get_logger().info(
            f"scenario '{sim.scenario.name}' ({sim.scenario.robot.model}, "
            f"{len(sim.obstacles)} obstacles, {sim.scenario.duration:g} s), "
            f"{settings.describe()}, real_time_factor "
            f"{self._rtf:g}, lockstep {self._lockstep}"
            + (", waiting for the first command" if self._waiting else "")
        )
        self._thread = threading.Thread(target=self._run, name="simulator_physics", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ public API

    @property
    def simulation(self) -> Simulation:
        """The underlying world (for the bringup: camera frames, summary, state)."""
        return self._sim

    @property
    def finished(self) -> bool:
        """True once the scenario duration has been reached (summary written, physics stopped)."""
        return self._finished

    @property
    def error(self) -> str | None:
        """Why the physics thread stopped on an exception (None while healthy)."""
        return self._error

    @property
    def waiting_for_command(self) -> bool:
        """True while physics is held at t = 0 waiting for the first command."""
        return self._waiting

    def add_finished_callback(self, callback: Callable[[SimulatorNode], None]) -> None:
        """Call ``callback(node)`` once when the scenario ends (immediately if it has).

        The call comes from the physics thread, with :attr:`lock` held.
        """
        with self.lock:
            if self._finished:
                callback(self)
            else:
                self._finished_callbacks.append(callback)

    def summary(self) -> dict[str, Any]:
        """The run summary (as written to ``summary_path``)."""
        with self.lock:
            return self._sim.summary(self._summary_extra())

    def take_frames(self) -> list:
        """Camera frames recorded since the last call (see ``Simulation.record_every``)."""
        with self.lock:
            return self._sim.take_frames()

    def _summary_extra(self) -> dict[str, Any]:
        wall = None
        if self._wall_start is not None:
            wall = (self._wall_end or time.monotonic()) - self._wall_start
        return {
            "lockstep": self._lockstep,
            "lockstep_timeouts": self.lockstep_timeouts,
            "stale_commands_ignored": self.stale_commands,
            "real_time_factor": self._rtf,
            "wall_time": wall,
            "achieved_real_time_factor": (self._sim.time / wall) if wall else None,
        }

    def destroy_node(self) -> None:
        """Stop physics, write the summary (if not yet written), close the world and node."""
        self._stop.set()
        self._bus.wake()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=10.0)
        self._bus.destroy()
        with self.lock:
            if not self._summary_written:
                self._write_summary()
            self._flush_video(close=True)
            self._sim.close()
        super().destroy_node()

    # ------------------------------------------------------------------ callbacks

    def _start_running(self) -> None:
        self._waiting = False
        now = time.monotonic()
        self._wall_start = now
        self._anchor = (now, self._sim.time)

    def _drain_commands(self) -> None:
        self._bus.drain()

    def _take_command(self, msg: MotorCommand) -> None:
        if self._finished:
            return
        sim = self._sim
        stamp = _stamp_ns(msg.header.stamp)
        if self._lockstep and not self._waiting and stamp < self._last_state_stamp:
            # Computed from an older state than the last one published: applying it would
            # make the run depend on message timing.
            self.stale_commands += 1
            return
        accepted = sim.set_command_arrays(msg.name, msg.q, msg.dq, msg.kp, msg.kd, msg.tau)
        if not accepted:
            now = time.monotonic()
            if now - self._last_reject_warning > 1.0:
                self._last_reject_warning = now
                self.get_logger().warn(
                    f"rejected a MotorCommand (non-finite, negative gains, unknown joints or "
                    f"array sizes); {sim.rejected_commands} rejected so far"
                )
            return
        if self._waiting:
            self.get_logger().info("first MotorCommand received: physics starts")
            self._start_running()
        if self._await_stamp is not None and stamp >= self._await_stamp:
            self._await_stamp = None

    # ------------------------------------------------------------------ physics thread

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                action, delay = self._cycle()
                if action == "stop":
                    break
                if action == "wait":  # for a command (or the lockstep timeout)
                    self._bus.wait(delay)
                elif delay > 0.0:  # for the wall time of the next period
                    time.sleep(delay)
                else:
                    time.sleep(0)  # hand the GIL to the executor's thread
        except Exception as exc:  # noqa: BLE001 - reported, then the thread ends
            if self.context.ok() and not self._stop.is_set():
                self._error = f"{type(exc).__name__}: {exc}"
                self.get_logger().error(
                    f"physics thread stopped: {self._error}\n{traceback.format_exc()}"
                )
                try:
                    self._publish_diagnostics()
                except Exception:  # noqa: BLE001 - the context may be gone already
                    pass

    def _cycle(self) -> tuple[str, float]:
        """One turn of the physics thread: take commands, then wait or advance one period.

        Returns ('stop', 0), ('wait', timeout) for a command, ('sleep', delay) until the
        next period is due, or ('go', 0) to go on at once.
        """
        with self.lock:
            self._drain_commands()
            if self._finished or self._stop.is_set():
                return "stop", 0.0
            now = time.monotonic()
            if self._waiting:
                if now - self._last_idle_publish >= _IDLE_PUBLISH_PERIOD:
                    self._last_idle_publish = now
                    self._publish_state()
                return "wait", _IDLE_PUBLISH_PERIOD
            if self._await_stamp is not None:
                remaining = self._lockstep_timeout - (now - self._await_since)
                if remaining > 0.0:
                    return "wait", min(remaining, 0.1)
                self.lockstep_timeouts += 1
                self.get_logger().warn(
                    f"lockstep: no MotorCommand for the state at t={self._sim.time:.3f} s "
                    f"within {self._lockstep_timeout:g} s; advancing with the previous "
                    f"command ({self.lockstep_timeouts} timeouts: this run is not "
                    "deterministic)",
                    throttle_duration_sec=5.0,
                )
                self._await_stamp = None
                self._anchor = (now, self._sim.time)
            if self._rtf > 0.0:
                delay = self._pacing_delay(now)
                if delay > 0.0:
                    return "sleep", delay
                if -delay > self._max_lag:  # cannot keep up: stop catching up
                    self._anchor = (now, self._sim.time)
            self._advance(self._steps_to_boundary())
            if self._finished:
                return "stop", 0.0
            if self._rtf > 0.0 and self._await_stamp is None:
                # Sleep until the next period is due right away; the commands that arrive
                # meanwhile are taken when it starts.
                delay = self._pacing_delay(time.monotonic())
                if delay > 0.0:
                    return "sleep", delay
            return "go", 0.0

    def _pacing_delay(self, now: float) -> float:
        """Wall time (s) until the period starting at the current sim time is due (< 0: late)."""
        assert self._anchor is not None
        wall0, sim0 = self._anchor
        return wall0 + (self._sim.time - sim0) / self._rtf - now

    def _steps_to_boundary(self) -> int:
        return self._state_every - self._sim.step_count % self._state_every

    def _advance(self, steps: int) -> None:
        sim = self._sim
        for i in range(steps):
            # Lockstep: commands only between periods. The first step's commands were just
            # taken by the caller.
            if i and not self._lockstep:
                self._drain_commands()
            sim.step(1)
            k = sim.step_count
            at_boundary = k % self._state_every == 0
            if at_boundary:
                self._publish_state()
            if k % self._gt_every == 0:
                self._publish_ground_truth()
            if k % self._det_every == 0:
                self._publish_detections()
            if sim.finished:
                self._finish()
                return
            if self._lockstep and at_boundary:
                self._await_stamp = self._last_state_stamp
                self._await_since = time.monotonic()
        if self._video is not None:
            self._flush_video()
        mode = sim.driver_mode
        if mode is not self._last_mode:
            if mode is DriverMode.DAMPING:
                self.get_logger().warn(
                    f"no MotorCommand for {sim.driver.timeout:g} s (sim time): motor drivers "
                    "switched to damping mode"
                )
            elif self._last_mode is DriverMode.DAMPING:
                self.get_logger().info("MotorCommands again: motor drivers active")
            self._last_mode = mode
            self._publish_diagnostics()

    # ------------------------------------------------------------------ publishing

    def _publish_state(self) -> None:
        self._last_state_stamp = self._state.publish(self._waiting)

    def _publish_detections(self) -> None:
        self._detections.publish()

    def _publish_ground_truth(self) -> None:
        self._truth.publish()

    def _publish_diagnostics(self) -> None:
        # Called from both threads; it only reads counters, so it takes no lock.
        sim = self._sim
        mode = sim.driver_mode
        if self._error is not None:
            level, message = "error", f"physics thread stopped: {self._error}"
        elif self._finished:
            level, message = "ok", "finished"
        elif self._waiting:
            level, message = "ok", "waiting for the first MotorCommand (physics held at t=0)"
        elif mode is DriverMode.DAMPING:
            level, message = "warn", "command timeout: motor drivers in damping mode"
        elif self._await_stamp is not None:
            level, message = "ok", "lockstep: waiting for the MotorCommand of the last state"
        else:
            level, message = "ok", "running"
        if not self._finished and self.lockstep_timeouts and level == "ok":
            level = "warn"
            message += f" ({self.lockstep_timeouts} lockstep timeouts)"
        gt = sim.ground_truth
        values = {
            "sim_time": f"{sim.time:.3f}",
            "physics_steps": sim.step_count,
            "driver_mode": mode.value,
            "commands_received": sim.commands_received,
            "rejected_commands": sim.rejected_commands,
            "driver_timeouts": sim.driver_timeouts,
            "lockstep": self._lockstep,
            "lockstep_timeouts": self.lockstep_timeouts,
            "stale_commands_ignored": self.stale_commands,
            "collision_count": gt.collision_count,
            "min_distance": f"{sim.monitor.stats.min_distance:.4f}",
            "fallen": sim.monitor.stats.fell,
            "finished": self._finished,
        }
        if self._wall_start is not None:
            wall = (self._wall_end or time.monotonic()) - self._wall_start
            if wall > 0:
                values["achieved_real_time_factor"] = f"{sim.time / wall:.3f}"
        msg = DiagnosticArray()
        msg.header.stamp = to_time_msg(sim.time)
        msg.status = [diagnostic_status("simulator", level, message, values)]
        self._pub_diag.publish(msg)

    # ------------------------------------------------------------------ end of run

    def _flush_video(self, close: bool = False) -> None:
        if self._video is None:
            return
        for frame in self._sim.take_frames():
            self._video.append(frame)
        if close:
            self._video.close()
            self.get_logger().info(
                f"video: {self._video.frames} frames written to {self._video.path}"
            )
            self._video = None

    def _write_summary(self) -> dict[str, Any]:
        extra = self._summary_extra()
        if self._summary_path:
            try:
                summary = self._sim.write_summary(self._summary_path, extra)
                self._summary_written = True
                return summary
            except OSError as exc:
                self.get_logger().error(f"cannot write summary to {self._summary_path}: {exc}")
        return self._sim.summary(extra)

    def _finish(self) -> None:
        self._wall_end = time.monotonic()
        self._flush_video(close=True)
        summary = self._write_summary()
        self._summary_written = True
        # Set only now, so whoever watches the flag finds the summary file written.
        self._finished = True
        self._publish_diagnostics()
        self.get_logger().info(
            f"scenario '{summary['scenario']}' finished at t={summary['sim_time']:.3f} s: "
            f"collisions={summary['collision_count']} min_distance={summary['min_distance']} "
            f"fell={summary['fell']} goal_reached={summary['goal_reached']}; summary: "
            + json.dumps(summary)
        )
        for callback in self._finished_callbacks:
            callback(self)
        self._finished_callbacks.clear()
        if self._exit_on_finish:
            self.context.try_shutdown()


def main(args: list[str] | None = None) -> int:
    """Console entry point ``simulator``."""
    try:
        return run_node(SimulatorNode, args)
    except (ScenarioError, ValueError) as exc:
        print(f"simulator: {exc}", file=sys.stderr)
        return 2


__all__ = ["PARAMETERS", "SimulatorNode", "main"]

if __name__ == "__main__":
    sys.exit(main())
