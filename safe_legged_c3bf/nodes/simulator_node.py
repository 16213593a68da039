"""ROS 2 bridge of the PyBullet world: the ``simulator`` node.

A thin wrapper around :class:`safe_legged_c3bf.sim.world.Simulation`, built from the parts in
:mod:`safe_legged_c3bf.nodes.simulator`; this module wires them and publishes /diagnostics.

* physics runs in the node's own thread (:mod:`~safe_legged_c3bf.nodes.simulator.physics_loop`:
  pacing to ``real_time_factor``, lockstep, the first-command wait), one state period
  (1 / ``state_rate``) at a time. The node never blocks an executor: the executor it is added
  to only runs its diagnostics timer, so it can share an executor (and a process) with other
  nodes, or run as its own process (``simulator`` console script). The world is used under
  :attr:`SimulatorNode.lock`.
* ``/joint_commands`` (MotorCommand) is read by the physics thread itself, without an executor
  (:mod:`~safe_legged_c3bf.nodes.simulator.command_bus`), and handed to the emulated motor
  drivers.
* publishes in sim time ``/imu`` and ``/joint_states`` (every state period), ``/odom`` and
  ``/clock`` (every round(``state_rate`` / ``odom_rate``) and round(``state_rate`` /
  ``clock_rate``) state periods: 125 Hz for the requested 100 Hz at the A1's 250 Hz state
  rate, 100 Hz at the biped's 200 Hz; logged at start)
  (:mod:`~safe_legged_c3bf.nodes.simulator.state_publisher`), ``/obstacles/detections``
  (noisy, no velocities) with the scenario's ``perception.source: oracle`` or, with
  ``sensors``, the range sensors' ``/scan`` and ``/points`` instead
  (:mod:`~safe_legged_c3bf.nodes.simulator.sensor_publisher`; an obstacle detector node then
  makes the detections), ``/ground_truth/safety`` and ``/ground_truth/obstacles``
  (:mod:`~safe_legged_c3bf.nodes.simulator.ground_truth_publisher`), and ``/diagnostics``
  (motor driver mode, rejected commands, lockstep timeouts; WARN while the drivers damp
  after a command timeout);
* stops when the scenario duration is reached: writes the JSON summary to ``summary_path``,
  logs it, sets :attr:`SimulatorNode.finished` (after the file is written) and publishes a
  final diagnostics status with message 'finished'; ``exit_on_finish`` then shuts the ROS
  context down (standalone process);
* optionally renders the follow camera every 1 / ``video_fps`` sim seconds and writes the
  frames to ``video_path`` (GIF or MP4, :mod:`safe_legged_c3bf.sim.video`). In-process, a
  bringup can instead call ``node.simulation.record_every(n)`` and ``node.take_frames()``.

Parameters: :class:`~safe_legged_c3bf.sim.node_params.SimulatorParams` (all fixed at start-up).
"""

from __future__ import annotations

import json
import sys
import threading
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.parameters import NodeParameters
from safe_legged_c3bf.nodes.ros_common import diagnostic_status, run_node, to_time_msg
from safe_legged_c3bf.nodes.simulator.detection_publisher import DetectionPublisher
from safe_legged_c3bf.nodes.simulator.ground_truth_publisher import GroundTruthPublisher
from safe_legged_c3bf.nodes.simulator.parameters import LoopSettings
from safe_legged_c3bf.nodes.simulator.physics_loop import PhysicsLoop
from safe_legged_c3bf.nodes.simulator.quiet_publisher import quiet_publisher
from safe_legged_c3bf.nodes.simulator.sensor_publisher import SensorPublisher
from safe_legged_c3bf.nodes.simulator.state_publisher import StatePublisher
from safe_legged_c3bf.sim.motor_driver import DriverMode
from safe_legged_c3bf.sim.node_params import SimulatorParams
from safe_legged_c3bf.sim.scenario import ScenarioError
from safe_legged_c3bf.sim.world import Simulation

__all__ = ["SimulatorNode", "main"]


class SimulatorNode(Node):
    """The simulator bridge node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        """Create the node, start physics; ``kwargs`` go to rclpy's Node (context, overrides...)."""
        super().__init__("simulator", **kwargs)
        # A bad value raises here, before the world is built; every parameter is read-only.
        self.params = NodeParameters(self, SimulatorParams)
        p = self.params.value
        physics_dt = 1.0 / float(p.physics_rate)
        seed = int(p.seed)
        self._sim = sim = Simulation(
            str(p.scenario),
            physics_dt=physics_dt,
            gui=bool(p.gui),
            seed=None if seed < 0 else seed,
            command_timeout=float(p.command_timeout),
            damping_kd=float(p.damping_kd),
        )
        perception = sim.scenario.perception
        settings = LoopSettings.from_parameters(p, perception)
        self._settings = settings
        self._summary_path = str(p.summary_path)
        self._exit_on_finish = bool(p.exit_on_finish)
        state = StatePublisher(self, sim, settings.clock_every, settings.odom_every)
        # Oracle perception: detections; sensors: /scan and /points for a detector node.
        sensors = SensorPublisher(self, sim) if perception.source == "sensors" else None
        detections = None if sensors else DetectionPublisher(self, sim,
                                                             bool(p.strip_detection_ids))
        truth = GroundTruthPublisher(self, sim)
        self._pub_diag = quiet_publisher(self, topics.DIAGNOSTICS)
        #: Held by the physics thread while it uses the world; hold it to use
        #: :attr:`simulation` from another thread while the node runs.
        self.lock = threading.RLock()
        self._finished = False
        self._summary_written = False
        self._finished_callbacks: list[Callable[[SimulatorNode], None]] = []
        self._video = self._open_video(p, physics_dt)
        self._loop = PhysicsLoop(
            self, sim, settings, self.lock,
            state=state, truth=truth, detections=detections, sensors=sensors,
            on_status=self._publish_diagnostics, on_finish=self._finish,
            on_period=self._flush_video if self._video is not None else None,
            cli_args=kwargs.get("cli_args"),
        )
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diag_timer = self.create_timer(
            float(p.diagnostics_period), self._publish_diagnostics, clock=steady
        )
        self.get_logger().info(
            f"scenario '{sim.scenario.name}' ({sim.scenario.robot.model}, "
            f"{len(sim.obstacles)} obstacles, {sim.scenario.duration:g} s), "
            f"perception from {perception.source}, {settings.describe()}, real_time_factor "
            f"{settings.real_time_factor:g}, lockstep {settings.lockstep}"
            + (", waiting for the first command" if settings.wait_for_first_command else "")
        )
        self._loop.start()

    def _open_video(self, p: SimulatorParams, physics_dt: float):  # noqa: ANN202 - VideoWriter
        """The video writer of ``video_path`` (None without), the world recording its frames."""
        if not p.video_path:
            return None
        from safe_legged_c3bf.sim.video import VideoWriter, frame_interval_steps

        video = VideoWriter(str(p.video_path), float(p.video_fps))
        self._sim.record_every(frame_interval_steps(float(p.video_fps), physics_dt))
        return video

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
        return self._loop.error

    @property
    def waiting_for_command(self) -> bool:
        """True while physics is held at t = 0 waiting for the first command."""
        return self._loop.waiting

    @property
    def lockstep_timeouts(self) -> int:
        """Lockstep periods that advanced without their command."""
        return self._loop.lockstep_timeouts

    @property
    def stale_commands(self) -> int:
        """Lockstep commands ignored because stamped before the last state."""
        return self._loop.stale_commands

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

    def destroy_node(self) -> None:
        """Stop physics, write the summary (if not yet written), close the world and node."""
        self._loop.stop()
        with self.lock:
            if not self._summary_written:
                self._write_summary()
            self._flush_video(close=True)
            self._sim.close()
        super().destroy_node()

    # ------------------------------------------------------------------ diagnostics

    def _publish_diagnostics(self) -> None:
        # Called from both threads; it only reads counters, so it takes no lock.
        sim, loop = self._sim, self._loop
        mode = sim.driver_mode
        if loop.error is not None:
            level, message = "error", f"physics thread stopped: {loop.error}"
        elif self._finished:
            level, message = "ok", "finished"
        elif loop.waiting:
            level, message = "ok", "waiting for the first MotorCommand (physics held at t=0)"
        elif mode is DriverMode.DAMPING:
            level, message = "warn", "command timeout: motor drivers in damping mode"
        elif loop.awaiting_command:
            level, message = "ok", "lockstep: waiting for the MotorCommand of the last state"
        else:
            level, message = "ok", "running"
        if not self._finished and loop.lockstep_timeouts and level == "ok":
            level = "warn"
            message += f" ({loop.lockstep_timeouts} lockstep timeouts)"
        gt = sim.ground_truth
        values = {
            "sim_time": f"{sim.time:.3f}",
            "physics_steps": sim.step_count,
            "driver_mode": mode.value,
            "commands_received": sim.commands_received,
            "rejected_commands": sim.rejected_commands,
            "driver_timeouts": sim.driver_timeouts,
            "lockstep": self._settings.lockstep,
            "lockstep_timeouts": loop.lockstep_timeouts,
            "stale_commands_ignored": loop.stale_commands,
            "collision_count": gt.collision_count,
            "min_distance": f"{sim.monitor.stats.min_distance:.4f}",
            "fallen": sim.monitor.stats.fell,
            "finished": self._finished,
        }
        wall = loop.wall_time()
        if wall is not None and wall > 0:
            values["achieved_real_time_factor"] = f"{sim.time / wall:.3f}"
        msg = DiagnosticArray()
        msg.header.stamp = to_time_msg(sim.time)
        msg.status = [diagnostic_status("simulator", level, message, values)]
        self._pub_diag.publish(msg)

    # ------------------------------------------------------------------ end of run

    def _flush_video(self, close: bool = False) -> None:
        """Append the frames recorded since the last call to the video; ``close``: finish it."""
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

    def _summary_extra(self) -> dict[str, Any]:
        """The node's entries of the summary: lockstep counters and wall time (s)."""
        wall = self._loop.wall_time()
        return {
            "lockstep": self._settings.lockstep,
            "lockstep_timeouts": self._loop.lockstep_timeouts,
            "stale_commands_ignored": self._loop.stale_commands,
            "driver_timeout_details": list(self._loop.damping_events),
            "pacing_resets": self._loop.pacing_resets,
            "pacing_lost": round(self._loop.pacing_lost, 4),
            "pacing_reset_times": list(self._loop.pacing_reset_times),
            "real_time_factor": self._settings.real_time_factor,
            "wall_time": wall,
            "achieved_real_time_factor": (self._sim.time / wall) if wall else None,
        }

    def _write_summary(self) -> dict[str, Any]:
        """Write the summary to ``summary_path`` (if set; errors are logged) and return it."""
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
        """End of the scenario (physics thread): video, summary, 'finished', callbacks."""
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


if __name__ == "__main__":
    sys.exit(main())
