"""The simulator's physics thread: pacing, lockstep, and the motor commands it waits for.

Physics runs in its own thread, one state period (``state_every`` physics steps) at a time,
paced to ``real_time_factor`` against the steady wall clock (0 = as fast as possible); if it
falls more than ``max_lag`` wall seconds behind the schedule it stops catching up (and runs
slower than real time). The world is used under ``lock``. MotorCommands come from the
:class:`~safe_legged_c3bf.nodes.simulator.command_bus.CommandBus`: taken before every physics
step (between periods in lockstep mode) and handed to the emulated motor drivers; rejected
ones (non-finite, negative gains, unknown joints, wrong sizes) are counted by the world.

Before the first command (``wait_for_first_command``) physics does not advance: /clock and
the state at t = 0 are republished every 0.1 wall s so controllers in slow-to-discover
processes can start.

Lockstep mode (``lockstep``), for deterministic runs: one control period = one state period.
After publishing the state stamped S, physics waits until a MotorCommand whose header.stamp
>= S has arrived, applies it at sim time S and advances one period; commands stamped before
S (computed from an older state, e.g. answers to the repeated t = 0 state) are ignored and
counted (:attr:`PhysicsLoop.stale_commands`). If no command arrives within
``lockstep_timeout`` wall seconds, a warning is logged, the timeout counted
(:attr:`PhysicsLoop.lockstep_timeouts`) and physics advances with the previous command.

What is deterministic: a lockstep run with no lockstep timeouts, deterministic controllers
that send one command per state, and the same scenario, seed and parameters is reproducible
bit for bit (physics, obstacle motion, perception noise and drop-outs drawn at fixed sim
times, the range sensors' casts at fixed sim steps, ground truth). What is not: outside
lockstep, when a command takes effect relative to the physics steps depends on process
scheduling and DDS latency, so the robot's motion is not reproducible (the obstacle motion
and the sequence of perception noise draws still are); the wall times are never
reproducible.
"""

from __future__ import annotations

import math
import threading
import time
import traceback
from collections.abc import Callable
from typing import Any

from rclpy.node import Node

from safe_legged_c3bf.nodes.simulator.command_bus import CommandBus
from safe_legged_c3bf.nodes.simulator.detection_publisher import DetectionPublisher
from safe_legged_c3bf.nodes.simulator.ground_truth_publisher import GroundTruthPublisher
from safe_legged_c3bf.nodes.simulator.parameters import LoopSettings
from safe_legged_c3bf.nodes.simulator.sensor_publisher import SensorPublisher
from safe_legged_c3bf.nodes.simulator.state_publisher import StatePublisher
from safe_legged_c3bf.sim.motor_driver import DriverMode
from safe_legged_c3bf.sim.world import Simulation
from safe_legged_c3bf_msgs.msg import MotorCommand

_IDLE_PUBLISH_PERIOD = 0.1  # wall s between state republications while waiting
THREAD_NAME = "simulator_physics"


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class PhysicsLoop:
    """Steps the world in its own thread and publishes at the step intervals of ``settings``.

    Publishes the state, ground truth and either the detections (oracle perception) or the
    range sensors' data (sensor perception), each after the physics step its interval ends on.
    Calls back from the physics thread, with ``lock`` held: ``on_period()`` after every
    state period (None: nothing to do), ``on_status()`` when the status shown in /diagnostics
    changes (driver mode; an error, without the lock), ``on_finish()`` once when the
    scenario's duration is reached (physics then stops).
    """

    def __init__(
        self,
        node: Node,
        sim: Simulation,
        settings: LoopSettings,
        lock: threading.RLock,
        *,
        state: StatePublisher,
        truth: GroundTruthPublisher,
        detections: DetectionPublisher | None,
        sensors: SensorPublisher | None = None,
        on_status: Callable[[], None],
        on_finish: Callable[[], None],
        on_period: Callable[[], None] | None = None,
        cli_args: list[str] | None = None,
    ) -> None:
        """Subscribe to the commands (``cli_args``: the node's); :meth:`start` starts physics."""
        self._sim, self._lock = sim, lock
        self._logger, self._context = node.get_logger(), node.context
        self._state_every = settings.state_every
        self._rtf, self._max_lag = settings.real_time_factor, settings.max_lag
        self._lockstep, self._lockstep_timeout = settings.lockstep, settings.lockstep_timeout
        self._publish_state = state.publish
        self._publish_ground_truth = truth.publish
        #: (interval in physics steps, publish) of everything published between states.
        self._periodic = [(settings.ground_truth_every, truth.publish)]
        if detections is not None and settings.detection_every:
            self._periodic.append((settings.detection_every, detections.publish))
        if sensors is not None and settings.scan_every:
            self._periodic.append((settings.scan_every, sensors.publish_scan))
        if sensors is not None and settings.points_every:
            self._periodic.append((settings.points_every, sensors.publish_points))
        self._on_status, self._on_finish, self._on_period = on_status, on_finish, on_period
        self._bus = CommandBus(node, self._take_command, cli_args)
        self._drain_commands = self._bus.drain
        self._stop = threading.Event()
        self._error: str | None = None
        self._done = False  # the scenario ended: physics stopped for good
        self._waiting = settings.wait_for_first_command
        self._await_stamp: int | None = None  # lockstep: stamp (ns) of the state to answer
        self._await_since = 0.0
        #: Lockstep periods that advanced without their command (the run is not deterministic).
        self.lockstep_timeouts = 0
        #: Lockstep commands ignored because stamped before the last state.
        self.stale_commands = 0
        self._anchor: tuple[float, float] | None = None  # (wall, sim) of the pacing
        self._wall_start: float | None = None
        self._wall_end: float | None = None
        self._last_idle_publish = -math.inf
        self._last_state_stamp = 0
        self._last_mode = sim.driver_mode
        self._last_reject_warning = -math.inf
        self._last_command_wall: float | None = None
        #: The first few switches to damping: sim time (s), wall s since the last accepted
        #: command, and wall s the physics was behind its schedule (paced runs) then.
        self.damping_events: list[dict[str, float]] = []
        #: Paced runs: times physics fell more than max_lag behind its schedule and gave up
        #: catching up, and the wall seconds given up so (the real-time factor's shortfall).
        self.pacing_resets = 0
        self.pacing_lost = 0.0
        self.pacing_reset_times: list[tuple[float, float]] = []  # the first: (sim s, wall s)
        self._thread = threading.Thread(target=self._run, name=THREAD_NAME, daemon=True)

    # ------------------------------------------------------------------ control

    @property
    def waiting(self) -> bool:
        """True while physics is held at t = 0 waiting for the first command."""
        return self._waiting

    @property
    def awaiting_command(self) -> bool:
        """Lockstep: True while physics waits for the command of the last state."""
        return self._await_stamp is not None

    @property
    def error(self) -> str | None:
        """Why the physics thread stopped on an exception (None while healthy)."""
        return self._error

    def wall_time(self) -> float | None:
        """Wall seconds from the start of physics to its end (or now); None before it starts."""
        if self._wall_start is None:
            return None
        return (self._wall_end or time.monotonic()) - self._wall_start

    def start(self) -> None:
        """Publish the state and ground truth at t = 0, then start the physics thread."""
        self._last_state_stamp = self._publish_state(self._waiting)
        self._publish_ground_truth()
        self._last_idle_publish = time.monotonic()
        if not self._waiting:
            self._start_running()
            if self._lockstep:  # the t = 0 state needs its command too
                self._await_stamp, self._await_since = 0, time.monotonic()
        self._thread.start()

    def stop(self) -> None:
        """Stop the physics thread (waiting up to 10 s for it) and close the command bus."""
        self._stop.set()
        self._bus.wake()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=10.0)
        self._bus.destroy()

    # ------------------------------------------------------------------ commands

    def _start_running(self) -> None:
        self._waiting = False
        now = time.monotonic()
        self._wall_start = now
        self._anchor = (now, self._sim.time)

    def _take_command(self, msg: MotorCommand) -> None:
        """Hand one MotorCommand to the drivers, unless stale (lockstep) or rejected."""
        if self._done:
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
                self._logger.warn(
                    f"rejected a MotorCommand (non-finite, negative gains, unknown joints or "
                    f"array sizes); {sim.rejected_commands} rejected so far"
                )
            return
        self._last_command_wall = time.monotonic()
        if self._waiting:
            self._logger.info("first MotorCommand received: physics starts")
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
            if self._context.ok() and not self._stop.is_set():
                self._error = f"{type(exc).__name__}: {exc}"
                self._logger.error(
                    f"physics thread stopped: {self._error}\n{traceback.format_exc()}"
                )
                try:
                    self._on_status()
                except Exception:  # noqa: BLE001 - the context may be gone already
                    pass

    def _cycle(self) -> tuple[str, float]:
        """One turn of the physics thread: take commands, then wait or advance one period.

        Returns ('stop', 0), ('wait', timeout) for a command, ('sleep', delay) until the
        next period is due, or ('go', 0) to go on at once.
        """
        with self._lock:
            self._drain_commands()
            if self._done or self._stop.is_set():
                return "stop", 0.0
            now = time.monotonic()
            if self._waiting:
                if now - self._last_idle_publish >= _IDLE_PUBLISH_PERIOD:
                    self._last_idle_publish = now
                    self._last_state_stamp = self._publish_state(self._waiting)
                return "wait", _IDLE_PUBLISH_PERIOD
            if self._await_stamp is not None:
                remaining = self._lockstep_timeout - (now - self._await_since)
                if remaining > 0.0:
                    return "wait", min(remaining, 0.1)
                self._lockstep_timed_out(now)
            if self._rtf > 0.0:
                delay = self._pacing_delay(now)
                if delay > 0.0:
                    return "sleep", delay
                if -delay > self._max_lag:  # cannot keep up: stop catching up
                    self._give_up_catching_up(now, -delay)
            self._advance(self._steps_to_boundary())
            if self._done:
                return "stop", 0.0
            if self._rtf > 0.0 and self._await_stamp is None:
                # Sleep until the next period is due right away; the commands that arrive
                # meanwhile are taken when it starts.
                delay = self._pacing_delay(time.monotonic())
                if delay > 0.0:
                    return "sleep", delay
            return "go", 0.0

    def _give_up_catching_up(self, now: float, lag: float) -> None:
        """Physics is ``lag`` wall s behind its schedule: count it, pace from now on."""
        self.pacing_resets += 1
        self.pacing_lost += lag
        if len(self.pacing_reset_times) < 20:
            self.pacing_reset_times.append((round(self._sim.time, 3), round(lag, 4)))
        self._anchor = (now, self._sim.time)

    def _lockstep_timed_out(self, now: float) -> None:
        """No command for the last state in time: count, warn, advance with the previous one."""
        self.lockstep_timeouts += 1
        self._logger.warn(
            f"lockstep: no MotorCommand for the state at t={self._sim.time:.3f} s "
            f"within {self._lockstep_timeout:g} s; advancing with the previous "
            f"command ({self.lockstep_timeouts} timeouts: this run is not "
            "deterministic)",
            throttle_duration_sec=5.0,
        )
        self._await_stamp = None
        self._anchor = (now, self._sim.time)

    def _pacing_delay(self, now: float) -> float:
        """Wall time (s) until the period starting at the current sim time is due (< 0: late)."""
        assert self._anchor is not None
        wall0, sim0 = self._anchor
        return wall0 + (self._sim.time - sim0) / self._rtf - now

    def _steps_to_boundary(self) -> int:
        return self._state_every - self._sim.step_count % self._state_every

    def _advance(self, steps: int) -> None:
        """Step physics ``steps`` times (to the next state boundary), publishing on the way."""
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
                self._last_state_stamp = self._publish_state(self._waiting)
            for every, publish in self._periodic:
                if k % every == 0:
                    publish()
            if sim.finished:
                self._finish()
                return
            if self._lockstep and at_boundary:
                self._await_stamp = self._last_state_stamp
                self._await_since = time.monotonic()
        if self._on_period is not None:
            self._on_period()
        mode = sim.driver_mode
        if mode is not self._last_mode:
            self._driver_mode_changed(mode)

    def _driver_mode_changed(self, mode: DriverMode) -> None:
        """Log the drivers' switch to or from damping mode; report it in /diagnostics."""
        if mode is DriverMode.DAMPING:
            self._note_damping()
            self._logger.warn(
                f"no MotorCommand for {self._sim.driver.timeout:g} s (sim time): motor drivers "
                "switched to damping mode"
            )
        elif self._last_mode is DriverMode.DAMPING:
            self._logger.info("MotorCommands again: motor drivers active")
        self._last_mode = mode
        self._on_status()

    def _note_damping(self) -> None:
        """Record when the drivers timed out, and whether the controller or physics was late."""
        if len(self.damping_events) >= 20:
            return
        now = time.monotonic()
        since = now - self._last_command_wall if self._last_command_wall is not None else -1.0
        lag = -self._pacing_delay(now) if self._rtf > 0.0 and self._anchor else 0.0
        self.damping_events.append({"t": round(self._sim.time, 3),
                                    "wall_since_command": round(since, 4),
                                    "behind_schedule": round(lag, 4)})

    def _finish(self) -> None:
        self._wall_end = time.monotonic()
        self._on_finish()
        self._done = True
