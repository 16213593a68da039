"""The simulated range sensors' raw data: /scan (LaserScan) and /points (PointCloud2).

Published with ``perception.source: sensors`` instead of /obstacles/detections, each message
stamped with the sim time of its cast and framed in its sensor's mount (``lidar_link``,
``depth_link``; x forward, y left, z up). The casts are the world's
(:mod:`safe_legged_c3bf.sim.range_sensors`): LaserScan ranges in m with the REP-117 values
(+inf no return, -inf too close, NaN dropped), and a PointCloud2 of the valid returns only,
unorganised (height 1), float32 x y z, 12 bytes per point, dense.
"""

from __future__ import annotations

import array
import sys

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import LaserScan, PointCloud2, PointField

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.nodes.ros_common import to_time_msg
from safe_legged_c3bf.nodes.simulator.quiet_publisher import quiet_publisher
from safe_legged_c3bf.sim.range_sensors import Lidar2D
from safe_legged_c3bf.sim.world import Simulation

#: Bytes per point of /points: x, y, z as float32.
POINT_STEP = 12


def xyz_fields() -> list[PointField]:
    """The PointField list of a float32 x y z cloud (offsets 0, 4, 8)."""
    return [
        PointField(name=name, offset=4 * i, datatype=PointField.FLOAT32, count=1)
        for i, name in enumerate("xyz")
    ]


def fill_cloud(msg: PointCloud2, points: np.ndarray) -> PointCloud2:
    """Put (n, 3) points (m) into ``msg`` as an unorganised float32 cloud; returns ``msg``.

    Only the size and data change: header, fields and endianness are the caller's (see
    :func:`empty_cloud`). The points must be finite (``is_dense`` is set).
    """
    data = np.ascontiguousarray(points, dtype=np.float32).reshape(-1, 3)
    msg.height = 1
    msg.width = len(data)
    msg.point_step = POINT_STEP
    msg.row_step = POINT_STEP * len(data)
    msg.is_dense = True
    # An array('B') is taken as is; a bytes object would be checked byte by byte.
    msg.data = array.array("B", data.tobytes())
    return msg


def empty_cloud(frame_id: str) -> PointCloud2:
    """A cloud message in ``frame_id`` with the x y z fields and no points."""
    msg = PointCloud2()
    msg.header.frame_id = frame_id
    msg.fields = xyz_fields()
    msg.is_bigendian = sys.byteorder == "big"
    return fill_cloud(msg, np.zeros((0, 3), dtype=np.float32))


def scan_template(lidar: Lidar2D) -> LaserScan:
    """A LaserScan with ``lidar``'s frame, angles (rad), ranges (m) and scan time (s) set."""
    cfg = lidar.config
    msg = LaserScan()
    msg.header.frame_id = lidar.mount.frame_id
    msg.angle_min = float(lidar.angles[0])
    msg.angle_max = float(lidar.angles[-1])
    msg.angle_increment = float(lidar.angle_increment)
    msg.time_increment = 0.0  # every ray of a scan is cast at the same instant
    msg.scan_time = 1.0 / cfg.rate
    msg.range_min = float(cfg.range_min)
    msg.range_max = float(cfg.range_max)
    return msg


class SensorPublisher:
    """Casts the world's LiDAR and 3-D sensor now and publishes /scan and /points."""

    def __init__(self, node: Node, sim: Simulation) -> None:
        """Create the two publishers on ``node`` (QoS from the topic contract)."""
        self._sim = sim
        self._pub_scan = quiet_publisher(node, topics.SCAN)
        self._pub_points = quiet_publisher(node, topics.POINTS)
        self._scan = scan_template(sim.lidar)
        self._cloud = empty_cloud(sim.depth.mount.frame_id)

    def publish_scan(self) -> None:
        """Cast the LiDAR and publish its ranges, stamped now (sim time)."""
        ranges = self._sim.lidar_scan()
        msg = self._scan
        msg.header.stamp = to_time_msg(self._sim.time)
        msg.ranges = array.array("f", ranges.tobytes())
        self._pub_scan.publish(msg)

    def publish_points(self) -> None:
        """Cast the 3-D sensor and publish its valid returns, stamped now (sim time)."""
        points = self._sim.depth_cloud()
        msg = fill_cloud(self._cloud, points)
        msg.header.stamp = to_time_msg(self._sim.time)
        self._pub_points.publish(msg)
