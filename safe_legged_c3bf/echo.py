"""Print the messages of a topic, like ``ros2 topic echo``, without a full ROS install.

``python -m safe_legged_c3bf.echo /cmd_vel_safe [--once] [-n N] [--domain-id N]``

The message type is discovered from the ROS graph (any type whose Python package is
importable works, not only the contract's); messages are printed as YAML with nested fields
indented, arrays one ``- value`` per line and ``---`` after each message, as ``ros2 topic echo``
prints them. The subscription's QoS follows the publishers found (best effort if any publisher
is best effort).

A bringup run uses a private ROS domain: pass the id it prints with ``--domain-id`` (this also
restricts discovery to this host, as the bringup does), or set ``ROS_DOMAIN_ID`` yourself.
"""

from __future__ import annotations

import argparse
import array
import importlib
import os
import sys
import time
from typing import Any

import yaml


def _plain(value: Any) -> Any:
    """A message, sequence or value as plain Python data for YAML."""
    if hasattr(value, "get_fields_and_field_types"):
        return {name: _plain(getattr(value, name)) for name in value.get_fields_and_field_types()}
    if isinstance(value, bytes):
        return list(value)  # byte[] / uint8[] fields
    if isinstance(value, array.array | list | tuple):
        return [_plain(v) for v in value]
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return _plain(value.tolist())
    return value


class _Dumper(yaml.SafeDumper):
    """YAML dumper: block style, keys in field order, lists at the key's indentation."""


def message_to_dict(msg: Any) -> dict[str, Any]:
    """Fields of a ROS message as an ordered dict of plain Python values."""
    return _plain(msg)


def message_to_yaml(msg: Any) -> str:
    """A ROS message as YAML text (block style, field order), as ``ros2 topic echo`` prints it."""
    return yaml.dump(
        message_to_dict(msg),
        Dumper=_Dumper,
        default_flow_style=False,
        sort_keys=False,
        allow_unicode=True,
        width=sys.maxsize,
    )


def import_message_type(type_name: str) -> type:
    """Message class of 'pkg/msg/Type'; ImportError with a hint when not installed."""
    parts = type_name.split("/")
    if len(parts) != 3:
        raise ImportError(f"cannot handle type name {type_name!r}")
    package, kind, name = parts
    try:
        return getattr(importlib.import_module(f"{package}.{kind}"), name)
    except (ImportError, AttributeError) as err:
        raise ImportError(
            f"message type {type_name} is not installed in this Python environment ({err})"
        ) from err


def wait_for_topic_type(node, topic: str, timeout: float, spin=None) -> str | None:  # noqa: ANN001
    """Type name of ``topic`` once it appears in the graph, or None after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while True:
        for name, types in node.get_topic_names_and_types():
            if name == topic and types:
                return types[0]
        if time.monotonic() >= deadline:
            return None
        if spin is not None:
            spin(0.05)
        else:
            time.sleep(0.05)


def subscription_qos(node, topic: str):  # noqa: ANN001, ANN201 - rclpy types
    """QoS compatible with every publisher of ``topic`` (contract depth when known)."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    from safe_legged_c3bf.interfaces import topics

    try:
        depth = topics.by_name(topic).depth
    except KeyError:
        depth = 10
    infos = node.get_publishers_info_by_topic(topic)
    best_effort = any(
        i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos
    )
    transient = bool(infos) and all(
        i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos
    )
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=max(depth, 10),
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if transient else DurabilityPolicy.VOLATILE,
    )


def build_parser() -> argparse.ArgumentParser:
    """Command line of the echo tool."""
    parser = argparse.ArgumentParser(
        prog="python -m safe_legged_c3bf.echo",
        description="Print the messages of a ROS 2 topic as YAML (like `ros2 topic echo`).",
    )
    parser.add_argument("topic", help="topic name, e.g. /cmd_vel_safe")
    parser.add_argument("--once", action="store_true", help="print one message and exit")
    parser.add_argument("-n", type=int, default=0, metavar="N",
                        help="print N messages and exit (default: until Ctrl-C)")
    parser.add_argument("--timeout", type=float, default=10.0, metavar="S",
                        help="seconds to wait for the topic to appear (default 10)")
    parser.add_argument("--domain-id", type=int, metavar="N",
                        help="ROS domain (as printed by the bringup); implies localhost discovery")
    return parser


def main(args: list[str] | None = None) -> int:
    """Echo a topic; exit 0 after the requested messages or Ctrl-C, 1 when it never appears."""
    opts = build_parser().parse_args(sys.argv[1:] if args is None else args)
    topic = opts.topic if opts.topic.startswith("/") else "/" + opts.topic
    limit = 1 if opts.once else max(opts.n, 0)
    if opts.domain_id is not None:
        from safe_legged_c3bf.run.ros_domain import restrict_to_localhost

        os.environ["ROS_DOMAIN_ID"] = str(opts.domain_id)
        restrict_to_localhost(os.environ)

    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

    rclpy.init(args=[])
    node = rclpy.create_node(f"echo_{os.getpid()}", start_parameter_services=False)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    printed = 0
    try:
        type_name = wait_for_topic_type(
            node, topic, opts.timeout, spin=lambda t: executor.spin_once(timeout_sec=t)
        )
        if type_name is None:
            known = sorted(name for name, _ in node.get_topic_names_and_types())
            domain = os.environ.get("ROS_DOMAIN_ID", "0")
            print(
                f"echo: topic {topic} did not appear within {opts.timeout:g} s on ROS domain "
                f"{domain}. Topics seen: {', '.join(known) or 'none'}. Is the bringup running, "
                "and did you pass its --domain-id?",
                file=sys.stderr,
            )
            return 1
        try:
            msg_class = import_message_type(type_name)
        except ImportError as err:
            print(f"echo: {err}", file=sys.stderr)
            return 1

        def on_message(msg: Any) -> None:
            nonlocal printed
            if limit and printed >= limit:
                return
            sys.stdout.write(message_to_yaml(msg) + "---\n")
            sys.stdout.flush()
            printed += 1

        node.create_subscription(msg_class, topic, on_message, subscription_qos(node, topic))
        while rclpy.ok() and not (limit and printed >= limit):
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except BrokenPipeError:  # e.g. piped into `head`
        sys.stderr.close()
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
