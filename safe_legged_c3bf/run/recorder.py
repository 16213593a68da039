"""Record topics to an MCAP file that Foxglove and ``ros2 bag`` open.

The file has profile ``ros2``; every channel has message encoding ``cdr`` and a ``ros2msg``
schema holding the rosbag2-style full message definition (see :mod:`.msgdefs`). Messages are
received serialized (``raw=True``) and written byte for byte, so recording costs no
deserialization. Log time and publish time are the wall-clock receive time (as ``ros2 bag
record``): the publisher's source timestamp would come with rclpy's MessageInfo, which the
EventsExecutor the project spins cannot pass to a callback (rclpy 7.1.6: SystemError). The
messages' own header stamps carry the simulation time.

Run on its own: ``python -m safe_legged_c3bf.run.recorder run.mcap [--topics /odom /cmd_vel]``
(all contract topics by default); the bringup starts it for ``--record``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from collections.abc import Iterable
from pathlib import Path

from mcap.records import Schema
from mcap_ros2.writer import Writer as Ros2Writer
from rclpy.node import Node

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.run import msgdefs

#: Reader-side queue depth: deep enough to ride out a busy moment without dropping messages.
QUEUE_DEPTH = 1000


def qos(topic: topics.Topic, depth: int | None = None):  # noqa: ANN201 - rclpy QoSProfile
    """The contract QoS of ``topic`` with a deeper reader queue (compatibility unchanged)."""
    from safe_legged_c3bf.nodes import ros_common

    profile = ros_common.qos(topic)
    if depth is not None:
        profile.depth = max(profile.depth, depth)
    return profile


class RawRos2Writer(Ros2Writer):
    """mcap-ros2-support's writer plus a method to write already-serialized CDR bytes."""

    def write_raw(
        self,
        topic: str,
        schema: Schema,
        data: bytes,
        log_time: int,
        publish_time: int | None = None,
        sequence: int = 0,
    ) -> None:
        """Write one serialized message on ``topic`` (channel created on first use)."""
        channel_id = self._channel_ids.get(topic)
        if channel_id is None:
            channel_id = self._writer.register_channel(
                topic=topic, message_encoding="cdr", schema_id=schema.id
            )
            self._channel_ids[topic] = channel_id
        self._writer.add_message(
            channel_id=channel_id,
            log_time=log_time,
            publish_time=log_time if publish_time is None else publish_time,
            sequence=sequence,
            data=data,
        )


class McapFile:
    """An MCAP file being written: one schema per type, one channel per topic."""

    def __init__(self, path: str | Path, entries: Iterable[topics.Topic]) -> None:
        """Open ``path`` for writing and register the schemas of ``entries``."""
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._stream = open(self.path, "wb")  # noqa: SIM115 - closed in close()
        self._writer = RawRos2Writer(self._stream)
        self._schemas: dict[str, Schema] = {}
        self.counts: Counter[str] = Counter()
        for entry in entries:
            if entry.type not in self._schemas:
                self._schemas[entry.type] = self._writer.register_msgdef(
                    entry.type, msgdefs.rosbag2_definition(entry.type)
                )

    def write(self, topic: topics.Topic, data: bytes, log_time: int, publish_time: int) -> None:
        """Write serialized ``data`` received on ``topic``."""
        self.counts[topic.name] += 1
        self._writer.write_raw(
            topic.name, self._schemas[topic.type], data, log_time, publish_time,
            sequence=self.counts[topic.name],
        )

    def close(self) -> None:
        """Write the summary section and close the file (safe to call twice)."""
        if self._stream.closed:
            return
        try:
            self._writer.finish()
        finally:
            self._stream.close()


class RecorderNode(Node):
    """Subscribes raw to the given contract topics and writes everything to an MCAP file."""

    def __init__(
        self,
        output: str | Path,
        entries: Iterable[topics.Topic] = topics.CONTRACT,
        node_name: str = "recorder",
        **kwargs,
    ) -> None:
        """Create the node and open ``output``; ``kwargs`` go to rclpy's Node."""
        super().__init__(node_name, **kwargs)
        self.entries = tuple(entries)
        self.file = McapFile(output, self.entries)
        for entry in self.entries:
            self.create_subscription(
                entry.msg_class(), entry.name, self._callback(entry),
                qos(entry, depth=QUEUE_DEPTH), raw=True,
            )

    def _callback(self, entry: topics.Topic):
        file = self.file

        def on_message(data: bytes) -> None:
            now = time.time_ns()
            if not file._stream.closed:
                file.write(entry, data, now, now)

        return on_message

    def close(self) -> None:
        """Finish the MCAP file."""
        self.file.close()

    def destroy_node(self) -> None:
        """Finish the file, then destroy the node."""
        self.close()
        super().destroy_node()


def select_topics(names: Iterable[str] | None) -> tuple[topics.Topic, ...]:
    """Contract entries for ``names`` (all of the contract when None or empty)."""
    names = list(names or [])
    return tuple(topics.by_name(n) for n in names) if names else topics.CONTRACT


def main(args: list[str] | None = None) -> int:
    """Record contract topics to an MCAP file until Ctrl-C / SIGTERM."""
    from rclpy.utilities import remove_ros_args

    argv = list(sys.argv if args is None else args)
    parser = argparse.ArgumentParser(
        prog="python -m safe_legged_c3bf.run.recorder", description=__doc__.split("\n")[0]
    )
    parser.add_argument("output", help="MCAP file to write")
    parser.add_argument("--topics", nargs="*", help="contract topics (default: all)")
    opts = parser.parse_args(remove_ros_args(argv)[1:])
    entries = select_topics(opts.topics)

    from safe_legged_c3bf.nodes.ros_common import run_node

    return run_node(lambda: RecorderNode(opts.output, entries), argv)


if __name__ == "__main__":
    raise SystemExit(main())
