"""What perception sees: /obstacles/detections, in odom, stamped with the frame's sim time.

The world's perception model (:mod:`safe_legged_c3bf.sim.perception`) draws each frame:
noisy centres and shapes (m), no velocities (VELOCITY_UNKNOWN), drop-outs; the ids are left
empty with ``strip_ids``.
"""

from __future__ import annotations

from rclpy.node import Node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.messages import obstacle_to_msg
from safe_legged_c3bf.nodes.ros_common import to_time_msg
from safe_legged_c3bf.nodes.simulator.quiet_publisher import quiet_publisher
from safe_legged_c3bf.sim.world import Simulation
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray


class DetectionPublisher:
    """Publishes one detection frame of the world now."""

    def __init__(self, node: Node, sim: Simulation, strip_ids: bool) -> None:
        """Create the publisher on ``node``; ``strip_ids``: publish empty obstacle ids."""
        self._sim = sim
        self._include_ids = not strip_ids
        self._pub = quiet_publisher(node, topics.OBSTACLE_DETECTIONS)
        self._msg = ObstacleArray()
        self._msg.header.frame_id = topics.ODOM_FRAME
        self._pool = [Obstacle() for _ in sim.obstacles]

    def publish(self) -> None:
        """Draw a detection frame from the world and publish it."""
        detections = self._sim.detections(include_ids=self._include_ids)
        # Obstacle messages are reused from frame to frame.
        pool = self._pool
        pool.extend(Obstacle() for _ in range(len(detections) - len(pool)))
        msg = self._msg
        msg.header.stamp = to_time_msg(self._sim.time)
        msg.obstacles = [
            obstacle_to_msg(d, m)
            for d, m in zip(detections, pool[: len(detections)], strict=True)
        ]
        self._pub.publish(msg)
