"""Simulated LiDAR and 3-D sensor: analytic ranges, REP-117 values, noise, the robot itself."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pybullet
import pytest

from safe_legged_c3bf.interfaces.joint_command import JointCommand
from safe_legged_c3bf.interfaces.rotations import quaternion_to_matrix, yaw_to_quaternion
from safe_legged_c3bf.interfaces.sensor_mounts import (
    DEPTH_FRAME,
    LIDAR_FRAME,
    SensorMount,
    default_mounts,
)
from safe_legged_c3bf.sim.perception import PerceptionModel
from safe_legged_c3bf.sim.range_sensors import DepthConfig, DepthSensor, Lidar2D, LidarConfig
from safe_legged_c3bf.sim.scenario import parse_scenario
from safe_legged_c3bf.sim.world import Simulation

EXACT = {"range_noise_std": 0.0, "dropout_probability": 0.0}


@pytest.fixture
def client():
    c = pybullet.connect(pybullet.DIRECT)
    yield c
    pybullet.disconnect(c)


def add_body(client, shape_type, position, **shape):
    shape_id = pybullet.createCollisionShape(shape_type, physicsClientId=client, **shape)
    return pybullet.createMultiBody(0.0, shape_id, basePosition=position, physicsClientId=client)


def ray_box(origin, dirs, lo, hi):
    """Range (m) along unit ``dirs`` from ``origin`` to an axis-aligned box (inf: missed)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (np.asarray(lo) - origin) / dirs, (np.asarray(hi) - origin) / dirs
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((far >= near) & (far > 0), np.maximum(near, 0.0), np.inf)


def ray_vertical_cylinder(origin, dirs, center, radius):
    """Range along horizontal unit ``dirs`` to a vertical cylinder's side (inf: missed)."""
    rel = origin[:2] - np.asarray(center[:2])
    b = dirs[:, :2] @ rel
    disc = b**2 - (rel @ rel - radius**2)
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(disc)
    return np.where((disc >= 0) & (t > 0), t, np.inf)


def scenario(obstacles=(), kind="quadruped", **perception):
    return parse_scenario({
        "robot": {"kind": kind}, "goal": {"position": [3.0, 0.0]}, "duration": 2.0, "seed": 5,
        "obstacles": list(obstacles), "perception": {"source": "sensors", **perception},
    })


def stand(sim: Simulation, seconds: float) -> None:
    pose = sim.robot.spec.standing_pose
    command = JointCommand(
        sim.joint_names, [pose[n] for n in sim.joint_names], 0.0, 60.0, 2.0, 0.0
    )
    for k in range(int(round(seconds / sim.physics_dt))):
        if k % 20 == 0:
            sim.set_command(command)
        sim.step()


def to_odom(sim: Simulation, sensor, points: np.ndarray) -> np.ndarray:
    """Points (m, sensor frame) of ``sensor`` on the robot of ``sim`` into odom."""
    pos, quat = sim.base_state().position, sim.base_state().orientation
    rotation = quaternion_to_matrix(quat)
    origin = pos + rotation @ np.asarray(sensor.mount.xyz)
    return origin + points @ (rotation @ sensor.mount.rotation()).T


# ------------------------------------------------------------------ geometry against analytic


def test_lidar_ranges_match_a_box_and_a_cylinder(client):
    box_lo, box_hi = np.array([2.5, -0.5, 0.0]), np.array([3.3, 1.5, 2.0])
    add_body(client, pybullet.GEOM_BOX, ((box_lo + box_hi) / 2).tolist(),
             halfExtents=((box_hi - box_lo) / 2).tolist())
    cyl_center, radius = np.array([-1.0, -3.0, 1.0]), 0.4
    add_body(client, pybullet.GEOM_CYLINDER, cyl_center.tolist(), radius=radius, height=2.0)
    mount = SensorMount(LIDAR_FRAME, (0.1, 0.05, 0.1), (0.0, 0.0, 0.2))
    lidar = Lidar2D(client, LidarConfig(**EXACT), mount, seed=0)
    base, yaw = np.array([0.5, -0.2, 0.3]), math.radians(30.0)
    ranges = lidar.scan(base, yaw_to_quaternion(yaw))
    # The same composition written out: planar yaw of the base, then the mount's offset and yaw.
    c, s = math.cos(yaw), math.sin(yaw)
    origin = base + np.array([c * 0.1 - s * 0.05, s * 0.1 + c * 0.05, 0.1])
    heading = yaw + 0.2 + lidar.angles
    dirs = np.column_stack([np.cos(heading), np.sin(heading), np.zeros_like(heading)])
    expected = np.minimum(ray_box(origin, dirs, box_lo, box_hi),
                          ray_vertical_cylinder(origin, dirs, cyl_center, radius))
    expected[expected > 8.0] = np.inf
    assert ranges.dtype == np.float32 and ranges.shape == (360,)
    both = np.isfinite(expected) & np.isfinite(ranges)
    assert np.count_nonzero(np.isfinite(expected) != np.isfinite(ranges)) <= 2  # grazing rays
    assert both.sum() > 40
    assert np.max(np.abs(ranges[both] - expected[both])) < 2e-3
    # The cylinder is seen too (its rays end on its side).
    to_cylinder = np.isfinite(ray_vertical_cylinder(origin, dirs, cyl_center, radius))
    assert np.all(np.isfinite(ranges[to_cylinder][1:-1]))


def test_depth_ranges_match_a_box_from_a_pitched_mount(client):
    box_lo, box_hi = np.array([1.5, -0.4, 0.0]), np.array([1.9, 0.6, 0.5])
    add_body(client, pybullet.GEOM_BOX, ((box_lo + box_hi) / 2).tolist(),
             halfExtents=((box_hi - box_lo) / 2).tolist())
    mount = SensorMount(DEPTH_FRAME, (0.2, 0.0, 0.05), (0.0, 0.3, 0.0))  # 0.3 rad down
    depth = DepthSensor(client, DepthConfig(columns=32, rows=24, **EXACT), mount, seed=0)
    base = np.array([0.0, 0.0, 0.5])
    ranges = depth.cast(base, [0.0, 0.0, 0.0, 1.0])
    pitch = 0.3
    rotation = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0],
                         [-math.sin(pitch), 0, math.cos(pitch)]])
    dirs = depth.directions @ rotation.T
    expected = ray_box(base + [0.2, 0.0, 0.05], dirs, box_lo, box_hi)
    expected[expected > 6.0] = np.inf
    assert np.count_nonzero(np.isfinite(expected) != np.isfinite(ranges)) <= 3
    both = np.isfinite(expected) & np.isfinite(ranges)
    assert both.sum() > 100
    assert np.max(np.abs(ranges[both] - expected[both])) < 2e-3
    # The cloud: the same returns as points in the sensor frame, float32, in ray order.
    depth_again = DepthSensor(client, depth.config, mount, seed=0)
    cloud = depth_again.cloud(base, [0.0, 0.0, 0.0, 1.0])
    assert cloud.dtype == np.float32 and cloud.shape == (both.sum(), 3)
    assert cloud == pytest.approx(depth.directions[both] * ranges[both, None], abs=1e-5)


def test_depth_grid_covers_its_field_of_view():
    cfg = DepthConfig(columns=4, rows=3, horizontal_fov=math.radians(90), vertical_fov=1.0)
    d = cfg.directions()
    assert d.shape == (12, 3) and np.allclose(np.linalg.norm(d, axis=1), 1.0)
    yaw = np.degrees(np.arctan2(d[:4, 1], d[:4, 0]))  # first row, left to right
    assert yaw == pytest.approx([36.87, 14.04, -14.04, -36.87], abs=0.01)  # atan(0.75), atan(0.25)
    assert d[0, 2] > 0 and d[-1, 2] < 0 and d[4, 2] == pytest.approx(0.0)  # top row first


def test_lidar_angles_full_circle_and_sector():
    angles, inc = LidarConfig(beams=4).angles()
    assert angles == pytest.approx([-math.pi, -math.pi / 2, 0.0, math.pi / 2])
    assert inc == pytest.approx(math.pi / 2)
    angles, inc = LidarConfig(beams=3, fov=math.pi).angles()
    assert angles == pytest.approx([-math.pi / 2, 0.0, math.pi / 2]) and inc == pytest.approx(
        math.pi / 2)
    assert LidarConfig(beams=2, fov=6.2832).full_circle  # a rounded 2 pi


# ------------------------------------------------------------------ REP-117, noise, drop-outs


def test_rep117_values(client):
    add_body(client, pybullet.GEOM_BOX, [0.05 + 0.5, 0.0, 0.0], halfExtents=[0.5, 0.5, 0.5])
    mount = SensorMount(LIDAR_FRAME, (0.0, 0.0, 0.0))
    cfg = LidarConfig(beams=4, **EXACT)  # beams at -pi, -pi/2, 0, pi/2
    ranges = Lidar2D(client, cfg, mount, seed=0).scan([0.0, 0.0, 0.0], [0, 0, 0, 1])
    # Straight ahead the box is 5 cm away, under range_min: -inf; elsewhere no return: +inf.
    assert ranges[2] == -np.inf and np.all(ranges[[0, 1, 3]] == np.inf)
    far = Lidar2D(client, cfg, mount, seed=0).scan([-1.0, 0.0, 0.0], [0, 0, 0, 1])
    assert far[2] == pytest.approx(1.05, abs=1e-3)
    dropped = Lidar2D(client, LidarConfig(beams=4, dropout_probability=1.0), mount, seed=0)
    assert np.all(np.isnan(dropped.scan([-1.0, 0.0, 0.0], [0, 0, 0, 1])))


def test_noise_and_dropout_statistics(client):
    add_body(client, pybullet.GEOM_BOX, [3.0, 0.0, 0.0], halfExtents=[0.5, 50.0, 1.0])
    cfg = LidarConfig(beams=90, fov=math.radians(60), range_noise_std=0.05,
                      dropout_probability=0.2)
    mount = SensorMount(LIDAR_FRAME, (0.0, 0.0, 0.0))
    lidar = Lidar2D(client, cfg, mount, seed=3)
    true = 2.5 / np.cos(lidar.angles)
    scans = np.array([lidar.scan([0.0, 0.0, 0.0], [0, 0, 0, 1]) for _ in range(200)])
    dropped = np.isnan(scans)
    n = scans.size
    assert abs(dropped.mean() - 0.2) < 4 * math.sqrt(0.2 * 0.8 / n)
    errors = (scans - true)[~dropped]
    assert np.all(np.isfinite(errors))
    assert abs(errors.mean()) < 4 * 0.05 / math.sqrt(errors.size)
    assert errors.std() == pytest.approx(0.05, rel=0.05)
    # The same seed gives the same scans; another seed others.
    again = Lidar2D(client, cfg, mount, seed=3)
    assert np.array_equal(again.scan([0, 0, 0], [0, 0, 0, 1]), scans[0], equal_nan=True)
    other = Lidar2D(client, cfg, mount, seed=4)
    assert not np.array_equal(other.scan([0, 0, 0], [0, 0, 0, 1]), scans[0], equal_nan=True)


def test_noise_beyond_range_max_is_no_return(client):
    add_body(client, pybullet.GEOM_BOX, [0.5 + 8.0, 0.0, 0.0], halfExtents=[0.5, 0.5, 0.5])
    cfg = LidarConfig(beams=4, range_max=8.0, range_noise_std=0.5, dropout_probability=0.0)
    lidar = Lidar2D(client, cfg, SensorMount(LIDAR_FRAME, (0.0, 0.0, 0.0)), seed=1)
    # The box face is at 7.999 m: a noisy value above range_max is +inf, never > range_max.
    ahead = np.array([lidar.scan([0.001, 0, 0], [0, 0, 0, 1])[2] for _ in range(50)])
    assert np.all((ahead <= 8.0) | (ahead == np.inf)) and np.any(ahead == np.inf)
    assert np.any(np.isfinite(ahead))


@pytest.mark.parametrize(
    ("cls", "kwargs", "message"),
    [
        (LidarConfig, {"beams": 0}, "lidar.beams: must be an integer within"),
        (LidarConfig, {"fov": 7.0}, "lidar.fov: must be within"),
        (LidarConfig, {"range_min": 9.0}, "lidar.range_min: must be less than range_max"),
        (LidarConfig, {"dropout_probability": math.nan}, "lidar.dropout_probability"),
        (DepthConfig, {"vertical_fov": math.pi}, "depth.vertical_fov: must be within"),
        (DepthConfig, {"columns": 1000, "rows": 1000}, "depth.rows: columns x rows"),
        (DepthConfig, {"range_noise_std": -1.0}, "depth.range_noise_std"),
        (DepthConfig, {"rate": 0.0}, "depth.rate: must be a positive number"),
    ],
)
def test_bad_configs_are_named(cls, kwargs, message):
    with pytest.raises(ValueError, match=message):
        cls(**kwargs)


# ------------------------------------------------------------------ in the simulated world


def test_depth_sees_a_bar_ahead_and_the_ground():
    bar = {"id": "bar", "plane": "horizontal", "position": [1.5, 0.0, 0.35],
           "semi_axes": [0.05, 0.05], "extent": 2.0}
    with Simulation(scenario([bar], depth=EXACT)) as sim:
        cloud = sim.depth_cloud()
        bar_id = sim.obstacles[0].body_id
        on_bar = sim.depth.hit_bodies == bar_id
        on_ground = sim.depth.hit_bodies == sim.plane_id
        points = to_odom(sim, sim.depth, cloud)
        valid = np.isfinite(sim.depth.cast(*sim._base_link_pose()))  # same rays, no noise
    assert len(points) == valid.sum()
    bar_points = points[on_bar[valid]]
    ground = points[on_ground[valid]]
    assert len(bar_points) > 50 and len(ground) > 500
    # On the bar's near side: x within its ellipse, z within its height (32-gon: 0.5 % in).
    assert np.all(np.abs(bar_points[:, 0] - 1.5) <= 0.0501)
    assert bar_points[:, 2].min() > 0.3 - 1e-3 and bar_points[:, 2].max() < 0.4 + 1e-3
    assert np.ptp(bar_points[:, 2]) > 0.05  # seen over its height, not as one line
    assert np.abs(ground[:, 2]).max() < 1e-3


def test_an_elongated_obstacle_is_hit_as_shaped():
    wall = {"id": "wall", "position": [2.5, 0.5], "semi_axes": [1.2, 0.1], "orientation": 0.4,
            "extent": 1.0}
    with Simulation(scenario([wall], lidar=EXACT)) as sim:
        ranges = sim.lidar_scan()
        hit = sim.lidar.hit_bodies == sim.obstacles[0].body_id
        world = to_odom(sim, sim.lidar, sim.lidar.directions[hit] * ranges[hit, None])
    assert hit.sum() > 10
    c, s = math.cos(0.4), math.sin(0.4)
    local = (world[:, :2] - [2.5, 0.5]) @ np.array([[c, -s], [s, c]])
    # Signed distance to the ellipse, to first order: (f - 1) / |grad f|. The body is a 32-gon
    # inscribed in it (at most a (1 - cos(pi/32)) = 5.8 mm inside) with a ~1 mm collision margin.
    f = (local[:, 0] / 1.2) ** 2 + (local[:, 1] / 0.1) ** 2
    grad = np.hypot(2 * local[:, 0] / 1.2**2, 2 * local[:, 1] / 0.1**2)
    distance = (f - 1.0) / grad
    assert np.all(distance > -0.006) and np.all(distance < 0.002), distance
    assert np.ptp(local[:, 0]) > 1.0  # seen along its length


def test_a_moving_obstacle_is_seen_where_it_is_now():
    mover = {"id": "mover", "position": [2.0, -1.2], "semi_axes": [0.2, 0.2], "extent": 1.0,
             "motion": {"type": "constant_velocity", "velocity": [0.0, 1.0]}}
    with Simulation(scenario([mover], lidar=EXACT)) as sim:
        stand(sim, 0.6)
        ranges = sim.lidar_scan()
        hit = sim.lidar.hit_bodies == sim.obstacles[0].body_id
        world = to_odom(sim, sim.lidar, sim.lidar.directions[hit] * ranges[hit, None])
        center = sim.obstacles[0].script.state(sim.time)[0]
    assert center[1] == pytest.approx(-0.6) and hit.sum() >= 3
    # 1 m/s: 1 cm is 10 ms; the points lie on the obstacle's circle around where it is now.
    distance = np.hypot(*(world[:, :2] - center[:2]).T)
    assert np.all(np.abs(distance - 0.2) < 0.005)


# ------------------------------------------------------------------ the robot's own body


@pytest.mark.parametrize("kind", ["quadruped", "biped"])
def test_default_mounts_do_not_see_the_standing_robot(kind):
    with Simulation(scenario(kind=kind)) as sim:
        sim.lidar_scan()
        sim.depth_cloud()
        assert sim.lidar.self_hits == 0 and sim.depth.self_hits == 0
        assert np.any(sim.depth.hit_bodies == sim.plane_id)  # the ground ahead is in view


def test_a1_legs_stay_out_of_view_over_the_gait_range():
    with Simulation(scenario()) as sim:
        c, body = sim.client, sim.robot.body_id
        index = dict(zip(sim.joint_names, sim.robot.joint_indices.tolist(), strict=True))
        for hip, thigh, calf in itertools.product((-0.2, 0.2), (0.3, 0.8, 1.3), (-2.4, -1.0)):
            for leg in ("FR", "FL", "RR", "RL"):
                for joint, angle in (("hip", hip), ("upper", thigh), ("lower", calf)):
                    pybullet.resetJointState(body, index[f"{leg}_{joint}_joint"], angle,
                                             physicsClientId=c)
            sim.lidar_scan()
            sim.depth_cloud()
            assert sim.lidar.self_hits == 0 and sim.depth.self_hits == 0, (hip, thigh, calf)


def test_hits_on_the_robot_are_real_returns():
    with Simulation(scenario(lidar=EXACT)) as sim:
        # A LiDAR 4 cm above the trunk, pitched down 0.5 rad: its forward beams hit the trunk.
        mount = SensorMount(LIDAR_FRAME, (-0.05, 0.0, 0.097), (0.0, 0.5, 0.0))
        lidar = Lidar2D(sim.client, LidarConfig(**EXACT), mount, 0, sim.robot.body_id)
        ranges = lidar.scan(*sim._base_link_pose())
        on_robot = lidar.hit_bodies == sim.robot.body_id
        assert lidar.self_hits == on_robot.sum() > 10
        assert np.all(np.isfinite(ranges[on_robot]) | (ranges[on_robot] == -np.inf))
        assert np.nanmin(np.abs(ranges[on_robot])) < 0.2


def test_sensor_streams_are_deterministic_and_leave_the_oracle_stream_alone():
    pillar = {"id": "p", "position": [2.0, 0.0], "semi_axes": [0.2, 0.2]}

    def run(**perception):
        with Simulation(scenario([pillar], **perception)) as sim:
            casts = [sim.lidar_scan(), sim.depth_cloud(), sim.lidar_scan(), sim.depth_cloud()]
            detections = [d.center for d in sim.detections()]
        return casts, detections

    (a, detections), (b, _) = run(), run()
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x, y, equal_nan=True)
    assert len(a[1]) != len(a[3]) or not np.array_equal(a[1], a[3])  # fresh noise per cast
    # The oracle draws from the generator it always had: the first spawn of the scenario seed.
    with Simulation(scenario([pillar])) as sim:
        model = PerceptionModel(sim.scenario.perception, np.random.SeedSequence(5).spawn(1)[0])
        expected = model.detect(sim.obstacles, sim.obstacle_states(), np.zeros(3))
    assert np.array_equal(np.array([d.center for d in expected]), np.array(detections))


def test_default_mounts_lie_outside_the_robot():
    for kind in ("quadruped", "biped"):
        with Simulation(scenario(kind=kind)) as sim:
            pos, quat = sim._base_link_pose()
            rotation = quaternion_to_matrix(quat)
            for mount in default_mounts(kind).values():
                point = np.asarray(pos) + rotation @ np.asarray(mount.xyz)
                probe = pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=0.005,
                                                      physicsClientId=sim.client)
                ball = pybullet.createMultiBody(0.0, probe, basePosition=point.tolist(),
                                                physicsClientId=sim.client)
                close = pybullet.getClosestPoints(ball, sim.robot.body_id, 0.0,
                                                  physicsClientId=sim.client)
                pybullet.removeBody(ball, physicsClientId=sim.client)
                assert not close, (kind, mount.frame_id)
