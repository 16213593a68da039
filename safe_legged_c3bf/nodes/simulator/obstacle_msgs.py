"""Obstacle messages from the world's obstacle states (odom frame, SI units)."""

from __future__ import annotations

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.messages import obstacle_to_msg, to_time_msg
from safe_legged_c3bf.sim.obstacles import ObstacleState
from safe_legged_c3bf_msgs.msg import ObstacleArray


def obstacle_array(states: list[ObstacleState], t: float) -> ObstacleArray:
    """ObstacleArray of ``states`` in odom, stamped ``t`` (s of sim time)."""
    msg = ObstacleArray()
    msg.header.stamp = to_time_msg(t)
    msg.header.frame_id = topics.ODOM_FRAME
    msg.obstacles = [obstacle_to_msg(s) for s in states]
    return msg
