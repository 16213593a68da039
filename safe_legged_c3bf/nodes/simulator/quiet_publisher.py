"""A publisher of a contract topic without QoS event handlers, for the simulator's topics."""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node

from safe_legged_c3bf.interfaces.topics import Topic
from safe_legged_c3bf.nodes.ros_common import qos


def quiet_publisher(node: Node, topic: Topic):  # noqa: ANN201 - rclpy Publisher
    """Publisher of ``topic`` (name, type and QoS from ``topics.py``) with no event handlers.

    Each QoS event handler is a waitable that the rclpy executor polls at every wake-up,
    which at ~1 kHz of wake-ups costs far more than the warnings they give (a subscriber
    with an incompatible QoS still warns on its side).
    """
    return node.create_publisher(
        topic.msg_class(), topic.name, qos(topic),
        event_callbacks=PublisherEventCallbacks(use_default_callbacks=False),
    )
