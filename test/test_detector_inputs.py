"""The detector's inputs without ROS: scan and cloud points, the pose history, the frames."""

from __future__ import annotations

import math

import numpy as np
import pytest

from safe_legged_c3bf.interfaces.sensor_mounts import (
    DEPTH_FRAME,
    LIDAR_FRAME,
    SensorMount,
    default_mounts,
    rpy_to_matrix,
)
from safe_legged_c3bf.perception.pose_history import PoseHistory, PoseLookup
from safe_legged_c3bf.perception.self_filter import (
    SelfBox,
    default_self_box,
    outside_self_box,
    resolve_self_box,
)
from safe_legged_c3bf.perception.sensor_frame import make_frame
from safe_legged_c3bf.perception.sensor_points import (
    FLOAT32,
    FLOAT64,
    CloudField,
    SensorInputError,
    cloud_points,
    scan_points,
    to_parent,
)

XYZ32 = [CloudField("x", 0, FLOAT32), CloudField("y", 4, FLOAT32), CloudField("z", 8, FLOAT32)]


def test_scan_drops_nan_inf_and_out_of_range_returns():
    ranges = [1.0, math.nan, math.inf, -math.inf, 0.01, 2.0, 31.0, 30.0]
    sp = scan_points(ranges, angle_min=0.0, angle_increment=math.pi / 2, range_min=0.05,
                     range_max=30.0, time_increment=0.001)
    assert sp.beams.tolist() == [0, 5, 7]
    assert sp.beam_count == 8
    np.testing.assert_allclose(sp.points[0], [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(sp.points[1], [0.0, 2.0, 0.0], atol=1e-12)  # 5 * 90 deg
    np.testing.assert_allclose(sp.points[2], [0.0, -30.0, 0.0], atol=1e-9)  # 7 * 90 deg
    np.testing.assert_allclose(sp.beam_times, [0.0, 0.005, 0.007])
    assert np.all(np.isfinite(sp.points))


def test_an_all_invalid_scan_gives_no_point():
    sp = scan_points([math.nan, math.inf, -math.inf], -1.0, 0.1, 0.1, 10.0)
    assert sp.points.shape == (0, 3)


@pytest.mark.parametrize("geometry", [
    dict(angle_min=math.nan), dict(angle_increment=math.inf), dict(range_min=math.nan),
    dict(range_max=math.nan), dict(range_min=5.0, range_max=1.0), dict(range_min=-1.0),
    dict(angle_increment=0.0), dict(time_increment=0.01),
])
def test_malformed_scan_geometry_is_a_clear_error(geometry):
    args = dict(angle_min=0.0, angle_increment=0.01, range_min=0.1, range_max=10.0,
                time_increment=0.0) | geometry
    with pytest.raises(SensorInputError) as err:
        scan_points(np.ones(360), **args)
    assert err.value.reason == "malformed"


def _packed(points: np.ndarray, dtype: str, pad: int = 0) -> tuple[bytes, int, int]:
    rows = np.asarray(points, dtype=dtype)
    width = rows.shape[1]
    data = b"".join(row.tobytes() + b"\0" * pad for row in rows)
    return data, rows.dtype.itemsize * 3, rows.dtype.itemsize * 3 * width + pad


@pytest.mark.parametrize("dtype,fields", [
    ("<f4", XYZ32),
    (">f4", XYZ32),
    ("<f8", [CloudField("x", 0, FLOAT64), CloudField("y", 8, FLOAT64),
             CloudField("z", 16, FLOAT64)]),
])
def test_cloud_points_in_either_byte_order_and_size_with_row_padding(dtype, fields):
    grid = np.arange(2 * 3 * 3, dtype=float).reshape(2, 3, 3) / 10.0
    grid[1, 1] = [math.nan, math.nan, math.nan]  # an organised cloud's missing return
    data, point_step, row_step = _packed(grid, dtype, pad=5)
    out = cloud_points(data, fields, point_step, row_step, width=3, height=2,
                       big_endian=dtype.startswith(">"))
    expected = grid.reshape(-1, 3)[[0, 1, 2, 3, 5]]
    np.testing.assert_allclose(out, expected, rtol=1e-6)


def test_cloud_fields_with_extra_channels_are_read_by_offset():
    pts = np.array([[1.0, 2.0, 3.0, 99.0], [4.0, 5.0, 6.0, 99.0]], dtype="<f4")
    fields = [CloudField("intensity", 12, FLOAT32)] + XYZ32
    out = cloud_points(pts.tobytes(), fields, 16, 32, width=2, height=1)
    np.testing.assert_allclose(out, pts[:, :3])


@pytest.mark.parametrize("case", ["no_z", "int_field", "outside", "short", "row_step"])
def test_malformed_clouds_are_clear_errors(case):
    data, fields, step, row, width = np.zeros(12, "<f4").tobytes(), list(XYZ32), 12, 48, 4
    if case == "no_z":
        fields = fields[:2]
    elif case == "int_field":
        fields[2] = CloudField("z", 8, 5)
    elif case == "outside":
        fields[2] = CloudField("z", 10, FLOAT32)
    elif case == "short":
        data = data[:40]
    elif case == "row_step":
        row = 40
    with pytest.raises(SensorInputError) as err:
        cloud_points(data, fields, step, row, width=width, height=1)
    assert err.value.reason == "malformed"


def test_to_parent_with_one_pose_or_a_pose_per_point():
    p = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    R = rpy_to_matrix(0.0, 0.0, math.pi / 2)
    np.testing.assert_allclose(to_parent(p, R, [1.0, 2.0, 3.0]), [[1, 3, 3], [0, 2, 3]],
                               atol=1e-12)
    Rs = np.stack([np.eye(3), R])
    np.testing.assert_allclose(to_parent(p, Rs, np.zeros((2, 3))), [[1, 0, 0], [-1, 0, 0]],
                               atol=1e-12)


def test_pose_history_interpolates_and_refuses_stamps_outside_it():
    h = PoseHistory(duration=1.0, max_extrapolation=0.05)
    assert h.check(1.0) is PoseLookup.NO_ODOM
    q_yaw = [0.0, 0.0, math.sin(0.25), math.cos(0.25)]  # yaw 0.5 rad
    assert h.add(1.0, [0.0, 0.0, 0.3], [0.0, 0.0, 0.0, 1.0])
    assert h.add(1.1, [1.0, 0.0, 0.3], q_yaw)
    p, R = h.pose_at(1.05)
    np.testing.assert_allclose(p, [0.5, 0.0, 0.3])
    assert math.atan2(R[1, 0], R[0, 0]) == pytest.approx(0.25, abs=2e-3)
    p, _ = h.pose_at(1.13)  # held up to max_extrapolation after the newest
    np.testing.assert_allclose(p, [1.0, 0.0, 0.3])
    assert h.check(0.99) is PoseLookup.BEFORE_HISTORY
    assert h.check(1.16) is PoseLookup.AFTER_HISTORY
    assert h.check(math.nan) is PoseLookup.BEFORE_HISTORY
    with pytest.raises(ValueError, match="after_odom"):
        h.pose_at(1.2)
    assert not h.add(1.05, [0.0, 0.0, 0.0], [0, 0, 0, 1])  # out of order
    assert h.out_of_order == 1
    assert not h.add(1.2, [math.nan, 0.0, 0.0], [0, 0, 0, 1])
    assert not h.add(1.2, [0.0, 0.0, 0.0], [0, 0, 0, 0])
    for k in range(30):  # old poses leave the history
        h.add(1.2 + 0.1 * k, [0.0, 0.0, 0.3], [0, 0, 0, 1])
    assert h.check(1.1) is PoseLookup.BEFORE_HISTORY and len(h) <= 12


def test_a_sensor_frame_goes_through_the_mount_and_the_base_pose():
    mount = SensorMount("depth_link", (0.1, 0.0, 0.2), (0.0, math.radians(20.0), 0.0))
    h = PoseHistory()
    yaw = math.pi / 2
    h.add(5.0, [1.0, 2.0, 0.8], [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
    ahead = np.array([[2.0, 0.0, 0.0]])  # 2 m along the sensor's axis, 20 deg down
    frame = make_frame("cloud", 5.0, ahead, mount.matrix(), h, default_self_box("biped"))
    d = 2.0 * np.array([math.cos(math.radians(20.0)), 0.0, -math.sin(math.radians(20.0))])
    base = np.array([0.1, 0.0, 0.2]) + d
    expected = np.array([1.0 - base[1], 2.0 + base[0], 0.8 + base[2]])  # yawed 90 deg
    np.testing.assert_allclose(frame.points[0], expected, atol=1e-9)
    np.testing.assert_allclose(frame.origin, [1.0, 2.1, 1.0], atol=1e-9)
    with pytest.raises(SensorInputError) as err:
        make_frame("cloud", 5.2, ahead, mount.matrix(), h, default_self_box("biped"))
    assert err.value.reason == "after_odom"


def test_self_boxes_per_robot_kind_and_overrides():
    for kind in ("quadruped", "biped"):
        box = default_self_box(kind)
        for mount in default_mounts(kind).values():
            assert np.all(outside_self_box(np.array([[1.0, 0.0, mount.xyz[2]]]), box))
    assert not outside_self_box(np.zeros((1, 3)), default_self_box("quadruped"))[0]
    box = resolve_self_box("biped", (math.nan,) * 3, (0.5, 0.5, 0.5))
    assert box.lower == default_self_box("biped").lower and box.upper == (0.5, 0.5, 0.5)
    with pytest.raises(ValueError, match="not below"):
        SelfBox((0.0, 0.0, 0.0), (1.0, -1.0, 1.0))
    with pytest.raises(ValueError, match="robot kind"):
        default_self_box("hexapod")
    assert LIDAR_FRAME in default_mounts("biped") and DEPTH_FRAME in default_mounts("biped")
