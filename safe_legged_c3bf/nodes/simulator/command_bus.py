"""The motor drivers' command bus: /joint_commands, read by the physics thread itself.

/joint_commands (MotorCommand) is subscribed by a helper node ``<name>_motor_drivers`` that
is never added to an executor: the physics thread takes the messages itself
(:meth:`CommandBus.drain`) and blocks on a wait set when it has to wait for one
(:meth:`CommandBus.wait`). Why not an executor callback: at the 500 Hz of states and
commands, rclpy's executor costs more CPU per wake-up than a physics step, and commands keep
reaching the drivers when a shared executor is busy.
"""

from __future__ import annotations

from collections.abc import Callable

from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.ros_common import qos
from safe_legged_c3bf_msgs.msg import MotorCommand


class CommandBus:
    """/joint_commands without an executor: take, wait for, and wake up a waiting thread."""

    def __init__(
        self,
        node: Node,
        on_command: Callable[[MotorCommand], None],
        cli_args: list[str] | None = None,
    ) -> None:
        """Subscribe in ``node``'s context and namespace; ``on_command`` gets each message.

        ``cli_args``: the node's ROS arguments (remappings apply to the helper node too).
        """
        self._node = Node(
            f"{node.get_name()}_motor_drivers",
            context=node.context,
            namespace=node.get_namespace(),
            cli_args=cli_args,
            start_parameter_services=False,
            enable_rosout=False,
        )
        self._sub = self._node.create_subscription(
            MotorCommand, topics.JOINT_COMMANDS.name, lambda _msg: None,
            qos(topics.JOINT_COMMANDS),
        )
        self._on_command = on_command
        self._wake = GuardCondition(None, None, context=node.context)
        self._wait_set = _rclpy.WaitSet(1, 1, 0, 0, 0, 0, node.context.handle)

    def drain(self) -> None:
        """Hand every MotorCommand waiting on the bus to ``on_command``, oldest first."""
        handle = self._sub.handle
        with handle:
            while (taken := handle.take_message(MotorCommand, False)) is not None:
                self._on_command(taken[0])

    def wait(self, timeout: float) -> None:
        """Block until a MotorCommand arrives, :meth:`wake` is called or ``timeout`` (wall s)."""
        wait_set = self._wait_set
        wait_set.clear_entities()
        with self._sub.handle, self._wake.handle:
            wait_set.add_subscription(self._sub.handle)
            wait_set.add_guard_condition(self._wake.handle)
            wait_set.wait(int(timeout * 1e9))

    def wake(self) -> None:
        """End a :meth:`wait` in progress (from another thread)."""
        self._wake.trigger()

    def destroy(self) -> None:
        """Destroy the helper node and the guard condition."""
        self._node.destroy_node()
        self._wake.destroy()
