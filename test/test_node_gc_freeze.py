"""A node process moves its start-up objects out of the garbage collector's reach.

Full collections that traverse every module and library object loaded at start-up took
30-110 ms in the node processes and stalled the simulator's physics thread past its pacing
bound every few seconds (real-time factor 0.98 with sensor perception).
"""

from __future__ import annotations

import os

from conftest import run_node_probe


def test_a_node_process_runs_with_its_startup_objects_frozen():
    env = dict(os.environ)  # the session's private domain on localhost (conftest)
    proc = run_node_probe('"frozen", gc.get_freeze_count()', env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    frozen = int(proc.stdout.split("frozen", 1)[1].split()[0])
    assert frozen > 10_000, proc.stdout  # rclpy, numpy and the node: far more objects
