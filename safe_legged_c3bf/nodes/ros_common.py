"""Helpers shared by the rclpy node wrappers.

QoS from the topic contract, the node clock, diagnostics, a publisher-count check and a
standard ``main`` for a single node. Message conversions live in ``nodes/messages.py`` (the
common ones are re-exported here for the nodes).
"""

from __future__ import annotations

import gc
import math
import os
import signal
import sys
import time
from collections.abc import Callable, Iterable

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from safe_legged_c3bf.interfaces.topics import Topic
from safe_legged_c3bf.nodes.messages import (  # noqa: F401 - re-exported for the nodes
    command_to_twist,
    from_time_msg,
    odometry_is_finite,
    odometry_to_base_state,
    to_time_msg,
    twist_is_finite,
    twist_to_command,
)

DIAGNOSTIC_LEVELS = {
    "ok": DiagnosticStatus.OK,
    "warn": DiagnosticStatus.WARN,
    "error": DiagnosticStatus.ERROR,
    "stale": DiagnosticStatus.STALE,
}


def qos(topic: Topic) -> QoSProfile:
    """QoS profile of a contract topic."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=topic.depth,
        reliability=ReliabilityPolicy.RELIABLE if topic.reliable else ReliabilityPolicy.BEST_EFFORT,
    )


def publisher(node: Node, topic: Topic):  # noqa: ANN201 - rclpy Publisher
    """Publisher of a contract topic: its name, message type and QoS from ``topics.py``."""
    return node.create_publisher(topic.msg_class(), topic.name, qos(topic))


def subscription(node: Node, topic: Topic, callback: Callable, raw: bool = False):  # noqa: ANN201
    """Subscription to a contract topic: its name, message type and QoS from ``topics.py``.

    ``raw``: the callback receives the serialized bytes (to bound work before decoding).
    """
    return node.create_subscription(
        topic.msg_class(), topic.name, callback, qos(topic), raw=raw
    )


class SinglePublisher:
    """Whether a topic has at most one publisher, asked of the ROS graph every ``period`` s.

    rclpy gives a callback no publisher identity, so two publishers on one topic cannot be
    told apart message by message. Where believing the wrong one is unsafe (odometry and
    obstacles for the filter, the safe command for the gait controller) the receiver rejects
    the topic's messages while it has more than one publisher, and fails safe.
    """

    def __init__(self, node: Node, topic: Topic, period: float = 0.2) -> None:
        """Watch ``topic`` for ``node``; ``period``: wall seconds between graph queries."""
        self._node, self._name, self._period = node, topic.name, period
        self._asked = -math.inf
        self._count = 0

    @property
    def count(self) -> int:
        """Publishers on the topic (at most ``period`` s old)."""
        now = time.monotonic()
        if now - self._asked >= self._period:
            self._count = self._node.count_publishers(self._name)
            self._asked = now
        return self._count

    def ok(self) -> bool:
        """True while the topic has at most one publisher."""
        return self.count <= 1


def use_sim_time(node: Node, enabled: bool = True) -> None:
    """Switch ``node`` to sim time from /clock, unless ``use_sim_time`` was set explicitly.

    Every node of the simulated graph runs on sim time; a deployment on a real robot starts
    the nodes with ``use_sim_time: false`` (a parameter override), which is kept.
    """
    if "use_sim_time" in getattr(node, "_parameter_overrides", {}):
        return
    if node.has_parameter("use_sim_time"):
        node.set_parameters([Parameter("use_sim_time", Parameter.Type.BOOL, enabled)])


def now_seconds(node: Node) -> float:
    """The node's clock (sim time when use_sim_time is set) in seconds."""
    return node.get_clock().now().nanoseconds * 1e-9


def diagnostic_status(
    name: str, level: str, message: str, values: dict[str, object] | None = None
) -> DiagnosticStatus:
    """A DiagnosticStatus; ``level`` is 'ok', 'warn', 'error' or 'stale'."""
    status = DiagnosticStatus(
        level=DIAGNOSTIC_LEVELS[level], name=name, message=message, hardware_id="sim"
    )
    status.values = [KeyValue(key=str(k), value=str(v)) for k, v in (values or {}).items()]
    return status


def diagnostic_array(node: Node, statuses: Iterable[DiagnosticStatus]) -> DiagnosticArray:
    """DiagnosticArray stamped with the node's clock."""
    msg = DiagnosticArray()
    msg.header.stamp = node.get_clock().now().to_msg()
    msg.status = list(statuses)
    return msg


#: Wall s a node process's executor waits at most before it checks for shutdown again.
SPIN_WAKE_PERIOD = 0.1


def freeze_startup_objects() -> None:
    """Move every object alive now out of the garbage collector's reach (``gc.freeze``).

    Call once a node is built. Full (generation 2) collections otherwise traverse every
    module, message class and library object loaded at start-up: 30-50 ms each in the
    simulator (every few seconds with sensor perception, stalling its physics thread past the
    pacing's 50 ms lag bound) and up to 80 ms in the safety filter (missed cycles). Objects
    created later are collected as usual.
    """
    gc.collect()
    gc.freeze()


EXECUTOR_VARIABLE = "SAFE_LEGGED_C3BF_EXECUTOR"
EXECUTORS = ("events", "single")
DEFAULT_EXECUTOR = "events"
"""The executor of every node process and of the ``--in-process`` bringup (``make_executor``)."""


def make_executor(kind: str | None = None, context: rclpy.Context | None = None):  # noqa: ANN201
    """The executor a node process spins (and the bringup's with ``--executor events``).

    ``events`` (default): rclpy's EventsExecutor (``rclpy.experimental``, C++): callbacks run
    from the middleware's events instead of a wait set rebuilt on every wake-up; the A1's
    graph paced by the wall clock used 0.81-0.91 core-s per sim s against 1.09-1.45 with
    ``single`` (interleaved, issue 18). ``single``: rclpy's SingleThreadedExecutor, the
    fallback. ``kind`` None reads ``$SAFE_LEGGED_C3BF_EXECUTOR`` (a ValueError names the
    choices).
    """
    kind = kind or os.environ.get(EXECUTOR_VARIABLE) or DEFAULT_EXECUTOR
    if kind not in EXECUTORS:
        raise ValueError(f"{EXECUTOR_VARIABLE}={kind!r}: choose one of {', '.join(EXECUTORS)}")
    if kind == "single":
        return SingleThreadedExecutor(context=context)
    from rclpy.experimental import EventsExecutor

    return EventsExecutor(context=context)


class _StopSignals:
    """SIGINT and SIGTERM: a flag that a node process's spin loop checks.

    While the node is being built (before ``spinning``) a signal also shuts the context down,
    so that a constructor waiting on the graph gives up. Once it spins, the flag alone: the
    loop ends within SPIN_WAKE_PERIOD, and no context is shut down under the executor's feet
    and no KeyboardInterrupt is raised inside a callback that the EventsExecutor's C++ runs.
    """

    def __init__(self) -> None:
        self.received: int | None = None
        self.spinning = False
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, self._on_signal)

    def _on_signal(self, signum: int, frame) -> None:  # noqa: ANN001 - a Python frame
        self.received = signum
        if not self.spinning:
            rclpy.try_shutdown()


def run_node(factory: Callable[[], Node], args: list[str] | None = None) -> int:
    """Standard ``main`` body: init, spin one node until Ctrl-C/SIGTERM, clean shutdown.

    The executor waits at most SPIN_WAKE_PERIOD at a time, then the loop checks for a stop
    signal (a Python signal handler runs only between the executor's calls). A signal while
    the node is still being built ends the process cleanly once it is built (the node is in
    the ROS graph before its constructor has declared all its parameters, and a launcher may
    stop it then); an error raised after the context was shut down is a clean exit too.
    """
    stop = _StopSignals()
    rclpy.init(args=sys.argv if args is None else args,
               signal_handler_options=SignalHandlerOptions.NO)
    node = None
    try:
        node = factory()
        freeze_startup_objects()
        executor = make_executor()
        executor.add_node(node)
        stop.spinning = True
        while rclpy.ok() and stop.received is None:
            executor.spin_once(timeout_sec=SPIN_WAKE_PERIOD)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if rclpy.ok() and stop.received is None:
            raise
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
