"""The robot state the controllers run on: /clock, /odom, /imu and /joint_states.

All four are stamped with the sim time of the state (/clock carries it). /imu and
/joint_states go out with every state; /clock and /odom with every ``clock_every`` and
``odom_every`` physics steps (multiples of the state period), and with every state while
physics is held waiting for the first command. Frames: /odom pose of base_link in odom,
twist in base_link (REP-105); /imu orientation in odom, angular velocity and specific force
(:class:`safe_legged_c3bf.sim.imu.Accelerometer`) in base_link; /joint_states in rad, rad/s
and N m (the torques of the last physics step).

Speed: at 250-1000 Hz the messages are not built and serialized each time but serialized
once and patched in place (:class:`~safe_legged_c3bf.nodes.simulator.cdr_template.CdrTemplate`),
and the world is read through its float fast paths (no numpy).
"""

from __future__ import annotations

import array

from nav_msgs.msg import Odometry
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import Imu, JointState

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.messages import time_parts
from safe_legged_c3bf.nodes.simulator.cdr_template import (
    STAMP,
    CdrTemplate,
    vector_fields,
)
from safe_legged_c3bf.nodes.simulator.quiet_publisher import quiet_publisher
from safe_legged_c3bf.sim.imu import Accelerometer
from safe_legged_c3bf.sim.world import Simulation

_JOINT_FIELDS = ("position", "velocity", "effort")


class StatePublisher:
    """Publishes the world's state now (see the module docstring)."""

    def __init__(self, node: Node, sim: Simulation, clock_every: int, odom_every: int) -> None:
        """Create the four publishers on ``node``; ``*_every``: physics steps between two."""
        self._sim = sim
        self._clock_every, self._odom_every = clock_every, odom_every
        self._pub_clock = quiet_publisher(node, topics.CLOCK)
        self._pub_odom = quiet_publisher(node, topics.ODOM)
        self._pub_imu = quiet_publisher(node, topics.IMU)
        self._pub_joints = quiet_publisher(node, topics.JOINT_STATES)
        self._accelerometer = Accelerometer(float(sim.scenario.physics.gravity))

        odom = Odometry()
        odom.header.frame_id, odom.child_frame_id = topics.ODOM_FRAME, topics.BASE_FRAME
        self._odom = CdrTemplate(odom, {
            "stamp": STAMP,
            "pose": vector_fields("pose.pose.position")
            + vector_fields("pose.pose.orientation", "xyzw"),
            "twist": vector_fields("twist.twist.linear") + vector_fields("twist.twist.angular"),
        })
        joints = JointState()
        joints.name = sim.joint_names
        n = len(sim.joint_names)
        for field in _JOINT_FIELDS:
            setattr(joints, field, array.array("d", [0.0] * n))
        self._joints = CdrTemplate(joints, {"stamp": STAMP} | {
            field: [f"{field}[{i}]" for i in range(n)] for field in _JOINT_FIELDS
        })
        imu = Imu()
        imu.header.frame_id = topics.BASE_FRAME
        self._imu = CdrTemplate(imu, {
            "stamp": STAMP,
            "orientation": vector_fields("orientation", "xyzw"),
            "angular_velocity": vector_fields("angular_velocity"),
            "linear_acceleration": vector_fields("linear_acceleration"),
        })
        self._clock = CdrTemplate(ClockMsg(), {"stamp": ["clock.sec", "clock.nanosec"]})

    def publish(self, waiting: bool) -> int:
        """Publish the state now; its stamp (ns of sim time).

        ``waiting``: physics is held for the first command (/clock and /odom go out too).
        """
        sim = self._sim
        sec, nanosec = time_parts(sim.time)
        k = sim.step_count
        if waiting or k % self._clock_every == 0:
            self._clock.set("stamp", sec, nanosec)
            self._pub_clock.publish(self._clock.bytes())
        position, orientation, linear, angular = sim.base_pose_twist()
        if waiting or k % self._odom_every == 0:
            odom = self._odom
            odom.set("stamp", sec, nanosec)
            odom.set("pose", *position, *orientation)
            odom.set("twist", *linear, *angular)
            self._pub_odom.publish(odom.bytes())
        imu = self._imu
        imu.set("stamp", sec, nanosec)
        imu.set("orientation", *orientation)
        imu.set("angular_velocity", *angular)
        imu.set("linear_acceleration",
                *self._accelerometer.specific_force(sim.time, orientation, linear))
        self._pub_imu.publish(imu.bytes())
        q, dq, tau = sim.joint_lists()
        joints = self._joints
        joints.set("stamp", sec, nanosec)
        joints.set("position", *q)
        joints.set("velocity", *dq)
        joints.set("effort", *tau)
        self._pub_joints.publish(joints.bytes())
        return sec * 1_000_000_000 + nanosec
