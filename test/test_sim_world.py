"""The ROS-free world: standing, obstacle scripts, perception noise, ground truth, camera."""

from __future__ import annotations

import array
import json
import math

import numpy as np
import pybullet
import pytest

from safe_legged_c3bf.interfaces.joint_command import JointCommand
from safe_legged_c3bf.sim.camera import CameraConfig
from safe_legged_c3bf.sim.motor_driver import DriverMode
from safe_legged_c3bf.sim.obstacles import (
    HORIZONTAL,
    VELOCITY_MEASURED,
    VELOCITY_UNKNOWN,
    MotionScript,
)
from safe_legged_c3bf.sim.scenario import MotionConfig, parse_scenario
from safe_legged_c3bf.sim.world import Simulation


def scenario(obstacles=(), duration=2.0, **extra):
    data = {
        "name": "unit",
        "robot": {"kind": "quadruped"},
        "goal": {"position": [3.0, 0.0]},
        "duration": duration,
        "seed": 11,
        "obstacles": list(obstacles),
    }
    data.update(extra)
    return parse_scenario(data)


def stand_command(sim: Simulation) -> JointCommand:
    pose = sim.robot.spec.standing_pose
    return JointCommand(sim.joint_names, [pose[n] for n in sim.joint_names], 0.0, 60.0, 2.0, 0.0)


def run_standing(sim: Simulation, seconds: float, every: int = 20, log=None) -> None:
    command = stand_command(sim)
    steps = int(round(seconds / sim.physics_dt))
    for k in range(steps):
        if k % every == 0:
            assert sim.set_command(command)
        sim.step()
        if log is not None:
            log(sim)


def test_a1_stands_10_s_under_constant_command():
    # Nominal standing height: thigh and calf 0.2 m at +-0.8 rad from vertical + toe radius.
    nominal = 2 * 0.2 * math.cos(0.8) + 0.02
    heights = []
    with Simulation(scenario(duration=10.0)) as sim:
        run_standing(sim, 10.0, log=lambda s: heights.append(s.ground_truth.base_height))
        assert sim.finished and sim.time == pytest.approx(10.0)
        summary = sim.summary()
        position = sim.base_state().position
    settled = np.array(heights[200:])  # after the 2 cm drop from the spawn height
    assert np.all(np.abs(settled - nominal) < 0.02), (settled.min(), settled.max())
    assert not summary["fell"] and summary["driver_timeouts"] == 0
    assert np.hypot(*position[:2]) < 0.02  # no drift


def test_driver_waits_then_damps_after_timeout():
    with Simulation(scenario(), command_timeout=0.05) as sim:
        sim.step(5)
        assert sim.driver_mode is DriverMode.WAITING
        sim.set_command(stand_command(sim))
        sim.step(10)
        assert sim.driver_mode is DriverMode.ACTIVE
        sim.step(60)
        assert sim.driver_mode is DriverMode.DAMPING and sim.driver_timeouts == 1
        # when: the only command at step 5, the timeout 0.05 s later
        assert len(sim.driver_timeout_times) == 1
        assert sim.driver_timeout_times[0] == pytest.approx(5 * sim.physics_dt + 0.05, abs=2e-3)
        bad = stand_command(sim)
        bad.q[3] = math.nan
        assert not sim.set_command(bad)
        assert not sim.set_command_arrays(sim.joint_names, [0.0] * 3, 0, 0, 0, 0)
        assert sim.rejected_commands == 2


def test_motion_scripts():
    still = MotionScript((1.0, 2.0, 0.5), MotionConfig())
    assert np.allclose(still.state(5.0)[0], [1.0, 2.0, 0.5]) and math.isinf(still.next_change(0))
    cv = MotionScript((0.0, 0.0, 0.5), MotionConfig("constant_velocity", (0.5, -0.2, 0.0),
                                                    start_time=1.0))
    assert np.allclose(cv.state(0.5)[0], [0, 0, 0.5]) and np.allclose(cv.state(0.5)[1], 0)
    assert np.allclose(cv.state(3.0)[0], [1.0, -0.4, 0.5]) and cv.next_change(0.2) == 1.0
    pp = MotionScript((0.0, 0.0, 0.5), MotionConfig("waypoints", waypoints=((2.0, 0.0, 0.5),
                                                                            (2.0, 1.0, 0.5)),
                                                    speed=1.0, mode="pingpong"))
    assert pp.period == pytest.approx(6.0)
    assert np.allclose(pp.state(1.0)[0], [1, 0, 0.5]) and np.allclose(pp.state(1.0)[1], [1, 0, 0])
    assert np.allclose(pp.state(2.5)[0], [2, 0.5, 0.5]) and np.allclose(pp.state(2.5)[1], [0, 1, 0])
    assert np.allclose(pp.state(3.5)[0], [2, 0.5, 0.5])
    assert np.allclose(pp.state(3.5)[1], [0, -1, 0])
    assert np.allclose(pp.state(5.0)[0], [1, 0, 0.5]) and np.allclose(pp.state(5.0)[1], [-1, 0, 0])
    assert np.allclose(pp.state(7.0)[0], [1, 0, 0.5])  # periodic
    assert pp.next_change(1.0) == pytest.approx(2.0) and pp.next_change(2.2) == pytest.approx(3.0)
    stop = MotionScript((0.0, 0.0, 0.5), MotionConfig("waypoints", waypoints=((1.0, 0.0, 0.5),),
                                                      speed=0.5, mode="stop"))
    assert np.allclose(stop.state(10.0)[0], [1, 0, 0.5]) and np.allclose(stop.state(10.0)[1], 0)


def test_moving_obstacle_body_follows_its_script():
    obstacles = [
        {"id": "cv", "position": [3.0, -2.0], "semi_axes": [0.2, 0.2],
         "motion": {"type": "constant_velocity", "velocity": [0.0, 0.8]}},
        {"id": "pp", "position": [4.0, 0.0], "semi_axes": [0.3, 0.1], "orientation": 0.7,
         "motion": {"type": "waypoints", "waypoints": [[4.5, 0.0], [4.5, 0.4]], "speed": 1.0,
                    "start_time": 0.1}},
    ]
    with Simulation(scenario(obstacles)) as sim:
        for _ in range(8):
            sim.step(150)
            for obstacle, truth in zip(sim.obstacles, sim.obstacle_states(), strict=True):
                position, velocity = obstacle.script.state(sim.time)
                assert np.allclose(obstacle.body_position(), position, atol=1e-6)
                assert np.allclose(truth.center, position) and np.allclose(truth.velocity, velocity)
                assert truth.velocity_source == VELOCITY_MEASURED
                # The body moves at the script's velocity of the step that just ended.
                _, step_velocity = obstacle.script.state(sim.time - sim.physics_dt / 2)
                body_velocity, _ = pybullet.getBaseVelocity(obstacle.body_id,
                                                             physicsClientId=sim.client)
                assert np.allclose(body_velocity, step_velocity, atol=1e-9)
        # cv moved 0.8 m/s for 1.2 s; pp went 0.5 m out, 0.4 m along, and is coming back.
        assert np.allclose(sim.obstacle_states()[0].center[:2], [3.0, -2.0 + 0.8 * 1.2])
        assert np.allclose(sim.obstacle_states()[1].center[:2], [4.5, 0.4 - 0.2])


def test_obstacle_geometry():
    obstacles = [
        {"id": "v", "position": [2.0, 0.0], "semi_axes": [0.4, 0.1], "orientation": math.pi / 2,
         "extent": 1.0},
        {"id": "h", "plane": "horizontal", "position": [3.0, 0.5, 0.6], "semi_axes": [0.2, 0.05],
         "extent": 2.0},
    ]
    with Simulation(scenario(obstacles)) as sim:
        (lo, hi) = pybullet.getAABB(sim.obstacles[0].body_id, physicsClientId=sim.client)
        assert np.allclose(np.subtract(hi, lo), [0.2, 0.8, 1.0], atol=0.01)  # a along y
        assert lo[2] == pytest.approx(0.0, abs=0.01)  # stands on the ground
        (lo, hi) = pybullet.getAABB(sim.obstacles[1].body_id, physicsClientId=sim.client)
        assert np.allclose(np.subtract(hi, lo), [0.4, 2.0, 0.1], atol=0.01)
        assert np.allclose(np.add(hi, lo) / 2, [3.0, 0.5, 0.6], atol=0.01)
        assert sim.obstacle_states()[1].plane == HORIZONTAL


def test_detection_noise_statistics():
    std, bias = np.array([0.05, 0.03, 0.02]), np.array([0.02, -0.015, 0.01])
    sc = scenario(
        [{"id": "p", "position": [2.0, 1.0], "semi_axes": [0.2, 0.2]}],
        perception={"position_noise_std": std.tolist(), "position_noise_bias": bias.tolist(),
                    "dropout_probability": 0.1},
    )
    errors, frames = [], 1000
    with Simulation(sc) as sim:
        truth = sim.obstacle_states()[0].center
        for _ in range(frames):
            for d in sim.detections():
                assert d.id == "p" and d.velocity_source == VELOCITY_UNKNOWN
                assert np.all(d.velocity == 0)
                assert np.allclose(np.diag(d.position_covariance), std**2)
                errors.append(d.center - truth)
        assert sim.detections(include_ids=False)[0].id == ""
    errors = np.array(errors)
    assert np.all(np.abs(errors.mean(axis=0) - bias) < 0.2 * np.abs(bias))
    assert np.all(np.abs(errors.std(axis=0) - std) < 0.2 * std)
    assert abs((1 - len(errors) / frames) - 0.1) < 0.02


def test_detections_are_reproducible_and_range_limited():
    obstacles = [{"id": "near", "position": [1.5, 0.0], "semi_axes": [0.2, 0.2]},
                 {"id": "far", "position": [9.0, 0.0], "semi_axes": [0.2, 0.2]}]
    sc = scenario(obstacles, perception={"max_range": 4.0, "dropout_probability": 0.3})
    runs = []
    for _ in range(2):
        with Simulation(sc) as sim:
            frames = [[(d.id, *d.center) for d in sim.detections()] for _ in range(50)]
        runs.append(frames)
    assert runs[0] == runs[1]
    assert all(det[0] == "near" for frame in runs[0] for det in frame)


def test_scripted_collision_is_detected_and_counted(tmp_path):
    # A post slides past the standing robot's right side along -x and clips the right feet
    # (front, then rear ~0.25 s later); a pillar far away is never hit.
    obstacles = [
        {"id": "sweeper", "position": [1.5, -0.24], "semi_axes": [0.1, 0.1], "extent": 1.0,
         "motion": {"type": "constant_velocity", "velocity": [-1.5, 0.0], "start_time": 0.3}},
        {"id": "pillar", "position": [3.0, 2.0], "semi_axes": [0.2, 0.2]},
    ]
    results = {}
    for debounce in (0.5, 0.0):
        samples = []
        sc = scenario(obstacles, duration=2.0, ground_truth={"collision_debounce": debounce})
        with Simulation(sc) as sim:
            run_standing(sim, 2.0, log=lambda s, out=samples: out.append(s.ground_truth))
            summary = sim.write_summary(tmp_path / f"summary_{debounce}.json")
        results[debounce] = summary
        touching = [s for s in samples if s.in_collision]
        assert touching and all(s.contact_obstacle_ids == ("sweeper",) for s in touching)
        assert samples[0].min_distance > 0.3 and not samples[0].in_collision
        assert not summary["fell"]
    summary = results[0.5]
    assert summary["collision_count"] == 1  # both touches within the debounce time
    event = summary["collisions"][0]
    assert event["obstacle_id"] == "sweeper" and 1.0 < event["time"] < 1.3
    assert any(link.startswith("FR") for link in event["links"])
    assert summary["min_distance"] <= 0.0 and summary["min_distance_obstacle"] == "sweeper"
    assert 0.0 < summary["time_in_collision"] < 0.5
    assert results[0.0]["collision_count"] == 2  # rising edges without debouncing
    saved = json.loads((tmp_path / "summary_0.5.json").read_text())
    assert saved["collision_count"] == 1 and saved["collisions"] == summary["collisions"]


def test_min_distance_is_exact_when_near():
    # A pillar 0.2 m in front of the A1's trunk (front face at x = +0.1335 m).
    obstacles = [{"id": "p", "position": [0.5335, 0.0], "semi_axes": [0.2, 0.2]}]
    with Simulation(scenario(obstacles)) as sim:
        run_standing(sim, 0.5)
        gt = sim.ground_truth
        assert gt.min_distance_exact and gt.closest_obstacle_id == "p"
        assert 0.1 < gt.min_distance <= 0.2 + 0.01




def _brute_force_ground_truth(sim: Simulation) -> tuple[float, set[str]]:
    """Min distance (search to the cutoff) and contacts (all robot contacts), as before."""
    cfg = sim.scenario.ground_truth
    robot, client = sim.robot.body_id, sim.client
    distance = math.inf
    for obstacle in sim.obstacles:
        points = pybullet.getClosestPoints(
            robot, obstacle.body_id, cfg.distance_cutoff, physicsClientId=client
        )
        distance = min([distance] + [p[8] for p in points])
    ids = {o.body_id: o.id for o in sim.obstacles}
    touching = {
        ids[p[2]] for p in pybullet.getContactPoints(bodyA=robot, physicsClientId=client)
        if p[2] in ids and p[8] <= cfg.contact_tolerance
    }
    return distance, touching


def test_ground_truth_shortcuts_match_brute_force():
    # Exact queries at every step for every obstacle within the cutoff: the minimum distance
    # must equal a search of every link pair out to the cutoff, and the contacts those of
    # all the robot's contact points, at every step (approach, touch, scrape, leave, and a
    # teleport that breaks the speed bound the query searches with).
    obstacles = [
        {"id": "sweeper", "position": [1.5, -0.24], "semi_axes": [0.1, 0.1], "extent": 1.0,
         "motion": {"type": "constant_velocity", "velocity": [-1.5, 0.0], "start_time": 0.2}},
        {"id": "walker", "position": [0.28, 0.8], "semi_axes": [0.15, 0.1], "orientation": 0.4,
         "motion": {"type": "waypoints", "waypoints": [[0.28, -0.8]], "speed": 0.8,
                    "mode": "pingpong"}},
        {"id": "bar", "plane": "horizontal", "position": [0.3, 0.0, 0.42],
         "semi_axes": [0.05, 0.05], "extent": 3.0},
        {"id": "far", "position": [4.0, 3.0], "semi_axes": [0.3, 0.3]},
    ]
    sc = scenario(obstacles, duration=2.0, ground_truth={
        "exact_distance_below": 1.0, "max_check_interval": 0.001, "collision_debounce": 0.0,
    })
    touched = set()
    with Simulation(sc) as sim:
        command = stand_command(sim)
        for k in range(1500):
            if k % 20 == 0:
                sim.set_command(command)
            if k == 700:  # far faster than max_closing_speed: away from the obstacles
                pos, quat = pybullet.getBasePositionAndOrientation(sim.robot.body_id)
                pybullet.resetBasePositionAndOrientation(
                    sim.robot.body_id, (pos[0] - 0.4, pos[1], pos[2]), quat
                )
            sim.step()
            gt = sim.ground_truth
            distance, touching = _brute_force_ground_truth(sim)
            if distance < sc.ground_truth.distance_cutoff:
                assert gt.min_distance_exact and gt.min_distance == distance, k
            assert set(gt.contact_obstacle_ids) == touching, k
            assert gt.in_collision == bool(touching)
            touched |= touching
        monitor = sim.monitor
        assert touched == {"sweeper", "walker"}
        assert monitor.distance_queries > 2000 and monitor.distance_requeries >= 1
def test_fall_detection():
    sc = scenario(ground_truth={"fall_min_height": 0.2})
    with Simulation(sc) as sim:
        sim.step(2000)  # no command: the drivers only damp and the robot sits down
        summary = sim.summary()
    assert summary["fell"] and summary["fall_time"] is not None
    assert sim.ground_truth.fallen


def test_camera_frames():
    with Simulation(scenario(duration=0.1)) as sim:
        sim.record_every(25, CameraConfig(width=64, height=48))
        sim.step(100)
        frames = sim.take_frames()
        assert len(frames) == 4 and sim.take_frames() == []
        assert frames[0].shape == (48, 64, 3) and frames[0].dtype == np.uint8
        assert frames[0].std() > 5  # not a blank image


def test_lockstep_style_determinism():
    obstacles = [{"id": "m", "position": [1.0, -1.0], "semi_axes": [0.2, 0.2],
                  "motion": {"type": "waypoints", "waypoints": [[1.0, 1.0]], "speed": 1.0}}]
    results = []
    for _ in range(2):
        with Simulation(scenario(obstacles, perception={"dropout_probability": 0.2})) as sim:
            command = stand_command(sim)
            for k in range(300):
                if k % 2 == 0:
                    command.q[0] = 0.1 * math.sin(0.01 * k)
                    sim.set_command(command)
                sim.step()
            dets = [(d.id, *d.center) for d in sim.detections()]
            results.append((tuple(sim.base_state().position), tuple(sim.joint_state().position),
                            dets))
    assert results[0] == results[1]


def test_base_state_is_base_link_not_centre_of_mass():
    # The A1's centre of mass is 1.3 cm ahead of base_link; odom must report base_link.
    with Simulation(scenario()) as sim:
        start = sim.base_state()
        assert np.allclose(start.position, [0.0, 0.0, sim.robot.spec.spawn_height], atol=1e-9)
        sim.step(150)  # no command: the robot sags and tips, so the base moves and rotates
        before = sim.base_state()
        sim.step(1)
        after = sim.base_state()
    finite_difference = (after.position - before.position) / sim.physics_dt
    mid_velocity = (before.linear_velocity_world + after.linear_velocity_world) / 2
    assert np.linalg.norm(finite_difference) > 0.05
    assert np.allclose(finite_difference, mid_velocity, atol=2e-3)


def test_driver_apply_matches_compute_torques():
    with Simulation(scenario()) as sim:
        command = stand_command(sim)
        command.tau[:] = np.linspace(-40.0, 40.0, len(command.tau))  # some beyond the limits
        sim.set_command(command)
        sim.step(20)
        state = sim.joint_state()
        expected = sim.driver.compute_torques(state.position, state.velocity, sim.time)
        applied = sim.driver.apply(sim.time)
        assert np.array_equal(applied, expected)
        assert np.all(np.abs(applied) <= sim.robot.torque_limits)


def test_command_arrays_validation_and_partial_commands():
    with Simulation(scenario()) as sim:
        names = sim.joint_names
        n = len(names)
        full = stand_command(sim)

        def arrays(command):
            return [array.array("d", getattr(command, f)) for f in ("q", "dq", "kp", "kd", "tau")]

        assert sim.set_command_arrays(names, *arrays(full))
        gains = [list(g) for g in sim.driver._gains]
        # Rejected (counted, previous command kept): non-finite, negative gain, unknown joint.
        bad_q, bad_kd = arrays(full), arrays(full)
        bad_q[0][3] = math.inf
        bad_kd[3][0] = -1.0
        assert not sim.set_command_arrays(names, *bad_q)
        assert not sim.set_command_arrays(names, *bad_kd)
        assert not sim.set_command_arrays(["nope"], [0.0], [0.0], [1.0], [1.0], [0.0])
        # Malformed: array sizes that match neither the names nor 1.
        assert not sim.set_command_arrays(names, [0.0, 0.0], 0.0, 1.0, 1.0, 0.0)
        assert not sim.set_command_arrays(names, "x", 0.0, 1.0, 1.0, 0.0)
        assert sim.rejected_commands == 5 and sim.driver.rejected_commands == 3
        assert [list(g) for g in sim.driver._gains] == gains and sim.commands_received == 1
        # A partial command, joints out of order, scalars broadcast: only those joints change.
        assert sim.set_command_arrays([names[5], names[2]], [0.5, 0.25], 0, 7, 1.5, 2)
        kp, q, kd, dq, tau = sim.driver._gains
        assert (q[5], q[2], kp[5], kp[2], kd[2], tau[5]) == (0.5, 0.25, 7.0, 7.0, 1.5, 2.0)
        assert kp[0] == 60.0 and q[0] == full.q[0] and sim.commands_received == 2
        # The array path and the JointCommand path drive the robot identically.
        sim.step(50)
        with Simulation(scenario()) as twin:
            twin.set_command(full)
            partial = JointCommand([names[5], names[2]], [0.5, 0.25], 0, 7, 1.5, 2)
            twin.set_command(partial)
            twin.step(50)
            assert twin.joint_lists() == sim.joint_lists()
        assert len(sim.driver._gains[0]) == n
