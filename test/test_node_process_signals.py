"""A node process started as users start it ends on SIGTERM and on SIGINT, exit code 0."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest


def _start_filter_node(log, node_name: str) -> subprocess.Popen:
    env = dict(os.environ)  # the session's private domain on localhost (conftest)
    return subprocess.Popen(
        [sys.executable, "-m", "safe_legged_c3bf.nodes.safety_filter_node",
         "--ros-args", "-r", f"__node:={node_name}"],
        env=env, stdout=subprocess.DEVNULL, stderr=log,
    )


def _wait_until_spinning(proc: subprocess.Popen, node_name: str, ctx,
                         timeout: float = 30.0) -> None:
    """Until the node is in the ROS graph (it is then in, or about to enter, its loop).

    Each process gets its own node name: the graph may still list the node of an earlier
    process that has exited, and a signal sent on that sight once reached the new process
    while it was still importing its modules (exit -2, CI of bda55c9).
    """
    import rclpy

    probe = rclpy.create_node("signal_probe", context=ctx)
    try:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if node_name in probe.get_node_names():
                return
            if proc.poll() is not None:
                raise AssertionError(f"node exited early ({proc.returncode})")
            time.sleep(0.1)
        raise AssertionError("node did not appear in the graph")
    finally:
        probe.destroy_node()


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_node_process_exits_on_signal(signum, ros_executor, tmp_path):
    for k in range(3):  # the hang this guards against was intermittent
        log_path = tmp_path / f"node{k}.log"
        log = open(log_path, "w")  # noqa: SIM115 - closed in finally
        node_name = f"safety_filter_{signum.name.lower()}_{k}_{os.getpid()}"
        proc = _start_filter_node(log, node_name)
        try:
            _wait_until_spinning(proc, node_name, ros_executor.context_for_nodes)
            time.sleep(0.3)
            proc.send_signal(signum)
            try:  # the hang guarded against lasted for good; 15 s is room for a loaded CI
                code = proc.wait(timeout=15.0)
            except subprocess.TimeoutExpired:
                raise AssertionError(f"node still running 15 s after {signum!r}") from None
            assert code == 0, f"exit {code} after {signum!r}: {log_path.read_text()[-2000:]}"
        finally:
            log.close()
            if proc.poll() is None:
                proc.kill()
                proc.wait()


_SIGNALLED_WHILE_BUILT = """
import os, signal, sys, time
import rclpy
from rclpy.node import Node
from safe_legged_c3bf.nodes import ros_common

class Slow(Node):
    def __init__(self):
        super().__init__("signalled_while_built")  # in the ROS graph from here on
        os.kill(os.getpid(), signal.SIG{name})     # a launcher stops it now
        deadline = time.monotonic() + 10.0
        while rclpy.ok() and time.monotonic() < deadline:
            time.sleep(0.01)
        self.declare_parameter("late", 1.0)        # publishes on a shut-down context: raises

sys.exit(ros_common.run_node(Slow, [sys.argv[0]]))
"""


@pytest.mark.parametrize("name", ["TERM", "INT"])
def test_a_signal_while_the_node_is_built_is_a_clean_exit(name):
    """A node is in the graph before its constructor ends; a signal then must not be exit 1."""
    env = dict(os.environ)  # the session's private domain on localhost (conftest)
    proc = subprocess.run(
        [sys.executable, "-c", _SIGNALLED_WHILE_BUILT.replace("{name}", name)],
        env=env, capture_output=True, text=True, timeout=60,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]
