"""Ground truth, for evaluation and tests only: /ground_truth/safety and /ground_truth/obstacles.

Both in odom, stamped with the sim time. /ground_truth/safety carries the world's safety
monitor (:mod:`safe_legged_c3bf.sim.ground_truth`): contacts, collision count, minimum
robot-obstacle distance (m), fall. /ground_truth/obstacles carries every obstacle's true state
(centre in m, velocity in m/s, VELOCITY_MEASURED); only the moving obstacles change, so it
is serialized once, at its first publication, and their centres and velocities patched in
place (:class:`~safe_legged_c3bf.nodes.simulator.cdr_template.CdrTemplate`).
"""

from __future__ import annotations

from rclpy.node import Node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.messages import time_parts
from safe_legged_c3bf.nodes.ros_common import to_time_msg
from safe_legged_c3bf.nodes.simulator.cdr_template import (
    STAMP,
    CdrTemplate,
    vector_fields,
)
from safe_legged_c3bf.nodes.simulator.obstacle_msgs import obstacle_array
from safe_legged_c3bf.nodes.simulator.quiet_publisher import quiet_publisher
from safe_legged_c3bf.sim.world import Simulation
from safe_legged_c3bf_msgs.msg import GroundTruthSafety


class GroundTruthPublisher:
    """Publishes the world's ground truth now (see the module docstring)."""

    def __init__(self, node: Node, sim: Simulation) -> None:
        """Create the two publishers on ``node``."""
        self._sim = sim
        self._pub_safety = quiet_publisher(node, topics.GROUND_TRUTH_SAFETY)
        self._pub_obstacles = quiet_publisher(node, topics.GROUND_TRUTH_OBSTACLES)
        self._safety = GroundTruthSafety()
        self._safety.header.frame_id = topics.ODOM_FRAME
        self._obstacles: CdrTemplate | None = None  # built at the first publication
        self._moving = [i for i, o in enumerate(sim.obstacles) if o.moving]

    def publish(self) -> None:
        """Publish both topics."""
        sim = self._sim
        gt = sim.ground_truth
        msg = self._safety
        msg.header.stamp = to_time_msg(sim.time)
        msg.in_collision = gt.in_collision
        msg.collision_count = gt.collision_count
        msg.min_distance = float(gt.min_distance)
        msg.closest_obstacle_id = gt.closest_obstacle_id
        msg.contact_obstacle_ids = list(gt.contact_obstacle_ids)
        msg.fallen = gt.fallen
        self._pub_safety.publish(msg)
        self._pub_obstacles.publish(self._obstacles_now())

    def _obstacles_now(self) -> bytes:
        """/ground_truth/obstacles now, serialized."""
        sim = self._sim
        if self._obstacles is None:
            self._obstacles = CdrTemplate(
                obstacle_array(sim.obstacle_states(), sim.time),
                {"stamp": STAMP} | {
                    f"moving{i}": vector_fields(f"obstacles[{i}].center")
                    + vector_fields(f"obstacles[{i}].velocity")
                    for i in self._moving
                },
            )
        template = self._obstacles
        t = sim.time
        template.set("stamp", *time_parts(t))
        for i in self._moving:
            position, velocity = sim.obstacles[i].script.state(t)
            template.set(f"moving{i}", *position.tolist(), *velocity.tolist())
        return template.bytes()
