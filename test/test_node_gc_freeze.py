"""A node process moves its start-up objects out of the garbage collector's reach.

Full collections that traverse every module and library object loaded at start-up took
30-110 ms in the node processes and stalled the simulator's physics thread past its pacing
bound every few seconds (real-time factor 0.98 with sensor perception).
"""

from __future__ import annotations

import os
import subprocess
import sys

_NODE_REPORTS_FREEZE = """
import gc, os, signal, sys
from rclpy.node import Node
from safe_legged_c3bf.nodes import ros_common

class Probe(Node):
    def __init__(self):
        super().__init__("gc_freeze_probe")
        self.create_timer(0.05, self._tick)

    def _tick(self):
        print("frozen", gc.get_freeze_count(), flush=True)
        os.kill(os.getpid(), signal.SIGINT)

sys.exit(ros_common.run_node(Probe, [sys.argv[0]]))
"""


def test_a_node_process_runs_with_its_startup_objects_frozen():
    env = dict(os.environ)  # the session's private domain on localhost (conftest)
    proc = subprocess.run([sys.executable, "-c", _NODE_REPORTS_FREEZE], env=env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    frozen = int(proc.stdout.split("frozen", 1)[1].split()[0])
    assert frozen > 10_000, proc.stdout  # rclpy, numpy and the node: far more objects
