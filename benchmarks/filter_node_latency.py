"""Latency of the safety filter node: from receiving /odom to publishing /cmd_vel_safe.

1. In-node (one process, in-process executor): the node's own measurement from odometry
   receipt to publish, with N obstacles (default 10) ahead of the robot; also split by the
   status the cycle ended with (the scripted odometry ignores the filter and drives through
   the obstacles, so about 40 % of the cycles end RELAXED).
2. End-to-end across processes: the filter runs as its own process
   (``python -m safe_legged_c3bf.nodes.safety_filter_node``); this process publishes /odom and
   measures the wall time until the matching /cmd_vel_safe arrives.

Usage: python benchmarks/filter_node_latency.py [--obstacles 10] [--cycles 500]
       [--body-model point|body]   (body: the whole-body filter, one row per body point and
                                    obstacle of the A1's cover; default: the node's default)
       [--model unicycle|unicycle_lateral|holonomic]   (the filter's dynamics model)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np

from safe_legged_c3bf.run.ros_domain import isolate_environment

_ENV, _LEASE = isolate_environment()

import rclpy  # noqa: E402
from geometry_msgs.msg import Twist  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402

from safe_legged_c3bf.interfaces import topics  # noqa: E402
from safe_legged_c3bf.nodes import ros_common  # noqa: E402
from safe_legged_c3bf.nodes.safety_filter_node import SafetyFilterNode  # noqa: E402
from safe_legged_c3bf.safety.params import BODY_MODELS, MODELS  # noqa: E402
from safe_legged_c3bf_msgs.msg import Obstacle, ObstacleArray  # noqa: E402


def obstacles(n: int) -> list[Obstacle]:
    rng = np.random.default_rng(0)
    out = []
    for i in range(n):
        o = Obstacle()
        o.id = f"o{i}"
        o.center.x, o.center.y, o.center.z = rng.uniform(1.5, 8), rng.uniform(-2, 2), 0.5
        o.velocity.x, o.velocity.y = rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)
        o.semi_axis_a = o.semi_axis_b = 0.2
        o.extent = 1.0
        out.append(o)
    return out


def odom(t: float, x: float) -> Odometry:
    m = Odometry()
    m.header.stamp = ros_common.to_time_msg(t)
    m.header.frame_id, m.child_frame_id = "odom", "base_link"
    m.pose.pose.position.x, m.pose.pose.position.z = x, 0.28
    m.pose.pose.orientation.w = 1.0
    m.twist.twist.linear.x = 0.4
    return m


class Driver:
    def __init__(self, node, n_obstacles):
        self.node = node
        self.clock = node.create_publisher(Clock, topics.CLOCK.name, 10)
        self.odom = node.create_publisher(Odometry, topics.ODOM.name, 10)
        self.obs = node.create_publisher(ObstacleArray, topics.OBSTACLES.name, 10)
        self.ref = node.create_publisher(Twist, topics.CMD_VEL.name, 10)
        self.received = 0
        self.arrivals: list[float] = []
        node.create_subscription(Twist, topics.CMD_VEL_SAFE.name, self._on_cmd, 10)
        self.obstacles = obstacles(n_obstacles)

    def _on_cmd(self, _msg):
        self.received += 1
        self.arrivals.append(time.perf_counter())

    def publish_inputs(self, t):
        self.clock.publish(Clock(clock=ros_common.to_time_msg(t)))
        arr = ObstacleArray(obstacles=self.obstacles)
        arr.header.stamp = ros_common.to_time_msg(t)
        arr.header.frame_id = "odom"
        self.obs.publish(arr)
        r = Twist()
        r.linear.x = 0.5
        self.ref.publish(r)


def wait(executor, predicate, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end and not predicate():
        executor.spin_once(timeout_sec=0.001)
    return predicate()


def run_cycles(executor, driver, cycles, dt=0.02, after=None):
    """Publish inputs then odometry; return the wall latency per cycle (s).

    ``after``: called after each answered cycle (e.g. to note the filter's status).
    """
    lat = []
    for k in range(1, cycles + 1):
        t = k * dt
        driver.publish_inputs(t)
        wait(executor, lambda: False, 0.002)  # let clock/obstacles/reference arrive first
        n0 = driver.received
        sent = time.perf_counter()
        driver.odom.publish(odom(t, 0.4 * t))
        if wait(executor, lambda n0=n0: driver.received > n0, 2.0):
            lat.append(driver.arrivals[-1] - sent)
            if after is not None:
                after()
    return np.array(lat)


def report_by_status(latencies, statuses):
    """In-node medians per filter status: the scripted odometry drives through the obstacles,
    so many cycles end RELAXED, which a robot that follows its commands rarely sees."""
    lat, st = np.asarray(latencies), np.asarray(statuses)
    n = min(lat.size, st.size)
    lat, st = lat[-n:], st[-n:]
    for status in sorted(set(st.tolist())):
        share = 100.0 * float(np.mean(st == status))
        report(f"  in-node, cycles ending {status} ({share:.0f} %)", lat[st == status])


def report(name, values):
    v = 1e3 * np.asarray(values)
    print(f"{name:<48} median {np.median(v):7.3f} ms   p99 {np.percentile(v, 99):7.3f} ms  "
          f"(n={v.size})")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--obstacles", type=int, default=10)
    ap.add_argument("--cycles", type=int, default=500)
    ap.add_argument("--body-model", choices=BODY_MODELS, default=None)
    ap.add_argument("--model", choices=MODELS, default=None,
                    help="the filter's dynamics model (default: the node's, unicycle)")
    args = ap.parse_args()
    print(f"ROS_DOMAIN_ID={_LEASE.domain_id}, {args.obstacles} obstacles, {args.cycles} cycles"
          f", body_model {args.body_model or 'default'}, model {args.model or 'default'}")
    chosen = {k: v for k, v in (("body_model", args.body_model), ("model", args.model)) if v}
    overrides = [Parameter(k, Parameter.Type.STRING, v) for k, v in chosen.items()]
    ros_args = ["--ros-args", *(a for k, v in chosen.items() for a in ("-p", f"{k}:={v}"))]

    rclpy.init()
    executor = SingleThreadedExecutor()
    filt = SafetyFilterNode(parameter_overrides=overrides)
    node = rclpy.create_node("latency_driver")
    executor.add_node(filt)
    executor.add_node(node)
    driver = Driver(node, args.obstacles)
    wait(executor, lambda: driver.odom.get_subscription_count() > 0, 10)
    statuses: list[str] = []
    e2e_in = run_cycles(executor, driver, args.cycles,
                        after=lambda: statuses.append(filt.last_status_name()))
    report("in-node: /odom receipt -> /cmd_vel_safe publish", filt.latencies[20:])
    report_by_status(filt.latencies[20:], statuses[20:])
    report("in-process round trip (DDS loopback both ways)", e2e_in[20:])
    executor.remove_node(filt)
    filt.destroy_node()

    proc = subprocess.Popen(
        [sys.executable, "-m", "safe_legged_c3bf.nodes.safety_filter_node", *ros_args],
        env=dict(os.environ), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    try:
        ok = wait(executor, lambda: driver.odom.get_subscription_count() > 0
                  and driver.clock.get_subscription_count() > 0, 20)
        if not ok:
            print("filter process did not appear", file=sys.stderr)
            return 1
        driver.received = 0
        e2e = run_cycles(executor, driver, args.cycles)
        report("end-to-end across processes: /odom -> /cmd_vel_safe", e2e[20:])
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            print("filter process ignored SIGTERM for 10 s: killed", file=sys.stderr)
            proc.kill()
            proc.wait()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
