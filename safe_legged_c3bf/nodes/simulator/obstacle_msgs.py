"""Obstacle messages from the world's obstacle states (odom frame, SI units)."""

from __future__ import annotations

from safe_legged_c3bf import topics
from safe_legged_c3bf.nodes.ros_common import to_time_msg
from safe_legged_c3bf.sim.obstacles import ObstacleState
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray


def obstacle_to_msg(state: ObstacleState, msg: Obstacle | None = None) -> Obstacle:
    """safe_legged_c3bf_msgs/Obstacle from an :class:`ObstacleState` (filled into ``msg``)."""
    if msg is None:
        msg = Obstacle()
    msg.id = state.id
    msg.plane = int(state.plane)
    center, velocity = msg.center, msg.velocity
    center.x, center.y, center.z = state.center.tolist()
    velocity.x, velocity.y, velocity.z = state.velocity.tolist()
    msg.semi_axis_a, msg.semi_axis_b = float(state.semi_axes[0]), float(state.semi_axes[1])
    msg.orientation = float(state.orientation)
    msg.extent = float(state.extent)
    msg.position_covariance = state.position_covariance.reshape(-1).astype(float)
    msg.velocity_covariance = state.velocity_covariance.reshape(-1).astype(float)
    msg.velocity_source = int(state.velocity_source)
    return msg


def obstacle_array(states: list[ObstacleState], t: float) -> ObstacleArray:
    """ObstacleArray of ``states`` in odom, stamped ``t`` (s of sim time)."""
    msg = ObstacleArray()
    msg.header.stamp = to_time_msg(t)
    msg.header.frame_id = topics.ODOM_FRAME
    msg.obstacles = [obstacle_to_msg(s) for s in states]
    return msg
