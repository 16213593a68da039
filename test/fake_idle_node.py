"""A stand-in node for supervisor tests: spins until stopped, as the project's nodes do.

It runs through ``ros_common.run_node`` like every node of the package (a stop signal sets a
flag the spin loop checks; no context is shut down under the executor's feet: with rclpy's
own handler a SIGINT during a wait-set rebuild raised an RCLError and the process exited 1).
``--ignore-signals`` makes it ignore SIGINT and SIGTERM (only SIGKILL stops it);
``--crash`` makes it fail at start with a traceback and exit code 3.
"""

import signal
import sys

import rclpy

from safe_legged_c3bf.nodes.ros_common import run_node


def idle_node():
    if "--ignore-signals" in sys.argv:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    node = rclpy.create_node("idle")
    print("ready", file=sys.stderr, flush=True)
    return node


def main():
    if "--crash" in sys.argv:
        print("about to fail", file=sys.stderr)
        raise SystemExit(3)
    return run_node(idle_node)


if __name__ == "__main__":
    raise SystemExit(main())
