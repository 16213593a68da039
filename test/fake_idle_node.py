"""A stand-in node for supervisor tests: spins until stopped.

``--ignore-signals`` makes it ignore SIGINT and SIGTERM (only SIGKILL stops it);
``--crash`` makes it fail at start with a traceback and exit code 3.
"""

import signal
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions


def main():
    stubborn = "--ignore-signals" in sys.argv
    if "--crash" in sys.argv:
        print("about to fail", file=sys.stderr)
        raise SystemExit(3)
    rclpy.init(args=sys.argv, signal_handler_options=(
        SignalHandlerOptions.NO if stubborn else SignalHandlerOptions.ALL))
    if stubborn:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    node = rclpy.create_node("idle")
    print("ready", file=sys.stderr, flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
