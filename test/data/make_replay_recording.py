"""Make test/data/replay_walker.mcap: a sensors run of replay_walker.yaml, replay topics only.

Run from the repository root:  .venv/bin/python test/data/make_replay_recording.py

Runs the bringup on test/data/replay_walker.yaml with ``--record`` (filter on, the detector
on the simulated sensors), then copies the topics a replay plays or scores (/clock, /odom,
/scan, /points, /cmd_vel, /ground_truth/obstacles) into a zstd-compressed MCAP.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

HERE = Path(__file__).resolve().parent
KEEP = ("/clock", "/odom", "/scan", "/points", "/cmd_vel", "/ground_truth/obstacles")


def copy_topics(source: Path, target: Path) -> dict[str, int]:
    """Copy the KEEP topics of ``source`` to ``target`` (schemas and channels kept)."""
    counts: dict[str, int] = {}
    with open(source, "rb") as src, open(target, "wb") as dst:
        writer = Writer(dst, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="safe_legged_c3bf test data")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, message in make_reader(src).iter_messages(topics=list(KEEP)):
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                            schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id])
            writer.add_message(channels[channel.id], message.log_time, message.data,
                               message.publish_time, message.sequence)
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
        writer.finish()
    return counts


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        full = Path(tmp) / "full.mcap"
        subprocess.run([sys.executable, "-m", "safe_legged_c3bf.bringup", "--scenario",
                        str(HERE / "replay_walker.yaml"), "--full-duration", "--record",
                        str(full), "--out", str(Path(tmp) / "run")], check=True)
        counts = copy_topics(full, HERE / "replay_walker.mcap")
    print(counts, (HERE / "replay_walker.mcap").stat().st_size, "bytes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
