"""Simulator throughput and CPU use, with the A1 and five obstacles, publishing all topics.

The simulator node runs alone in this process: its physics thread plus an executor spun by
this script's main thread, woken by the node's timers only (as when the node runs as its
own process). A second process stands for the rest of the graph: it receives every topic
the simulator publishes (so the messages really go out over DDS, /imu and /joint_states at
250 Hz included) and reports how many it got, and it sends a constant standing
MotorCommand at 50 Hz (so the drivers stay active) once it hears every topic. Two
measurements:

1. real_time_factor 0 (as fast as possible): physics steps per wall second;
2. real_time_factor 1: CPU use of the simulator process (physics thread, executor thread,
   DDS threads), from time.process_time() over a wall interval, in % of one core, and the
   physics thread's share of it (its own CPU clock).

The machine's load average is printed too: on a shared machine the numbers vary with it
(contention slows the same work down and the process may not even get the CPU it asks for).

Usage: python benchmarks/sim_rate.py [--seconds 5]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time

import yaml

SCENARIO = {
    "name": "bench_five_obstacles",
    "robot": {"kind": "quadruped", "position": [0.0, 0.0]},
    "goal": {"position": [6.0, 0.0]},
    "duration": 1000.0,
    "seed": 3,
    "perception": {"rate": 20.0, "position_noise_std": 0.02, "dropout_probability": 0.05},
    "obstacles": [
        {"id": "pillar", "position": [2.0, 0.5], "semi_axes": [0.3, 0.2]},
        {"id": "box", "position": [3.0, -0.8], "semi_axes": [0.4, 0.25], "orientation": 0.5},
        {"id": "walker", "position": [1.0, -1.0], "semi_axes": [0.25, 0.2],
         "motion": {"type": "waypoints", "waypoints": [[1.0, 1.0]], "speed": 0.4}},
        {"id": "cart", "position": [4.0, 2.0], "semi_axes": [0.3, 0.3],
         "motion": {"type": "constant_velocity", "velocity": [0.0, -0.1]}},
        {"id": "bar", "plane": "horizontal", "position": [0.6, 0.0, 0.45],
         "semi_axes": [0.05, 0.05], "extent": 3.0},
    ],
}


PHYSICS_THREAD = "simulator_physics"  # SimulatorNode's physics thread


def _sim_topics():
    from safe_legged_c3bf.interfaces import topics

    return [
        topics.CLOCK, topics.ODOM, topics.IMU, topics.JOINT_STATES, topics.OBSTACLE_DETECTIONS,
        topics.GROUND_TRUTH_SAFETY, topics.GROUND_TRUTH_OBSTACLES, topics.DIAGNOSTICS,
    ]


def graph_process(command: str) -> None:
    """The rest of the graph: count every simulator topic, send ``command`` at 50 Hz.

    ``command`` is JSON: {"name": [...], "q": [...]}. Runs until stdin closes, then prints
    the counts as JSON.
    """
    import rclpy

    from safe_legged_c3bf.interfaces import topics
    from safe_legged_c3bf.nodes.ros_common import qos
    from safe_legged_c3bf_msgs.msg import MotorCommand

    rclpy.init()
    node = rclpy.create_node("sim_rate_graph")
    counts = {t.name: 0 for t in _sim_topics()}

    def counter(name):
        def callback(_msg) -> None:
            counts[name] += 1

        return callback

    subscriptions = [  # raw: counting needs no deserialization
        node.create_subscription(
            topic.msg_class(), topic.name, counter(topic.name), qos(topic), raw=True
        )
        for topic in _sim_topics()
    ]
    spec = json.loads(command)
    n = len(spec["name"])
    msg = MotorCommand(
        name=spec["name"], q=spec["q"], dq=[0.0] * n, kp=[60.0] * n, kd=[2.0] * n, tau=[0.0] * n
    )
    pub = node.create_publisher(
        MotorCommand, topics.JOINT_COMMANDS.name, qos(topics.JOINT_COMMANDS)
    )

    stop = threading.Event()

    def send() -> None:
        # From a thread of its own: a timer would wait behind hundreds of message callbacks.
        # Physics starts with the first command: only once every topic is heard.
        while not stop.wait(0.02):
            if all(sub.get_publisher_count() > 0 for sub in subscriptions):
                pub.publish(msg)

    sender = threading.Thread(target=send, daemon=True)
    sender.start()
    threading.Thread(target=lambda: (sys.stdin.read(), stop.set()), daemon=True).start()
    while not stop.is_set():
        rclpy.spin_once(node, timeout_sec=0.05)
    sender.join()
    print(json.dumps(counts), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


def _spin_for(executor, seconds: float) -> None:  # noqa: ANN001
    """Spin ``executor`` for ``seconds`` of wall time, waking only for its events."""
    end = time.monotonic() + seconds
    while (remaining := end - time.monotonic()) > 0.0:
        executor.spin_once(timeout_sec=remaining)


def _thread_cpu(name: str) -> float:
    """CPU time (s) of the running thread called ``name`` (nan if there is none)."""
    for thread in threading.enumerate():
        if thread.name == name and thread.ident is not None:
            return time.clock_gettime(time.pthread_getcpuclockid(thread.ident))
    return math.nan


def run(
    seconds: float, rtf: float, scenario_path: str, overrides: dict | None = None
) -> dict[str, float]:
    """Measure one run of ``seconds`` wall time; returns sim/wall/cpu seconds and msg rates."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from safe_legged_c3bf.nodes.simulator_node import SimulatorNode

    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    sim_node = SimulatorNode(
        context=context,
        parameter_overrides=[
            Parameter("scenario", value=scenario_path),
            Parameter("real_time_factor", value=rtf),
            # The robot keeps standing even if a busy machine delays a 50 Hz command by more
            # than the default 0.1 s (sim time, which runs faster at real_time_factor 0).
            Parameter("command_timeout", value=1.0),
        ] + [Parameter(k, value=v) for k, v in (overrides or {}).items()],
    )
    sim = sim_node.simulation
    pose = sim.robot.spec.standing_pose
    command = json.dumps({"name": sim.joint_names, "q": [pose[j] for j in sim.joint_names]})
    graph = subprocess.Popen(
        [sys.executable, __file__, "--graph-process", command],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )
    executor.add_node(sim_node)
    try:
        deadline = time.monotonic() + 30.0
        while sim_node.waiting_for_command and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
        if sim_node.waiting_for_command:
            raise RuntimeError("no command from the graph process (discovery failed?)")
        start_sim = sim.time
        _spin_for(executor, 0.5)  # warm-up
        physics0 = _thread_cpu(PHYSICS_THREAD)
        sim0, wall0, cpu0 = sim.time, time.monotonic(), time.process_time()
        _spin_for(executor, seconds)
        result = {
            "sim": sim.time - sim0,
            "wall": time.monotonic() - wall0,
            "cpu": time.process_time() - cpu0,
            "physics_cpu": _thread_cpu(PHYSICS_THREAD) - physics0,
        }
        _spin_for(executor, 0.3)  # let the last messages arrive, then stop the graph process
    finally:
        executor.remove_node(sim_node)
        sim_node.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)
        try:
            out, _ = graph.communicate(input="", timeout=30)  # closing stdin stops it
        except subprocess.TimeoutExpired:
            graph.kill()
            out, _ = graph.communicate()
    counts = json.loads(out.strip().splitlines()[-1])
    total_sim = sim.time - start_sim  # physics has stopped: every message sent is counted
    result["rates"] = {name: c / total_sim for name, c in counts.items()}
    return result


def _print_rates(rates: dict[str, float]) -> None:
    text = ", ".join(f"{name} {rate:.0f}" for name, rate in rates.items())
    print(f"    received by the graph process, messages per sim second: {text}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="wall seconds per measurement")
    parser.add_argument("--state-rate", type=float, help="simulator state_rate (Hz)")
    parser.add_argument("--graph-process", metavar="COMMAND_JSON", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.graph_process:
        graph_process(args.graph_process)
        return
    from safe_legged_c3bf.run.ros_domain import isolate_environment

    _, lease = isolate_environment()
    print(f"load average before: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "bench_five_obstacles.yaml")
        with open(path, "w", encoding="utf-8") as f:
            yaml.safe_dump(SCENARIO, f)
        overrides = {} if args.state_rate is None else {"state_rate": args.state_rate}
        if overrides:
            print(f"simulator parameters: {overrides}")
        r = run(args.seconds, 0.0, path, overrides)
        print(
            f"real_time_factor 0 (as fast as possible): {r['sim'] * 1000.0 / r['wall']:.0f} "
            f"physics steps/s (A1 + 5 obstacles, all topics published), "
            f"sim/wall = {r['sim'] / r['wall']:.2f}, CPU {100.0 * r['cpu'] / r['wall']:.0f} %"
        )
        _print_rates(r["rates"])
        r = run(args.seconds, 1.0, path, overrides)
        print(
            f"real_time_factor 1: sim/wall = {r['sim'] / r['wall']:.3f} "
            f"({r['sim'] * 1000.0 / r['wall']:.0f} physics steps/s), CPU of the simulator "
            f"process {100.0 * r['cpu'] / r['wall']:.1f} % of one core (process_time "
            f"{r['cpu']:.2f} s over {r['wall']:.2f} s wall), of which the physics thread "
            f"{100.0 * r['physics_cpu'] / r['wall']:.1f} %; "
            f"{100.0 * r['cpu'] / r['sim']:.1f} % of one core per sim second"
        )
        _print_rates(r["rates"])
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    lease.release()


if __name__ == "__main__":
    main()
