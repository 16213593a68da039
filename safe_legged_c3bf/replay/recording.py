"""Read an MCAP recording for a replay: the messages to play and the ground truth to score.

Messages keep their serialized CDR bytes (played back byte for byte, stamps unchanged). Each
is played at its own stamp (``/clock``'s time, a header's stamp), an unstamped message at the
newest ``/clock`` logged before it; a stamped message is never played before its stamp (a
receiver on sim time would take it for a message from the future). Ground truth for
:mod:`.kpis` comes from ``/odom`` (robot pose and velocity) and ``/ground_truth/obstacles``
(vertical obstacles: centre, velocity, larger semi-axis as radius).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.rotations import yaw_from_quaternion
from safe_legged_c3bf.nodes.messages import from_time_msg
from safe_legged_c3bf.replay.kpis import GroundTruth

#: What the replay publishes into the safety pipeline by default.
PLAYED_TOPICS = (topics.CLOCK.name, topics.ODOM.name, topics.SCAN.name, topics.POINTS.name,
                 topics.CMD_VEL.name)
_TRUTH_TOPICS = (topics.ODOM.name, topics.GROUND_TRUTH_OBSTACLES.name)
#: Played topics whose message starts with a std_msgs/Header (or is a Time, /clock).
_STAMPED = (topics.CLOCK.name, topics.ODOM.name, topics.SCAN.name, topics.POINTS.name)


@dataclass
class Recording:
    """A recording ready to replay.

    Attributes:
        path: the MCAP file.
        messages: (sim time s, topic, CDR bytes) in log order, played topics only.
        truth: robot poses and true obstacles over sim time.
        counts: messages per played topic.

    """

    path: Path
    messages: list[tuple[float, str, bytes]]
    truth: GroundTruth
    counts: dict[str, int]

    @property
    def duration(self) -> float:
        """Sim seconds from the first to the last played message."""
        if not self.messages:
            return 0.0
        return self.messages[-1][0] - self.messages[0][0]


class RecordingError(ValueError):
    """The file is not a recording the replay can use (with the reason)."""


def load_recording(path: str | Path, played: tuple[str, ...] = PLAYED_TOPICS) -> Recording:
    """Read ``path`` (an MCAP file written by the bringup's ``--record``)."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader
    from rclpy.serialization import deserialize_message

    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"{path}: no such file")
    wanted = set(played) | set(_TRUTH_TOPICS)
    classes = {name: topics.by_name(name).msg_class() for name in wanted}
    clock = None
    messages: list[tuple[float, str, bytes]] = []
    poses: list[tuple[float, float, float, float]] = []
    frames: list[tuple[float, np.ndarray]] = []
    try:
        with open(path, "rb") as stream:
            for _schema, channel, message in make_reader(stream).iter_messages(
                    topics=sorted(wanted), log_time_order=True):
                name, data = channel.topic, bytes(message.data)
                if name == topics.CLOCK.name:
                    clock = from_time_msg(deserialize_message(data, classes[name]).clock)
                if clock is None:
                    continue  # nothing is played before the first /clock
                if name == topics.ODOM.name:
                    poses.append(_pose(deserialize_message(data, classes[name])))
                elif name == topics.GROUND_TRUTH_OBSTACLES.name:
                    msg = deserialize_message(data, classes[name])
                    frames.append((from_time_msg(msg.header.stamp), _vertical(msg)))
                if name in played:
                    stamp = _cdr_stamp(data) if name in _STAMPED else None
                    messages.append((max(clock, stamp) if stamp is not None else clock, name,
                                     data))
    except (McapError, OSError, ValueError) as err:
        raise RecordingError(f"{path}: cannot read the recording: {err}") from None
    messages.sort(key=lambda m: m[0])  # stable: log order within one instant
    if not messages:
        raise RecordingError(f"{path}: no /clock or none of {', '.join(played)}")
    counts = {name: sum(1 for _, n, _ in messages if n == name) for name in played}
    pose = np.array(poses, float).reshape(-1, 6)
    truth = GroundTruth(pose[:, 0], pose[:, 1:], np.array([f[0] for f in frames], float),
                        [f[1] for f in frames])
    return Recording(path, messages, truth, counts)


def _cdr_stamp(data: bytes) -> float | None:
    """The leading builtin_interfaces/Time of a CDR message (after its 4-byte encapsulation)."""
    if len(data) < 12:
        return None
    order = "<" if data[1] == 1 else ">"
    sec, nanosec = struct.unpack(order + "iI", data[4:12])
    return sec + nanosec * 1e-9


def _pose(msg) -> tuple[float, ...]:  # noqa: ANN001 - nav_msgs/Odometry
    """t, x, y, yaw, and the body-frame velocity vx, vy (m/s) of an Odometry."""
    q = msg.pose.pose.orientation
    yaw = yaw_from_quaternion(q.x, q.y, q.z, q.w)
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return from_time_msg(msg.header.stamp), p.x, p.y, yaw, v.x, v.y


def _vertical(msg) -> np.ndarray:  # noqa: ANN001 - ObstacleArray
    rows = [(o.center.x, o.center.y, o.velocity.x, o.velocity.y,
             max(o.semi_axis_a, o.semi_axis_b))
            for o in msg.obstacles if o.plane == o.VERTICAL]
    return np.array(rows, float).reshape(-1, 5)
