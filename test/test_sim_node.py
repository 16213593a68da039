"""The simulator node in-process: topics out, /joint_commands in, lockstep determinism."""

from __future__ import annotations

import json
import math

import imageio.v2 as imageio
import pytest
import rclpy
import yaml
from conftest import spin_until, wait_for_discovery
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from safe_legged_c3bf.interfaces import topics
from safe_legged_c3bf.interfaces.base_state import quaternion_to_matrix
from safe_legged_c3bf.nodes.ros_common import from_time_msg, qos, to_time_msg
from safe_legged_c3bf.nodes.simulator_node import SimulatorNode
from safe_legged_c3bf.run.config import config_path
from safe_legged_c3bf.sim.node_params import SimulatorParams
from safe_legged_c3bf.sim.scenario import ScenarioError
from safe_legged_c3bf_msgs.msg import GroundTruthSafety, MotorCommand, Obstacle, ObstacleArray


class Probe:
    """A test node that records the simulator's topics and answers states with commands."""

    def __init__(self, executor, sim_node: SimulatorNode, name: str = "probe") -> None:
        self.node = rclpy.create_node(name, context=executor.context_for_nodes)
        executor.add_node(self.node)
        self.msgs = {key: [] for key in ("clock", "odom", "imu", "joints", "detections", "gt",
                                         "gt_obstacles", "diag")}
        for key, topic, cls in (
            ("clock", topics.CLOCK, Clock), ("odom", topics.ODOM, Odometry),
            ("imu", topics.IMU, Imu),
            ("joints", topics.JOINT_STATES, JointState),
            ("detections", topics.OBSTACLE_DETECTIONS, ObstacleArray),
            ("gt", topics.GROUND_TRUTH_SAFETY, GroundTruthSafety),
            ("gt_obstacles", topics.GROUND_TRUTH_OBSTACLES, ObstacleArray),
            ("diag", topics.DIAGNOSTICS, DiagnosticArray),
        ):
            callback = self._on_joints if key == "joints" else self.msgs[key].append
            self.node.create_subscription(cls, topic.name, callback, qos(topic) if key != "joints"
                                          else 50)
        self.pub = self.node.create_publisher(
            MotorCommand, topics.JOINT_COMMANDS.name, qos(topics.JOINT_COMMANDS)
        )
        sim = sim_node.simulation
        pose = sim.robot.spec.standing_pose
        self.names = sim.joint_names
        self.q = [pose[n] for n in self.names]
        self.answer = False
        self.answered = -1

    def command(self, stamp, q_offset: float = 0.0, kp: float = 60.0) -> MotorCommand:
        n = len(self.names)
        msg = MotorCommand(name=self.names, q=[q + q_offset for q in self.q], dq=[0.0] * n,
                           kp=[kp] * n, kd=[2.0] * n, tau=[0.0] * n)
        msg.header.stamp = stamp
        return msg

    def _on_joints(self, msg: JointState) -> None:
        """Answer every state (joint states come with each one), like the gait controller."""
        self.msgs["joints"].append(msg)
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        if self.answer and stamp > self.answered:  # one command per state, like a controller
            self.answered = stamp
            # The command depends on the state, so any timing dependence would show.
            self.pub.publish(self.command(msg.header.stamp, 0.2 * msg.position[2]))


def make_node(executor, **params) -> SimulatorNode:
    overrides = [Parameter(k, value=v) for k, v in params.items()]
    node = SimulatorNode(context=executor.context_for_nodes, parameter_overrides=overrides)
    executor.add_node(node)
    return node


def test_parameter_defaults_match_config_file():
    with open(config_path("simulator.yaml"), encoding="utf-8") as f:
        values = yaml.safe_load(f)["simulator"]["ros__parameters"]
    assert values == SimulatorParams.defaults()


def test_node_publishes_state_and_consumes_commands(ros_executor, tmp_path):
    summary_path = tmp_path / "out" / "summary.json"
    video_path = tmp_path / "video.gif"
    node = make_node(ros_executor, scenario="test_minimal", real_time_factor=0.0,
                     summary_path=str(summary_path), video_path=str(video_path), video_fps=5.0)
    probe = Probe(ros_executor, node)
    assert wait_for_discovery(ros_executor, probe.pub)
    got = probe.msgs
    # Before any command: /clock and the state at t = 0 are published, physics holds.
    assert spin_until(ros_executor, lambda: got["clock"] and got["odom"] and got["joints"], 15)
    assert node.waiting_for_command and node.simulation.time == 0.0
    # Oracle perception (the default): detections, no raw sensor data.
    assert probe.node.count_publishers(topics.OBSTACLE_DETECTIONS.name) == 1
    assert probe.node.count_publishers(topics.SCAN.name) == 0
    assert probe.node.count_publishers(topics.POINTS.name) == 0
    assert all(from_time_msg(m.clock) == 0.0 for m in got["clock"])
    odom = got["odom"][-1]
    assert odom.header.frame_id == topics.ODOM_FRAME and odom.child_frame_id == topics.BASE_FRAME
    assert odom.pose.pose.position.z == pytest.approx(0.32, abs=0.01)
    assert list(got["joints"][-1].name) == node.simulation.joint_names
    # A non-finite command is rejected and does not start physics.
    bad = probe.command(odom.header.stamp)
    bad.q[0] = math.nan
    probe.pub.publish(bad)
    assert spin_until(ros_executor, lambda: node.simulation.rejected_commands == 1, 10)
    assert node.waiting_for_command
    # Answer every state with a standing command until the scenario ends.
    probe.answer = True
    probe.pub.publish(probe.command(odom.header.stamp))
    assert spin_until(ros_executor, lambda: node.finished, 40)
    assert spin_until(
        ros_executor,
        lambda: any(s.message == "finished" for m in got["diag"] for s in m.status), 10,
    )
    clock = [from_time_msg(m.clock) for m in got["clock"]]
    assert clock == sorted(clock) and clock[-1] == pytest.approx(2.0)
    joints = got["joints"][-1]
    assert len(joints.position) == len(joints.velocity) == len(joints.effort) == 12
    assert any(abs(e) > 0.1 for e in joints.effort)  # the drivers hold the robot up
    detections = [d for m in got["detections"] for d in m.obstacles]
    assert detections and {d.id for d in detections} == {"pillar", "mover"}
    assert all(d.velocity_source == Obstacle.VELOCITY_UNKNOWN for d in detections)
    assert all(d.velocity.x == d.velocity.y == d.velocity.z == 0.0 for d in detections)
    truth = got["gt_obstacles"][-1].obstacles
    mover = next(o for o in truth if o.id == "mover")
    assert mover.velocity.y == pytest.approx(0.5)
    script = next(o for o in node.simulation.obstacles if o.id == "mover").script
    expected, _ = script.state(from_time_msg(got["gt_obstacles"][-1].header.stamp))
    assert (mover.center.x, mover.center.y, mover.center.z) == pytest.approx(tuple(expected))
    assert from_time_msg(got["gt_obstacles"][-1].header.stamp) == pytest.approx(2.0)
    assert mover.velocity_source == Obstacle.VELOCITY_MEASURED
    assert got["gt"] and not got["gt"][-1].fallen and got["gt"][-1].min_distance > 0.0
    assert got["gt"][-1].header.frame_id == topics.ODOM_FRAME
    # Standing still: the IMU's specific force is gravity, upwards, seen from base_link.
    imu = got["imu"][-1]
    assert imu.header.frame_id == topics.BASE_FRAME
    assert from_time_msg(imu.header.stamp) == pytest.approx(2.0)
    o = imu.orientation
    up = quaternion_to_matrix([o.x, o.y, o.z, o.w]).T @ [0.0, 0.0, 9.81]
    force = imu.linear_acceleration
    assert (force.x, force.y, force.z) == pytest.approx(tuple(up), abs=0.3)
    summary = json.loads(summary_path.read_text())
    assert summary["finished"] and summary["rejected_commands"] == 1
    frames = imageio.mimread(video_path)
    assert len(frames) == 10 and frames[0].shape[:2] == (240, 320)  # 5 fps for 2 s
    assert summary["sim_time"] == pytest.approx(2.0) and not summary["fell"]
    assert summary["collision_count"] == 0 and summary["driver_timeouts"] == 0


def _paced_run(executor, tmp_path, name: str, answer: bool) -> dict:
    """test_minimal for 0.5 s at real-time factor 1; the probe sends a first command and
    answers every state (``answer``) or none; the simulator's summary."""
    scenario = yaml.safe_load(config_path("scenarios", "test_minimal.yaml").read_text())
    scenario.update(duration=0.5, name=name)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(scenario))
    node = make_node(executor, scenario=str(path), real_time_factor=1.0)
    probe = Probe(executor, node, name=f"{name}_probe")
    assert wait_for_discovery(executor, probe.pub)
    probe.answer = answer
    probe.pub.publish(probe.command(to_time_msg(0.0)))
    assert spin_until(executor, lambda: node.finished, 20)
    summary = node.summary()
    for n in (node, probe.node):
        executor.remove_node(n)
        n.destroy_node()
    return summary


def test_real_time_factor_paces_physics(ros_executor, tmp_path):
    summary = _paced_run(ros_executor, tmp_path, "paced", answer=True)
    # Never ahead of the schedule by more than one 4 ms state period of sim time; behind it
    # only as far as a busy machine makes it.
    assert 0.05 < summary["achieved_real_time_factor"] <= 0.5 / (0.5 - 0.004)
    assert summary["commands_received"] > 10


def _lockstep_run(executor, scenario_path: str, summary_path: str):
    node = make_node(executor, scenario=scenario_path, real_time_factor=0.0, lockstep=True,
                     lockstep_timeout=5.0, summary_path=summary_path)
    probe = Probe(executor, node, name="lockstep_probe")
    probe.answer = True
    assert wait_for_discovery(executor, probe.pub)
    assert spin_until(executor, lambda: node.finished, 40)
    sim = node.simulation
    # Every detection frame published must have arrived before comparing runs.
    assert spin_until(executor, lambda: len(probe.msgs["detections"]) == sim.perception.frames, 10)
    result = {
        "position": tuple(sim.base_state().position),
        "joints": tuple(sim.joint_state().position),
        "detections": [(d.id, d.center.x, d.center.y) for m in probe.msgs["detections"]
                       for d in m.obstacles],
        "summary": node.summary(),
    }
    for n in (node, probe.node):
        executor.remove_node(n)
        n.destroy_node()
    return result


def test_lockstep_runs_are_identical(ros_executor, tmp_path):
    scenario = yaml.safe_load(config_path("scenarios", "test_minimal.yaml").read_text())
    scenario.update(duration=0.3, name="lockstep")
    scenario["perception"]["dropout_probability"] = 0.3
    path = tmp_path / "lockstep.yaml"
    path.write_text(yaml.safe_dump(scenario))
    runs = [_lockstep_run(ros_executor, str(path), str(tmp_path / f"s{i}.json")) for i in range(2)]
    for run in runs:
        summary = run["summary"]
        assert summary["finished"] and summary["lockstep_timeouts"] == 0
        assert summary["commands_received"] == 75  # one per 4 ms state period
    assert runs[0]["position"] == runs[1]["position"]
    assert runs[0]["joints"] == runs[1]["joints"]
    assert runs[0]["detections"] == runs[1]["detections"] and runs[0]["detections"]


def test_bad_scenario_parameter(ros_executor, tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("obstacles:\n  - {id: x, position: [1, 0], semi_axes: [0.2, 0]}\n")
    with pytest.raises(ScenarioError, match=r"obstacles\[0\].semi_axes: must be two positive"):
        SimulatorNode(context=ros_executor.context_for_nodes,
                      parameter_overrides=[Parameter("scenario", value=str(path))])


def test_a_driver_timeout_says_how_late_the_controller_was(ros_executor, tmp_path):
    """Paced by the wall clock, a silent controller shows as wall time since its last command."""
    summary = _paced_run(ros_executor, tmp_path, "silent", answer=False)  # one command only
    assert summary["driver_timeouts"] == 1
    (event,) = summary["driver_timeout_details"]
    assert event["t"] == pytest.approx(0.1, abs=0.01)
    # 0.1 s of sim time at real time: the controller was silent >= ~0.1 s of wall time, and
    # physics was on schedule (the timeout is the controller's, not a catch-up burst).
    assert event["wall_since_command"] > 0.08
    assert event["behind_schedule"] < 0.05
